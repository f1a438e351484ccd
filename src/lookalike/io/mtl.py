"""Wavefront MTL material libraries, read into and written from ``Material``s.

Read statements: ``Kd``/``map_Kd`` (sRGB; the map replaces ``Kd``, as Blender does), ``d``,
``Tr`` (``d = 1 - Tr``), ``map_d``, ``Pr``/``map_Pr`` (roughness), ``Pm``/``map_Pm``
(metalness), ``Ns`` (roughness ``1 - sqrt(Ns / 1000)`` where ``Pr`` is absent, Blender's mapping),
``Ke``/``map_Ke`` (emission), ``bump``/``map_Bump``/``norm`` (tangent-space normal map, MikkTSpace
with +Y up; ``-bm`` scales x and y). With ``bsdf pbr`` (nvdiffmodeling's convention) ``Ks`` and
``map_Ks`` hold ``(gamma, roughness, metalness)`` directly. Map statements may carry options
(``-bm 2 -s 1 1 1 file.png``); options other than ``-bm`` are ignored.

A material is ``BLEND`` when its alpha is below 1 anywhere, else ``OPAQUE``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import torch

from ..asset import Material, Texture
from ..errors import AssetError
from .arrays import constant_texel
from .image_files import linear_to_srgb, read_image, resize, srgb_to_linear, write_png

# Map options taking up to this many numbers, and options taking one word.
_NUMERIC_OPTIONS = {"-bm": 1, "-boost": 1, "-mm": 2, "-o": 3, "-s": 3, "-t": 3, "-texres": 1}
_WORD_OPTIONS = frozenset({"-blendu", "-blendv", "-clamp", "-imfchan", "-type", "-cc"})


def _is_number(token: str) -> bool:
    try:
        float(token)
    except ValueError:
        return False
    return True


def _split_map(args: list[str]) -> tuple[str, dict[str, list[str]]]:
    """``(file name, {option: arguments})`` of a map statement's arguments; the file name is
    whatever follows the options (it may contain spaces)."""
    options, i = {}, 0
    while i < len(args) - 1 and (args[i] in _NUMERIC_OPTIONS or args[i] in _WORD_OPTIONS):
        name, i = args[i], i + 1
        if name in _WORD_OPTIONS:
            options[name], i = [args[i]], i + 1
            continue
        values = []
        while i < len(args) - 1 and len(values) < _NUMERIC_OPTIONS[name] and _is_number(args[i]):
            values.append(args[i])
            i += 1
        options[name] = values
    return " ".join(args[i:]), options


class _MaterialStatements:
    """Statements of one ``newmtl`` block: scalar/colour values and map files."""

    def __init__(self, name: str):
        self.name = name
        self.values: dict[str, list[float]] = {}
        self.maps: dict[str, tuple[str, dict]] = {}
        self.pbr_ks = False


def parse_mtl(path: Path) -> list[_MaterialStatements]:
    """Statements of every material in an MTL file, in file order."""
    try:
        text = path.read_text(errors="replace")
    except OSError as e:
        raise AssetError(path, f"cannot read material library: {e.strerror or e}") from None
    blocks: list[_MaterialStatements] = []
    for line_no, line in enumerate(text.splitlines(), 1):
        tokens = line.split("#", 1)[0].split()
        if not tokens:
            continue
        key, args = tokens[0], tokens[1:]
        if key == "newmtl":
            blocks.append(_MaterialStatements(" ".join(args) or f"material{len(blocks)}"))
            continue
        if not blocks:
            continue
        block = blocks[-1]
        lowered = key.lower()
        if lowered.startswith("map_") or lowered in ("bump", "norm", "disp", "refl"):
            file, options = _split_map(args)
            block.maps["map_bump" if lowered in ("bump", "norm") else lowered] = (file, options)
        elif lowered == "bsdf":
            block.pbr_ks = args[:1] == ["pbr"]
        else:
            try:
                block.values[lowered] = [float(a) for a in args]
            except ValueError:
                if lowered in ("kd", "ks", "ke", "d", "tr", "pr", "pm", "ns"):
                    raise AssetError(path, f"line {line_no}: cannot parse {line.strip()!r}") from None
    return blocks


def _map(block: _MaterialStatements, key: str, base: Path) -> tuple[np.ndarray, dict] | None:
    """``([H, W, 4] raw pixels, options)`` of a map statement, or ``None``; a missing image is an
    ``AssetError`` naming the MTL file."""
    if key not in block.maps:
        return None
    file, options = block.maps[key]
    image = base.parent / file.replace("\\", "/")
    if not image.is_file():
        raise AssetError(base, f"material {block.name!r}: texture '{file}' is missing (looked for {image})")
    return read_image(image), options


def _scalar_map(block, key: str, base: Path, default: float) -> np.ndarray:
    """``[H, W]`` values of map ``key`` (its first channel, or alpha where the image has one), or
    ``[1, 1]`` holding the scalar statement (``map_pr`` -> ``Pr``) or ``default``."""
    value = block.values.get(key[4:] if key.startswith("map_") else key, [default])[0]
    mapped = _map(block, key, base)
    if mapped is None:
        return np.full((1, 1), value, np.float32)
    pixels = mapped[0]
    return (pixels[..., 0] if np.all(pixels[..., 3] == 1.0) else pixels[..., 3]).astype(np.float32)


def _common_size(*arrays: np.ndarray) -> list[np.ndarray]:
    """Resample ``[H, W(, C)]`` arrays to the largest of their sizes (1x1 ones broadcast)."""
    h = max(a.shape[0] for a in arrays)
    w = max(a.shape[1] for a in arrays)
    out = []
    for a in arrays:
        a3 = a if a.ndim == 3 else a[..., None]
        a3 = np.broadcast_to(a3, (h, w, a3.shape[-1])) if a3.shape[:2] == (1, 1) else resize(a3, h, w)
        out.append(np.ascontiguousarray(a3 if a.ndim == 3 else a3[..., 0], dtype=np.float32))
    return out


def _tex(array: np.ndarray) -> Texture:
    return Texture(torch.from_numpy(np.ascontiguousarray(array, dtype=np.float32)))


def material_from_statements(block: _MaterialStatements, base: Path) -> Material:
    """A ``Material`` from one MTL block (see the module docstring for the mapping)."""
    kd_map = _map(block, "map_kd", base)
    if kd_map is not None:
        rgb = srgb_to_linear(kd_map[0][..., :3])
    else:
        rgb = np.asarray(block.values.get("kd", [0.75, 0.72, 0.68])[:3], np.float32).reshape(1, 1, 3)
    if "d" in block.values or "tr" not in block.values:
        opacity = block.values.get("d", [1.0])[0]
    else:
        opacity = 1.0 - block.values["tr"][0]
    alpha_map = _map(block, "map_d", base)
    alpha = np.full((1, 1), opacity, np.float32)
    if alpha_map is not None:
        px = alpha_map[0]
        alpha = opacity * (px[..., 0] if np.all(px[..., 3] == 1.0) else px[..., 3])
    rgb, alpha = _common_size(rgb, alpha)
    kd = np.concatenate([rgb, alpha[..., None]], axis=-1)

    if block.pbr_ks:
        ks_map = _map(block, "map_ks", base)
        ks = ks_map[0][..., :3] if ks_map is not None else \
            np.asarray(block.values.get("ks", [0.0, 0.45, 0.0])[:3], np.float32).reshape(1, 1, 3)
    else:
        default_rough = 1.0 - np.sqrt(np.clip(block.values["ns"][0], 0, 1000) / 1000.0) if "ns" in block.values \
            else 0.45
        rough = _scalar_map(block, "map_pr", base, default_rough)
        metal = _scalar_map(block, "map_pm", base, 0.0)
        rough, metal = _common_size(rough, metal)
        ks = np.stack([np.zeros_like(rough), rough, metal], axis=-1)

    normal = None
    bump = _map(block, "map_bump", base)
    if bump is not None:
        pixels, options = bump
        scale = float(options.get("-bm", ["1"])[0])
        n = pixels[..., :3] * 2.0 - 1.0
        n[..., :2] *= scale
        normal = _tex(n / np.maximum(np.linalg.norm(n, axis=-1, keepdims=True), 1e-12))

    emissive = None
    ke_map = _map(block, "map_ke", base)
    ke = np.asarray(block.values.get("ke", [1.0, 1.0, 1.0] if ke_map is not None else [0, 0, 0])[:3], np.float32)
    if ke_map is not None:
        emissive = _tex(srgb_to_linear(ke_map[0][..., :3]) * ke)
    elif ke.any():
        emissive = Texture.constant(ke)
    return Material(name=block.name, kd=_tex(kd), ks=_tex(ks), normal=normal,
                    alpha_mode="BLEND" if float(alpha.min()) < 1.0 else "OPAQUE", emissive=emissive)


def read_mtl(path: Path) -> dict[str, Material]:
    """Materials of an MTL file by name."""
    return {block.name: material_from_statements(block, path) for block in parse_mtl(path)}


def write_mtl(materials: list[Material], names: list[str], path: Path) -> None:
    """Write ``materials`` (with unique ``names``) to the MTL file ``path``, textures as PNGs next to
    it named ``<stem>_<material>_<channel>.png``. Constant channels become ``Kd``/``d``/``Pr``/
    ``Pm``/``Ke`` statements; ``gamma`` is not representable in MTL and is dropped (a warning is
    the caller's business). Normal maps are written as given (the caller converts the frame)."""
    lines = [f"# written by lookalike: {len(materials)} material(s)"]
    for material, name in zip(materials, names):
        lines += ["", f"newmtl {name}"]

        def image(channel: str, pixels: np.ndarray) -> str:
            file = f"{path.stem}_{name}_{channel}.png"
            write_png(pixels, path.parent / file)
            return file

        kd = constant_texel(material.kd)
        if kd is not None:
            lines += [f"Kd {kd[0]:.6g} {kd[1]:.6g} {kd[2]:.6g}", f"d {kd[3]:.6g}"]
        else:
            data = material.kd.data.detach().cpu().numpy()
            lines.append("Kd 1 1 1")
            lines.append(f"map_Kd {image('basecolor', linear_to_srgb(data[..., :3]))}")
            if not np.all(data[..., 3] == 1.0):
                lines.append(f"map_d {image('alpha', data[..., 3:4])}")
        ks = constant_texel(material.ks)
        if ks is not None:
            lines += [f"Pr {ks[1]:.6g}", f"Pm {ks[2]:.6g}"]
        else:
            data = material.ks.data.detach().cpu().numpy()
            lines += [f"map_Pr {image('roughness', data[..., 1:2])}", f"map_Pm {image('metalness', data[..., 2:3])}"]
        if material.normal is not None:
            lines.append(f"map_Bump {image('normal', material.normal.data.detach().cpu().numpy() * 0.5 + 0.5)}")
        if material.emissive is not None:
            ke = constant_texel(material.emissive)
            if ke is not None:
                lines.append(f"Ke {ke[0]:.6g} {ke[1]:.6g} {ke[2]:.6g}")
            else:
                data = np.clip(material.emissive.data.detach().cpu().numpy(), 0, None)
                scale = max(float(data.max()), 1.0)  # Ke multiplies the map: emission above 1 survives
                lines += [f"Ke {scale:.6g} {scale:.6g} {scale:.6g}",
                          f"map_Ke {image('emissive', linear_to_srgb(data / scale))}"]
    try:
        path.write_text("\n".join(lines) + "\n")
    except OSError as e:
        raise AssetError(path, f"cannot write material library: {e.strerror or e}") from None

