"""Pictures for the report: display images, a signed difference map, labelled grids.

Display images use the same tone map as the metrics (``metrics.display_values``), so what a
reader sees is what was measured.
"""

from __future__ import annotations

import numpy as np
from PIL import Image, ImageDraw, ImageFont

from .metrics import display_values

DIFFERENCE_FULL_SCALE = 0.2        # tone-mapped difference drawn at full saturation
_RED = np.array([0.84, 0.19, 0.15])
_BLUE = np.array([0.19, 0.39, 0.78])


def to_srgb_uint8(images) -> np.ndarray:
    """Tone-mapped 8-bit sRGB of linear radiance: ``[..., C>=3]`` -> ``[..., 3]`` uint8."""
    return np.round(display_values(images) * 255).astype(np.uint8)


def signed_difference(reference, test, full_scale: float = DIFFERENCE_FULL_SCALE) -> np.ndarray:
    """Where ``test`` is too bright (red) or too dim (blue) against ``reference``.

    ``d`` = mean over RGB of ``tonemap(test) - tonemap(reference)``; a pixel is white blended
    toward red by ``d / full_scale`` (clamped to 1) where ``d > 0`` and toward blue where ``d < 0``.

    Args:
        reference, test: ``[..., H, W, C>=3]`` linear radiance.

    Returns:
        ``[..., H, W, 3]`` uint8.
    """
    d = (display_values(test) - display_values(reference)).mean(axis=-1, keepdims=True)
    weight = np.clip(np.abs(d) / full_scale, 0, 1)
    tint = np.where(d > 0, _RED, _BLUE)
    return np.round(((1 - weight) + weight * tint) * 255).astype(np.uint8)


def _font(size: int) -> ImageFont.ImageFont:
    for name in ("DejaVuSans.ttf", "LiberationSans-Regular.ttf", "Arial.ttf"):
        try:
            return ImageFont.truetype(name, size)
        except OSError:
            continue
    return ImageFont.load_default()


def image_grid(cells: list[list[np.ndarray]], column_labels: list[str], row_labels: list[str] | None = None,
               gap: int = 6, background=(250, 250, 249)) -> Image.Image:
    """A labelled grid of equally sized pictures.

    Args:
        cells: ``rows x columns`` of ``[H, W, 3]`` uint8 pictures, all the same size.
        column_labels: one caption per column, drawn above it.
        row_labels: optional caption per row, drawn at its left.
        gap: pixels between cells; background: RGB of the margins.

    Returns:
        A PIL RGB image.
    """
    h, w = cells[0][0].shape[:2]
    font = _font(max(12, h // 18))
    text_h = font.getbbox("Ag")[3] + 2 * gap
    left = 0 if row_labels is None else max(font.getbbox(t)[2] for t in row_labels) + 2 * gap
    columns = len(column_labels)
    canvas = Image.new("RGB", (left + columns * (w + gap) + gap, text_h + len(cells) * (h + gap) + gap), background)
    draw = ImageDraw.Draw(canvas)
    for c, label in enumerate(column_labels):
        x = left + gap + c * (w + gap) + (w - font.getbbox(label)[2]) // 2
        draw.text((x, gap), label, fill=(40, 40, 40), font=font)
    for r, row in enumerate(cells):
        y = text_h + r * (h + gap)
        if row_labels is not None:
            draw.text((gap, y + (h - text_h) // 2 + gap), row_labels[r], fill=(90, 90, 90), font=font)
        for c, picture in enumerate(row):
            canvas.paste(Image.fromarray(picture), (left + gap + c * (w + gap), y))
    return canvas


def animated_picture(columns: list[np.ndarray], labels: list[str], seconds_per_frame: float) -> list[Image.Image]:
    """The frames of an animated side-by-side comparison: frame ``f`` is the labelled row of
    every column's picture ``f`` (``image_grid``).

    Args:
        columns: per column, ``[F, H, W, 3]`` uint8 pictures, all the same size.
        labels: one caption per column.
        seconds_per_frame: how long each frame shows (kept in each frame's ``info``).
    """
    frames = [image_grid([[column[f] for column in columns]], labels) for f in range(len(columns[0]))]
    for frame in frames:
        frame.info["duration"] = max(round(1000 * seconds_per_frame), 20)
    return frames


def save_animation(frames: list[Image.Image], path) -> None:
    """Write ``frames`` (``animated_picture``) as a looping GIF, each with its own palette."""
    durations = [frame.info["duration"] for frame in frames]
    frames[0].save(path, save_all=True, append_images=frames[1:], duration=durations, loop=0, optimize=False,
                   disposal=1)
