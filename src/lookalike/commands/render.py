"""``lookalike render INPUT -o DIR``: pictures of an asset from random views around its
bounding sphere, each lit by a random point light (``lookalike.shading.view_sampling``), as PNGs
``view_000.png`` ... plus a contact sheet ``sheet.png``.

Tone mapping: linear radiance is clamped to [0, 1] and sRGB-encoded; alpha is kept (the
colour is stored un-premultiplied, as PNG wants). The sheet shows every view over grey.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

from ..errors import ConfigError
from ..limits import MAX_LAYERS, MAX_RESOLUTION, MAX_SPP, MAX_VIEWS

HELP = "render PNG pictures of an asset from random views with a point light"

SHEET_BACKGROUND = 0.5
"""Grey (sRGB-encoded value) behind the views on the contact sheet."""


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("input", type=Path, help="asset file (.gltf, .glb, .obj, .ply)")
    parser.add_argument("-o", "--output", type=Path, required=True, help="folder for the pictures")
    parser.add_argument("--views", type=int, default=8, help=f"number of views (default 8, at most {MAX_VIEWS})")
    parser.add_argument("--resolution", type=int, default=512,
                        help=f"picture size in pixels (default 512, at most {MAX_RESOLUTION})")
    parser.add_argument("--spp", type=int, default=2, help=f"supersampling factor per axis (default 2, at most {MAX_SPP})")
    parser.add_argument("--layers", type=int, default=None,
                        help="depth-peeled layers (default: 4 when a material blends, else 2, so that "
                             f"culled back faces and alpha cut-outs show what lies behind them; at most {MAX_LAYERS})")
    parser.add_argument("--seed", type=int, default=0, help="random seed of the views (default 0)")
    parser.add_argument("--force", action="store_true", help="overwrite existing pictures")


def output_paths(folder: Path, views: int) -> list[Path]:
    """The files the command writes: one PNG per view, then the contact sheet."""
    return [folder / f"view_{i:03d}.png" for i in range(views)] + [folder / "sheet.png"]


def tone_map(image):
    """``[H, W, 4]`` linear RGB (over black) + alpha, torch -> ``[H, W, 4]`` float32 NumPy in
    [0, 1]: colour un-premultiplied, clamped, sRGB-encoded; alpha as is."""
    import numpy as np

    from ..io.image_files import linear_to_srgb

    rgba = image.detach().cpu().double().numpy()
    alpha = rgba[..., 3:4].clip(0.0, 1.0)
    colour = np.where(alpha > 0, rgba[..., :3] / np.maximum(alpha, 1e-12), 0.0)
    return np.concatenate([linear_to_srgb(colour.clip(0.0, 1.0)), alpha], axis=-1).astype(np.float32)


def contact_sheet(pictures):
    """Tone-mapped ``[H, W, 4]`` pictures composited over grey on a grid of
    ``ceil(sqrt(n))`` columns -> ``[rows H, columns W, 3]``."""
    import numpy as np

    columns = math.ceil(math.sqrt(len(pictures)))
    rows = math.ceil(len(pictures) / columns)
    height, width = pictures[0].shape[:2]
    sheet = np.full((rows * height, columns * width, 3), SHEET_BACKGROUND, dtype=np.float32)
    for i, picture in enumerate(pictures):
        r, c = divmod(i, columns)
        alpha = picture[..., 3:4]
        tile = sheet[r * height:(r + 1) * height, c * width:(c + 1) * width]
        tile[:] = picture[..., :3] * alpha + tile * (1.0 - alpha)
    return sheet


def run(args: argparse.Namespace) -> int:
    import numpy as np
    import torch

    from .. import io
    from ..io.image_files import write_png
    from ..shading import render
    from ..shading.view_sampling import random_lights, random_views

    for name, most in (("views", MAX_VIEWS), ("resolution", MAX_RESOLUTION), ("spp", MAX_SPP), ("layers", MAX_LAYERS)):
        value = getattr(args, name)
        if value is not None and not 1 <= value <= most:
            raise ConfigError(f"--{name} must lie in [1, {most}], not {value}")
    if args.output.exists() and not args.output.is_dir():
        raise ConfigError(f"{args.output} exists and is not a folder")
    paths = output_paths(args.output, args.views)
    existing = [p for p in paths if p.exists()]
    if existing and not args.force:
        raise ConfigError(f"{existing[0]} exists ({len(existing)} of the pictures do); use --force to overwrite")
    asset = io.load(args.input)
    layers = args.layers or (4 if any(m.alpha_mode == "BLEND" for m in asset.materials) else 2)
    centre, radius = asset.mesh.bounding_sphere()
    generator = np.random.default_rng(args.seed)
    cameras = random_views(centre, radius, args.views, generator)
    lights = random_lights(cameras, centre, generator)
    args.output.mkdir(parents=True, exist_ok=True)
    pictures = []
    with torch.no_grad():
        for i in range(args.views):
            image = render(asset, cameras[i], lights[i], args.resolution, spp=args.spp, layers=layers)
            pictures.append(tone_map(image[0]))
            write_png(pictures[-1], paths[i])
    write_png(contact_sheet(pictures), paths[-1])
    print(f"wrote {args.views} views and {paths[-1].name} to {args.output}")
    return 0
