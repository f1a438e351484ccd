"""The loss curve of a run, and its validation scores, as a PNG (matplotlib, drawn off-screen)."""

from __future__ import annotations

from pathlib import Path

import numpy as np


def smooth(values: np.ndarray, fraction: float = 0.02) -> np.ndarray:
    """Exponential moving average of ``values [N]`` with a time constant of ``fraction * N``
    steps (at least 1), bias-corrected so the first values are not pulled toward 0:
    ``s_t = (sum_k (1 - a)^(t-k) a v_k) / (1 - (1 - a)^(t+1))``, ``a = 1 / (1 + fraction * N)``."""
    from scipy.signal import lfilter

    values = np.asarray(values, dtype=np.float64)
    alpha = 1.0 / (1.0 + max(1.0, fraction * len(values)))
    running = lfilter([alpha], [1.0, alpha - 1.0], values)
    return running / (1 - (1 - alpha) ** np.arange(1, len(values) + 1))


def _minor_label(value: float, _position) -> str:
    """Label the minor log ticks 2 and 5 of each decade, leave the rest bare."""
    leading = round(value / 10 ** np.floor(np.log10(value)))
    return f"{value:g}" if leading in (2, 5) else ""


def plot_loss(history, path: str | Path, title: str = "Training loss", validation=None,
              validation_metric: str = "PSNR") -> Path:
    """Write the loss curve: raw loss per iteration (light) under its smoothed curve, log y;
    with ``validation``, its scores on a second axis at the right.

    Args:
        history: ``[N]`` loss per iteration (non-positive values are dropped from the log plot).
        path: the PNG to write.
        validation: optional ``[K, 2]`` (iteration, score in dB) scorings on validation views.
        validation_metric: what those scores are (e.g. ``"PSNR"``).

    Returns:
        ``path``.
    """
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.ticker import FuncFormatter, MaxNLocator

    path = Path(path)
    values = np.asarray(history, dtype=np.float64)
    steps = np.arange(1, len(values) + 1)
    fig, ax = plt.subplots(figsize=(8, 3.6), dpi=150)
    try:
        ax.plot(steps, values, color="#9bb7d4", linewidth=0.8, alpha=0.7, label="per iteration")
        if len(values) > 2:
            ax.plot(steps, smooth(values), color="#1f4e8c", linewidth=2.0, label="smoothed")
        if (values > 0).any():
            ax.set_yscale("log")
            ax.yaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
            ax.yaxis.set_minor_formatter(FuncFormatter(_minor_label))
        ax.set_xlabel("iteration")
        ax.set_ylabel("loss")
        ax.set_title(title, loc="left", fontsize=12, color="#222222")
        ax.grid(True, which="major", color="#e3e3e3", linewidth=0.8)
        ax.grid(True, which="minor", color="#f1f1f1", linewidth=0.5)
        for side in ("top", "right"):
            ax.spines[side].set_visible(False)
        for side in ("left", "bottom"):
            ax.spines[side].set_color("#bbbbbb")
        ax.tick_params(which="both", colors="#555555", labelsize=9)
        handles, labels = ax.get_legend_handles_labels()
        legend_axes = ax
        if validation is not None and len(validation):
            points = np.asarray(validation, dtype=np.float64).reshape(-1, 2)
            right = ax.twinx()
            label = f"validation {validation_metric} (dB)"
            right.plot(points[:, 0], points[:, 1], color="#c0562b", linewidth=1.6, marker="o", markersize=2.5,
                       label=label)
            right.set_ylabel(label, color="#c0562b")
            right.tick_params(colors="#c0562b", labelsize=9)
            for side in ("top", "left"):
                right.spines[side].set_visible(False)
            more_handles, more_labels = right.get_legend_handles_labels()
            handles, labels = handles + more_handles, labels + more_labels
            legend_axes = right  # drawn last, so the legend's box covers the curves under it
        legend_axes.legend(handles, labels, fontsize=9, loc="lower right", frameon=True, framealpha=0.9,
                           edgecolor="none")
        ax.set_xlim(1, max(2, len(values)))
        ax.xaxis.set_major_locator(MaxNLocator(integer=True))
        fig.tight_layout()
        fig.savefig(path, facecolor="white")
    finally:
        plt.close(fig)
    return path


def plot_levels(rows: list[dict], path: str | Path) -> Path:
    """Write held-out PSNR against triangles (left) and against file bytes (right), log x, for
    ``rows`` (one per level: ``triangles``, ``bytes``, ``psnr`` of ours and ``bake_triangles``,
    ``bake_bytes``, ``bake_psnr`` of the classic bake at that count, where scored): what one
    base mesh with one set of maps buys against a mesh for each count."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    path = Path(path)
    fig, axes = plt.subplots(1, 2, figsize=(8, 3.2), dpi=150, sharey=True)
    try:
        for ax, x in zip(axes, ("triangles", "bytes")):
            for prefix, label, colour in (("", "ours", "#1f4e8c"), ("bake_", "classic bake", "#c0562b")):
                points = [(row[prefix + x], row[prefix + "psnr"]) for row in rows
                          if row.get(prefix + "psnr") is not None]
                if points:
                    ax.plot(*zip(*points), color=colour, marker="o", linewidth=1.6, label=label)
            ax.set_xscale("log")
            ax.set_xlabel("triangles" if x == "triangles" else "file bytes")
            ax.grid(True, color="#e3e3e3", linewidth=0.8)
            for side in ("top", "right"):
                ax.spines[side].set_visible(False)
        axes[0].set_ylabel("held-out PSNR (dB)")
        axes[0].legend(frameon=False, fontsize=8)
        fig.tight_layout()
        fig.savefig(path)
    finally:
        plt.close(fig)
    return path
