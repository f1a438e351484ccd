"""``lookalike convert INPUT OUTPUT``: read an asset in any readable format (.gltf, .glb, .obj,
.ply) and write it as ``.glb`` or ``.obj`` (+ .mtl + PNGs). Refuses to overwrite an existing
OUTPUT unless ``--force``. ``--atlas SIZE`` first merges all materials into one material with a
``SIZE x SIZE`` texture atlas (``lookalike.init.atlas``). The geometry is not changed, so the
input's normals (hard edges included) are written as they were read."""

from __future__ import annotations

import argparse
from pathlib import Path

from ..errors import ConfigError
from ..limits import MAX_BAKE_TEXTURE_SIZE

HELP = "convert an asset to .glb or .obj (optionally merging its materials into one atlas)"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("input", type=Path, help="asset file (.gltf, .glb, .obj, .ply)")
    parser.add_argument("output", type=Path, help="file to write (.glb or .obj)")
    parser.add_argument("--force", action="store_true", help="overwrite OUTPUT if it exists")
    parser.add_argument("--atlas", type=int, default=None, metavar="SIZE",
                        help=f"merge all materials into one with a SIZE x SIZE texture atlas (at most {MAX_BAKE_TEXTURE_SIZE})")


def run(args: argparse.Namespace) -> int:
    from ..io import load, save, writable_extensions

    if args.output.suffix.lower() not in writable_extensions():
        raise ConfigError(f"cannot write {args.output.suffix or 'files without extension'!r}: "
                          f"OUTPUT must end in one of {', '.join(writable_extensions())}")
    if args.output.exists() and not args.force:
        raise ConfigError(f"{args.output} exists; pass --force to overwrite it")
    if args.atlas is not None and not 8 <= args.atlas <= MAX_BAKE_TEXTURE_SIZE:
        raise ConfigError(f"--atlas must lie in [8, {MAX_BAKE_TEXTURE_SIZE}] texels, not {args.atlas}")
    if not args.output.parent.is_dir():
        raise ConfigError(f"the folder of {args.output} does not exist")
    asset = load(args.input)
    if args.atlas is not None:
        from ..init.atlas import merge_materials

        asset = merge_materials(asset, args.atlas)
    save(asset, args.output)
    skin = f", skin with {len(asset.skin.joints)} joints, {len(asset.animations)} animation(s)" if asset.skin else ""
    print(f"{args.input} -> {args.output}: {asset.mesh.num_triangles} triangles, {len(asset.materials)} material(s)"
          + skin)
    return 0
