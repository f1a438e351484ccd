"""The chain's own page, ``OUTDIR/report.html`` of ``lookalike lod``: every level at the size it
is drawn at, beside the supersampled reference and the classic level of the same triangles and
texture size (the level run's classic bake, ``lodK/classic.glb``), magnified with
nearest-neighbour scaling so that aliasing shows; a slow orbit per level as an animated GIF
(reference | classic | ours), because flicker is seen in motion; and held-out PSNR against
triangles for both chains.

The stills and the orbits are drawn here: the reference supersampled ``orbit_spp`` per axis,
both levels as an engine draws them (one sample per pixel, trilinear mipmaps at the GPU's
levels), under the orbit's light fixed in the world. A path-traced chain has no orbit (each
frame would be path traced): its page shows the table and the plot, each level's report its
views.
"""

from __future__ import annotations

import html
from pathlib import Path

import numpy as np

from .. import io
from ..asset import Asset
from ..fit.reference import MeshReference, render_in_chunks
from ..fit.textured_mesh import render_asset
from ..io.atomic import write_text_atomic
from ..report.heldout import over_background
from ..report.html import PAGE_CSS
from ..report.pictures import to_srgb_uint8
from ..shading.texturing import ENGINE_FOOTPRINT
from ..shading.view_sampling import orbit_views
from .outputs import MODEL_NAME, REPORT_NAME

CLASSIC_NAME = "classic.glb"
"""A level run's classic bake (decimation, atlas, projection bake at its count and texture size)."""

FILES = "report_files"
ORBIT_FRAMES = 24
ORBIT_DEGREES = 12.0
"""Half a degree a frame: slow enough that what changes between frames is what aliasing adds."""
SHOWN_HEIGHT = 256
"""CSS pixels a level's pictures are shown at, magnified by an integer factor, nearest neighbour."""
REFERENCE_SAMPLES = 2048
"""The orbit's reference takes ``REFERENCE_SAMPLES / pixels`` samples per axis (2 to 8): 8 x 8
at the small levels where aliasing is, 4 x 4 at 512 pixels, where the frames are big."""


def orbit_spp(pixels: int) -> int:
    """Samples per axis of the orbit's reference at a level of ``pixels``: ``REFERENCE_SAMPLES /
    pixels`` clamped to [2, 8]."""
    return int(np.clip(REFERENCE_SAMPLES // pixels, 2, 8))


def level_frames(reference: MeshReference, models: dict[str, Asset], resolution: int,
                 pixels: int) -> dict[str, np.ndarray]:
    """``{"reference" | name: [F, H, W, 3] uint8 sRGB}``: the orbit (``orbit_views``) drawn by
    the reference at ``orbit_spp(pixels)`` per axis and by each of ``models`` as an engine draws it."""
    centre, radius = reference.bounding_sphere()
    camera, light = orbit_views(centre, radius, ORBIT_FRAMES, ORBIT_DEGREES)
    frames = {"reference": render_in_chunks(reference, camera, light, resolution, orbit_spp(pixels))}
    for name, model in models.items():
        frames[name] = render_asset(model, camera, light, resolution=resolution, msaa=1, footprint=ENGINE_FOOTPRINT)
    return {name: to_srgb_uint8(over_background(rgba)) for name, rgba in frames.items()}


def write_level_pictures(frames: dict[str, np.ndarray], files: Path, k: int) -> dict[str, str]:
    """Write level ``k``'s first orbit frame per column as a PNG and the orbit as one looping GIF
    (the columns side by side, 2 pixels apart); returns ``{role: path relative to the page}``."""
    from PIL import Image

    paths = {}
    for name, pictures in frames.items():
        paths[name] = f"{FILES}/lod{k}_{name}.png"
        Image.fromarray(pictures[0]).save(files.parent / paths[name])
    count, height = frames["reference"].shape[:2]
    gap = np.full((count, height, 2, 3), 255, np.uint8)
    strip = np.concatenate([part for name in frames for part in (frames[name], gap)][:-1], axis=2)
    images = [Image.fromarray(frame) for frame in strip]
    paths["orbit"] = f"{FILES}/lod{k}_orbit.gif"
    images[0].save(files.parent / paths["orbit"], save_all=True, append_images=images[1:], duration=80, loop=0)
    return paths


def plot_chains(rows: list[dict], path: Path) -> None:
    """Held-out PSNR against triangles (log) of ours and the classic chain, each point labelled
    with its level's size, as a PNG."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.ticker import NullFormatter

    fig, ax = plt.subplots(figsize=(6, 3.4), dpi=150)
    try:
        triangles = [row["triangles"] for row in rows]
        ax.plot(triangles, [row["classic"]["psnr"] for row in rows], marker="o", color="#9a9ea5", label="classic chain")
        ax.plot(triangles, [row["psnr"] for row in rows], marker="o", color="#1f4e8c", label="ours")
        for row in rows:
            ax.annotate(f"{row['pixels']} px", (row["triangles"], row["psnr"]), textcoords="offset points",
                        xytext=(4, 6), fontsize=8, color="#62666d")
        ax.set_xscale("log")
        ax.set_xticks(triangles, [f"{count:,}" for count in triangles])
        ax.xaxis.set_minor_formatter(NullFormatter())
        ax.set_xlabel("triangles")
        ax.set_ylabel("held-out PSNR (dB) at the level's size")
        ax.grid(True, color="#e3e3e3", linewidth=0.8)
        ax.legend(frameon=False)
        fig.tight_layout()
        fig.savefig(path)
    finally:
        plt.close(fig)


def write_chain_page(outdir: Path, asset: Asset, rows: list[dict], resolutions: list[int],
                     path_traced: bool) -> Path:
    """Write ``outdir/report.html`` for the chain ``rows`` (``lods.json``'s levels, each with
    the held-out scores of its run's classic bake, ``"classic"``) fitted from ``asset`` (as the
    runs saw it), the levels' pictures at ``resolutions``; returns its path."""
    files = outdir / FILES
    files.mkdir(exist_ok=True)
    plot_chains(rows, files / "psnr_triangles.png")
    reference = None if path_traced else MeshReference(asset)
    sections = []
    for row, resolution in zip(rows, resolutions):
        folder = outdir / row["folder"]
        scale = max(1, SHOWN_HEIGHT // resolution)
        figures = ""
        if reference is not None and (folder / CLASSIC_NAME).is_file():
            models = {"classic": io.load(folder / CLASSIC_NAME), "ours": io.load(folder / MODEL_NAME)}
            paths = write_level_pictures(level_frames(reference, models, resolution, row["pixels"]), files,
                                         row["level"])
            size = f'width="{resolution * scale}"'
            figures = "".join(f'<figure><img src="{paths[key]}" {size} alt="{label}"><figcaption>{label}</figcaption>'
                              f'</figure>' for key, label in (("reference", f"Reference, {orbit_spp(row['pixels'])}"
                                                               f"&times;{orbit_spp(row['pixels'])} spp"),
                                                              ("classic", "Classic level"), ("ours", "Ours")))
            figures += (f'<figure><img src="{paths["orbit"]}" width="{(3 * resolution + 4) * scale}" alt="orbit">'
                        f'<figcaption>A slow orbit: reference | classic | ours</figcaption></figure>')
        sections.append(f'<section><h2>Level {row["level"]}: {row["triangles"]:,} triangles at {row["pixels"]} px '
                        f'(shown {scale}&times;)</h2><div class="pictures">{figures}</div>'
                        f'<p><a href="{row["folder"]}/{REPORT_NAME}">its report</a></p></section>')
    cells = "".join(f"<tr><td>{row['level']}</td><td>{row['triangles']:,}</td><td>{row['pixels']}</td>"
                    f"<td>{row['texture_size']}</td><td>{row['switch_distance']:.3g}</td>"
                    f"<td>{row['classic']['psnr']:.2f}</td><td><b>{row['psnr']:.2f}</b></td>"
                    f"<td>{row['classic']['flip']:.4f}</td><td><b>{row['flip']:.4f}</b></td>"
                    f"<td>{row['file_bytes'] / 1024:,.0f}</td><td>{row['gpu_bytes']['total'] / 1024:,.0f}</td>"
                    f"<td>{_compressed_cells(row)}</td></tr>" for row in rows)
    page = (f"<!doctype html><html><head><meta charset='utf-8'><title>{html.escape(asset.name)}: levels of detail"
            f"</title><style>{PAGE_CSS} .pictures {{ display:flex; flex-wrap:wrap; gap:12px; }} "
            f".pictures img {{ image-rendering:pixelated; }} figure {{ margin:0; }}</style></head><body><main>"
            f"<h1>{html.escape(asset.name)}: a chain of {len(rows)} levels</h1>"
            f"<table><thead><tr><th>level</th><th>triangles</th><th>px</th><th>texels</th><th>switch distance</th>"
            f"<th>PSNR classic</th><th>PSNR ours</th><th>FLIP classic</th><th>FLIP ours</th><th>KB</th>"
            f"<th>GPU KB</th><th>compressed KB / PSNR</th></tr></thead><tbody>{cells}</tbody></table>"
            f"<p><img src='{FILES}/psnr_triangles.png' width='600' alt='PSNR against triangles'></p>"
            f"{''.join(sections)}</main></body></html>")
    write_text_atomic(outdir / REPORT_NAME, page)
    return outdir / REPORT_NAME


def _compressed_cells(row: dict) -> str:
    """``"KB / PSNR"`` of a level's compressed file, or a dash."""
    compressed = row.get("compressed")
    return "&mdash;" if compressed is None else f"{compressed['file_bytes'] / 1024:,.0f} / {compressed['psnr']:.2f}"
