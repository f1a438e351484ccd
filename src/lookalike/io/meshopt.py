"""Quantised, meshopt-compressed glTF geometry through ``gltfpack`` (meshoptimizer's).

Why: an engine-ready file is small. ``KHR_mesh_quantization`` stores positions, normals,
tangents and UVs as 8- and 16-bit integers (positions on a grid of 2^14 steps across the
model, dequantised by the node's scale and offset, UVs by a ``KHR_texture_transform``), and
``EXT_meshopt_compression`` entropy-codes the buffers so that a GPU-side decoder restores them
at load time; three.js, Babylon.js, Unity's glTFast and Godot read both.

``gltfpack`` is the maintained encoder (npm ``gltfpack``; its node build carries no texture
compressor, so KTX2 textures are made beforehand, ``io.ktx2``, and passed through as they are).
It also reads such files: ``decompress_glb`` asks it for the same file without compression or
quantisation (``-noq``), the dequantising node transforms and texture transforms kept, which
is what the glTF reader then reads. Every run of gltfpack has a deadline scaled to the file's
triangles (``lookalike.external_tools``).
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path

from ..errors import ConfigError
from ..external_tools import run_tool
from .gltf_data import triangle_count

GLTFPACK_ENVIRONMENT = "LOOKALIKE_GLTFPACK"
"""Names the ``gltfpack`` executable (or the npm package's ``cli.js``) where it is not on ``PATH``."""

INSTALL_HINT = (f"meshoptimizer's gltfpack: npm install --prefix ~/.lookalike gltfpack@1.3.0 and point "
                f"{GLTFPACK_ENVIRONMENT} at ~/.lookalike/node_modules/gltfpack/cli.js (or put gltfpack on PATH)")

GLTFPACK_BASE_S = 30.0
"""Seconds a run of gltfpack may take besides its triangles (starting it, under node where it is
the npm package's, on a busy machine)."""

GLTFPACK_SECONDS_PER_TRIANGLE = 2e-5
"""Seconds a run of gltfpack may take per triangle of its input: about twenty times what it takes."""

KEEP = ("-kn", "-km", "-ke", "-af", "0", "-ac")
"""Keep named nodes (the chain's ``NAME_LODk``, a skin's joints), named materials, extras
(a displacement map's parameters) and every animation sample as it is (no resampling)."""


def find_gltfpack() -> list[str] | None:
    """The command that runs ``gltfpack``: ``$LOOKALIKE_GLTFPACK`` (a ``.js`` file runs under
    ``node``), else ``gltfpack`` on ``PATH``; ``None`` where there is none."""
    named = os.environ.get(GLTFPACK_ENVIRONMENT)
    if named:
        if not Path(named).is_file():
            return None
        if named.endswith(".js"):
            node = shutil.which("node")
            return [node, named] if node else None
        return [named]
    found = shutil.which("gltfpack")
    return [found] if found else None


def gltfpack_deadline(triangles: int) -> float:
    """``GLTFPACK_BASE_S + GLTFPACK_SECONDS_PER_TRIANGLE * triangles``: how long a run of
    gltfpack on ``triangles`` may take."""
    return GLTFPACK_BASE_S + GLTFPACK_SECONDS_PER_TRIANGLE * triangles


def _gltfpack(source: Path, arguments: list[str], task: str) -> None:
    """Run ``gltfpack -i source arguments`` for ``task`` (words for the error, e.g. "compressing
    a.glb") within ``gltfpack_deadline`` of ``source``'s triangles; ``ConfigError`` saying what
    is missing, or with gltfpack's own message; ``ExternalToolTimeout`` where it hangs."""
    command = find_gltfpack()
    if command is None:
        raise ConfigError(f"{task} needs {INSTALL_HINT}")
    result = run_tool([*command, "-i", str(source), *arguments], tool="gltfpack", subject=Path(source).name,
                      deadline=gltfpack_deadline(triangle_count(source)))
    if result.returncode != 0:
        tail = (result.stderr or result.stdout).strip().splitlines()[-1:] or ["no output"]
        raise ConfigError(f"{task}: gltfpack failed ({tail[0]})")


def compress_glb(source: Path, target: Path) -> None:
    """Write ``source`` (a ``.glb``) to ``target`` quantised (``KHR_mesh_quantization``) and
    meshopt-compressed (``EXT_meshopt_compression``, gltfpack's ``-cc``), its images as they
    are; ``ConfigError`` where gltfpack is missing or fails, ``ExternalToolTimeout`` where it hangs."""
    _gltfpack(source, ["-o", str(target), "-cc", *KEEP], f"compressing the geometry of {source}")


def decompress_glb(source: Path, target: Path) -> None:
    """Write ``source`` (a ``.glb`` or ``.gltf`` using ``EXT_meshopt_compression``) to
    ``target`` as plain float buffers (gltfpack's ``-noq``), the dequantising transforms kept;
    ``ConfigError`` where gltfpack is missing or fails, ``ExternalToolTimeout`` where it hangs."""
    _gltfpack(source, ["-o", str(target), "-noq", *KEEP], "decoding its EXT_meshopt_compression")
