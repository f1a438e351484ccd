"""``model.compressed.glb``: a written model as an engine ships it.

Every texture becomes a KTX2 mip chain (UASTC, Zstandard; ``io.ktx2``) with no PNG beside it:
its own mip levels where it has them (fitted, prefiltered), else the box filter of the texture
(``render.mipmap.texture_construct_mip``, the mips our renderer and an engine build from a
PNG), so that the GPU samples exactly what was scored. Then gltfpack quantises the geometry
(``KHR_mesh_quantization``) and meshopt-compresses its buffers (``EXT_meshopt_compression``,
``io.meshopt``). The file is read back and scored beside the model it came from, so that what
compression costs is seen.
"""

from __future__ import annotations

import dataclasses
import tempfile
from collections.abc import Callable
from pathlib import Path

from .. import io
from ..asset import Asset, Material, Texture
from ..errors import ConfigError
from ..io.atomic import copy_atomic
from ..io.gltf_lod_chain import relink_lod_chain, write_lod_chain
from ..io.gltf_write import write_glb
from ..io.ktx2 import ENCODER_HINT, find_encoder
from ..io.meshopt import INSTALL_HINT, compress_glb, find_gltfpack
from ..render.mipmap import texture_construct_mip
from ..settings import Config

COMPRESSED_NAME = "model.compressed.glb"

SECONDS_PER_MEGATEXEL = 10.0
"""What writing and reading back a compressed model costs per million texels of its maps'
finest levels (2 cores: three 2048² maps took 50 s to encode with their mips, 77 s to decode)."""


def compress_seconds(cfg: Config) -> float:
    """The seconds a run keeps aside for its compressed model (``io.compress``): base colour,
    specular and normal map (and the emission of a path-traced run) at ``SECONDS_PER_MEGATEXEL``;
    0 where it writes none."""
    maps = 3 + cfg.reference.path_traced
    return SECONDS_PER_MEGATEXEL * maps * cfg.latent.texture_size ** 2 / 1e6 if cfg.io.compress else 0.0


def check_compression_tools() -> None:
    """``ConfigError`` naming what is missing where gltfpack or the KTX2 encoder is not found,
    so that a run asked to compress says so before it fits, not after."""
    if find_gltfpack() is None:
        raise ConfigError(f"--compress needs {INSTALL_HINT}")
    if find_encoder() is None:
        raise ConfigError(f"--compress needs {ENCODER_HINT}")


def with_mips(texture: Texture) -> Texture:
    """``texture`` with mip levels: its own, else the box filter of its texels (a 1 x 1
    texture, written as a factor, has none)."""
    if texture.mips or texture.data.shape[0] * texture.data.shape[1] == 1:
        return texture
    return dataclasses.replace(texture, mips=[level[0] for level in texture_construct_mip(texture.data[None])])


def with_mip_chains(asset: Asset) -> Asset:
    """``asset`` with every texture of every material given mip levels (``with_mips``)."""
    def material(m: Material) -> Material:
        maps = {name: with_mips(getattr(m, name)) for name in ("kd", "ks", "normal", "emissive", "occlusion")
                if getattr(m, name) is not None}
        return dataclasses.replace(m, **maps)

    return dataclasses.replace(asset, materials=[material(m) for m in asset.materials])


def shipped(write_ktx2: Callable[[Path], None], target: Path,
            finish: Callable[[Path], None] | None = None) -> Path:
    """``target`` written by ``write_ktx2`` (given a scratch ``.glb`` path to write with KTX2-only
    textures), then meshopt-compressed by gltfpack and given to ``finish`` (to edit in place),
    all in a scratch folder: ``target`` appears complete or not at all, whichever tool fails or
    hangs. Returns ``target``."""
    with tempfile.TemporaryDirectory(prefix="lookalike-compress-") as scratch:
        textured, packed = Path(scratch) / target.name, Path(scratch) / "packed" / target.name
        write_ktx2(textured)
        packed.parent.mkdir()
        compress_glb(textured, packed)
        if finish is not None:
            finish(packed)
        copy_atomic(packed, target)
    return target


def write_compressed(model: Path, target: Path) -> Path:
    """Write the ``.glb`` at ``model`` to ``target`` as an engine ships it (see the module
    docstring); returns ``target``. ``ConfigError`` where a tool is missing or fails,
    ``ExternalToolTimeout`` where one hangs; ``target`` is then not written."""
    return shipped(lambda path: write_glb(with_mip_chains(io.load(model)), path, ktx2_only=True), target)


def write_compressed_chain(models: list[Path], target: Path, name: str, coverages: list[float]) -> Path:
    """Write the chain of the ``.glb`` files ``models`` (finest first) as ``lods.glb`` is written
    (``io.gltf_lod_chain``), shipped as ``write_compressed`` ships one model, to ``target``;
    returns ``target``."""
    levels = [with_mip_chains(io.load(model)) for model in models]
    return shipped(lambda path: write_lod_chain(levels, path, name, coverages, ktx2_only=True), target,
                   finish=relink_lod_chain)
