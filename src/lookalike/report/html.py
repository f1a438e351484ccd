"""``report.html``: one self-contained page (inline CSS, no scripts, no network) with the run's
summary, the held-out views side by side with their error maps, the loss curve and the
configuration. Pictures are written next to it, in ``report_files/``, and referenced relatively.
"""

from __future__ import annotations

import datetime as _dt
import html
import os
from pathlib import Path

import numpy as np
from PIL import Image

from ..io.atomic import write_text_atomic
from ..version import __version__
from .map_noise import CHANNELS as MAP_NOISE_CHANNELS
from .record import MethodResult, RunRecord
from .metrics import PSNR_CAP_DB, SILHOUETTE_WIDTH_PX
from .pictures import (DIFFERENCE_FULL_SCALE, animated_picture, image_grid, save_animation, signed_difference,
                     to_srgb_uint8)
from .plot import plot_levels, plot_loss

FILES_DIR = "report_files"
JUDGE_SLOT = ("<!-- judge -->", "<!-- /judge -->")
"""Where ``add_judge_section`` puts the judge's scores in a written page (empty until judged)."""
EXPANDED_VIEWS = 4                 # views shown open; the rest sit in a collapsed section
_JPEG_QUALITY = 90
_MIN_CELL_PX = 180                 # views sit side by side while their pictures stay this wide

PAGE_CSS = """
:root { --ink:#1d1f21; --muted:#62666d; --faint:#9a9ea5; --line:#e4e4e1; --paper:#fafaf8;
  --card:#ffffff; --accent:#1f4e8c; --good:#1b7f4b; --good-bg:#e8f5ed; --bad:#b3261e; }
* { box-sizing:border-box; }
body { margin:0; background:var(--paper); color:var(--ink);
  font:15px/1.55 -apple-system, "Segoe UI", "Helvetica Neue", "DejaVu Sans", Arial, sans-serif; }
main { max-width:1240px; margin:0 auto; padding:40px 28px 64px; }
header .eyebrow { text-transform:uppercase; letter-spacing:.08em; font-size:12px; color:var(--faint); }
h1 { font-size:34px; font-weight:650; margin:4px 0 6px; letter-spacing:-.01em; }
h2 { font-size:20px; font-weight:620; margin:44px 0 14px; padding-bottom:8px; border-bottom:1px solid var(--line); }
.lede { color:var(--muted); font-size:17px; margin:0; }
.cards { display:grid; grid-template-columns:repeat(auto-fit, minmax(220px, 1fr)); gap:14px; margin-top:28px; }
.card { background:var(--card); border:1px solid var(--line); border-radius:10px; padding:16px 18px; }
.card .k { font-size:12px; text-transform:uppercase; letter-spacing:.06em; color:var(--faint); }
.card .v { font-size:28px; font-weight:650; margin-top:2px; font-variant-numeric:tabular-nums; }
.card .s { color:var(--muted); font-size:13.5px; }
.gain { color:var(--good); font-weight:650; }
.loss { color:var(--bad); font-weight:650; }
table { border-collapse:collapse; width:100%; background:var(--card); border:1px solid var(--line);
  border-radius:10px; overflow:hidden; font-variant-numeric:tabular-nums; }
th, td { padding:10px 14px; text-align:right; border-bottom:1px solid var(--line); }
th { font-size:12px; text-transform:uppercase; letter-spacing:.05em; color:var(--muted); font-weight:600; background:#f4f4f1; }
th:first-child, td:first-child { text-align:left; }
tr:last-child td { border-bottom:none; }
tr.ours td { background:var(--good-bg); font-weight:600; }
.scroll { overflow-x:auto; }
.notes { color:var(--muted); font-size:14px; margin:12px 0 0; padding-left:18px; }
.legend { display:flex; flex-wrap:wrap; gap:28px; align-items:center; color:var(--muted); font-size:13px; margin:0 0 18px; }
.legend .bar { display:inline-block; width:140px; height:10px; border-radius:5px; vertical-align:middle; margin:0 8px; }
.views { display:grid; grid-template-columns:repeat(auto-fill, minmax(min(100%, var(--fig)), 1fr)); gap:18px; margin-bottom:18px; }
figure.view { margin:0; background:var(--card); border:1px solid var(--line); border-radius:10px; padding:14px; }
figure.view figcaption { font-size:14px; color:var(--muted); margin:0 0 10px; }
figure.view figcaption b { color:var(--ink); }
.grid { display:grid; grid-template-columns:repeat(var(--cols), minmax(0, 1fr)); gap:10px; }
.cell img { width:100%; height:auto; display:block; border-radius:6px; background:#eee; }
.cell .t { font-size:12.5px; color:var(--muted); margin-top:5px; display:flex; justify-content:space-between; gap:6px; }
.cell .t b { color:var(--ink); font-weight:600; }
.cell.best .t b { color:var(--good); }
details { margin-top:8px; }
details summary { cursor:pointer; color:var(--accent); font-weight:600; margin:4px 0 18px; }
.plot { background:var(--card); border:1px solid var(--line); border-radius:10px; padding:10px; }
.plot img { width:100%; height:auto; display:block; }
.two { display:grid; grid-template-columns:2fr 1fr; gap:18px; align-items:start; }
table.kv td { text-align:left; font-size:13.5px; padding:7px 14px; }
table.kv td:first-child { color:var(--muted); width:45%; }
table.kv.mono td:first-child { font-family:"DejaVu Sans Mono", Menlo, Consolas, monospace; font-size:12.5px; }
footer { margin-top:48px; color:var(--faint); font-size:13px; }
a { color:var(--accent); }
@media (max-width: 900px) {
  .grid { grid-template-columns:repeat(2, minmax(0, 1fr)); }
  .two { grid-template-columns:1fr; }
  h1 { font-size:28px; }
}
"""


def _esc(value) -> str:
    return html.escape(str(value), quote=True)


def _minutes(seconds: float) -> str:
    return f"{seconds / 60:.1f} min" if seconds >= 60 else f"{seconds:.1f} s"


def _signed(value: float, digits: int, unit: str = "") -> str:
    return f"{'+' if value >= 0 else '−'}{abs(value):.{digits}f}{unit}"


def _change(delta: float, digits: int, unit: str = "", higher_is_better: bool = True) -> str:
    """A signed difference, green where it is an improvement and red where not."""
    good = delta >= 0 if higher_is_better else delta <= 0
    return f'<span class="{"gain" if good else "loss"}">{_signed(delta, digits, unit)}</span>'


def _magma_css() -> str:
    """A CSS gradient through matplotlib's magma map, the colour map FLIP draws its errors in."""
    from matplotlib import colormaps

    stops = colormaps["magma"](np.linspace(0, 1, 6))[:, :3]
    return ", ".join(f"rgb({r * 255:.0f},{g * 255:.0f},{b * 255:.0f})" for r, g, b in stops)


def _save(picture: np.ndarray, path: Path) -> None:
    Image.fromarray(picture).save(path, quality=_JPEG_QUALITY)


def _write_view_pictures(data: RunRecord, files: Path) -> list[dict[str, str]]:
    """Write every picture of every view; returns, per view, ``{role: relative path}``."""
    reference = to_srgb_uint8(data.reference)
    renders = {m.key: to_srgb_uint8(m.images) for m in data.methods}
    difference = signed_difference(data.reference, data.ours.images)
    views = []
    for i in range(data.num_views):
        paths = {"reference": f"{FILES_DIR}/view{i:02d}_reference.jpg",
                 "difference": f"{FILES_DIR}/view{i:02d}_{data.ours.key}_difference.jpg"}
        _save(reference[i], files.parent / paths["reference"])
        _save(difference[i], files.parent / paths["difference"])
        for m in data.methods:
            paths[m.key] = f"{FILES_DIR}/view{i:02d}_{m.key}.jpg"
            paths[m.key + "_flip"] = f"{FILES_DIR}/view{i:02d}_{m.key}_flip.jpg"
            _save(renders[m.key][i], files.parent / paths[m.key])
            _save(m.flip_maps[i], files.parent / paths[m.key + "_flip"])
        views.append(paths)
    _write_overview(data, reference, renders, files / "comparison.png")
    return views


def _write_overview(data: RunRecord, reference, renders, path: Path) -> None:
    """One PNG with the first views: reference, each method, FLIP of ours."""
    rows = [[reference[i]] + [renders[m.key][i] for m in data.methods] + [data.ours.flip_maps[i]]
            for i in range(min(EXPANDED_VIEWS, data.num_views))]
    labels = [data.reference_label] + [m.label for m in data.methods] + [f"FLIP error, {data.ours.label}"]
    image_grid(rows, labels).save(path)


def _cell(src: str, title: str, value: str = "", best: bool = False) -> str:
    return (f'<div class="cell{" best" if best else ""}"><a href="{_esc(src)}"><img src="{_esc(src)}" '
            f'alt="{_esc(title)}" loading="lazy"></a><div class="t"><span>{_esc(title)}</span><b>{_esc(value)}</b></div></div>')


def _view_figure(data: RunRecord, i: int, paths: dict[str, str]) -> str:
    best = max(data.methods, key=lambda m: m.psnr_views[i]).key
    renders = [_cell(paths["reference"], data.reference_label)] + [
        _cell(paths[m.key], m.label, f"{m.psnr_views[i]:.2f} dB", best=m.key == best) for m in data.methods]
    errors = [_cell(paths["difference"], f"{data.ours.label}: brighter / dimmer")] + [
        _cell(paths[m.key + "_flip"], f"FLIP, {m.label}", f"{m.flip_views[i]:.3f}") for m in data.methods]
    gain = data.ours.psnr_views[i] - data.baseline.psnr_views[i]
    pose = f" ({_esc(data.view_labels[i])})" if data.view_labels else ""
    caption = (f"<b>View {i + 1}</b>{pose} · {_esc(data.ours.label)} {data.ours.psnr_views[i]:.2f} dB, "
               f"{_esc(data.baseline.label.lower())} {data.baseline.psnr_views[i]:.2f} dB ({_change(gain, 2, ' dB')})")
    return (f'<figure class="view"><figcaption>{caption}</figcaption>'
            f'<div class="grid" style="--cols:{len(data.methods) + 1}">{"".join(renders + errors)}</div></figure>')


def _motion_section(data: RunRecord, files: Path) -> str:
    """Write ``report_files/motion.gif`` and return its section; empty without ``data.motion``."""
    motion = data.motion
    if motion is None:
        return ""
    columns = [to_srgb_uint8(frames) for frames in motion.columns.values()]
    save_animation(animated_picture(columns, list(motion.columns), motion.seconds_per_frame), files / "motion.gif")
    return (f'<h2>In motion</h2><div class="plot"><img src="{FILES_DIR}/motion.gif" alt="the clip {_esc(motion.clip)}, '
            f'side by side"></div><p class="notes">The clip {_esc(motion.clip)} in real time, from the first held-out '
            f"camera and light: {', '.join(_esc(label) for label in motion.columns)}.</p>")


def _summary_cards(data: RunRecord) -> str:
    ours, base = data.ours, data.baseline
    psnr_gain, flip_change = ours.psnr - base.psnr, ours.flip - base.flip
    ratio = data.input_triangles / max(ours.triangles, 1)
    others = "".join(f"<br>{_change(ours.psnr - m.psnr, 2, ' dB')} over {_esc(m.label.lower())}"
                     for m in data.methods[1:-1])
    cards = [
        ("Triangles", f"{ours.triangles:,}", f"{ratio:.0f}× fewer than the input's {data.input_triangles:,}"),
        ("PSNR", f"{ours.psnr:.2f} dB", f"{_change(psnr_gain, 2, ' dB')} over {_esc(base.label.lower())}{others}"),
        ("FLIP", f"{ours.flip:.4f}",
         f"{_change(flip_change, 4, higher_is_better=False)} against {_esc(base.label.lower())}"),
        ("Time", _minutes(data.wall_time),
         f"{data.iterations:,} iterations · {data.seconds_per_iteration:.2f} s/iteration"),
    ]
    return '<section class="cards">' + "".join(
        f'<div class="card"><div class="k">{k}</div><div class="v">{v}</div><div class="s">{s}</div></div>'
        for k, v, s in cards) + "</section>"


def _methods_table(data: RunRecord) -> str:
    outline = any(m.silhouette_error is not None for m in data.methods)
    noise = any(m.map_noise is not None for m in data.methods)
    iou = any(m.silhouette_iou is not None for m in data.methods)

    def noise_cell(m: MethodResult) -> str:
        if not noise:
            return ""
        if m.map_noise is None:
            return "<td>—</td>"
        return "<td>" + " / ".join(f"{m.map_noise[k]:.4f}" for k in MAP_NOISE_CHANNELS) + "</td>"

    def row(m: MethodResult) -> str:
        gain_text = "—" if m is data.baseline else _change(m.psnr - data.baseline.psnr, 2, " dB")
        texture = f"{m.texture_size}²" if m.texture_size else "input's own"
        share = "—" if m.silhouette_error is None else f"{100 * m.silhouette_error:.0f} %"
        overlap = "—" if m.silhouette_iou is None else f"{m.silhouette_iou:.3f}"
        return (f'<tr class="{"ours" if m is data.ours else ""}"><td>{_esc(m.label)}</td><td>{m.triangles:,}</td>'
                f"<td>{texture}</td><td>{m.psnr:.2f}</td><td>{m.flip:.4f}</td><td>{gain_text}</td>"
                f"{f'<td>{share}</td>' if outline else ''}{f'<td>{overlap}</td>' if iou else ''}{noise_cell(m)}</tr>")

    head = ("<tr><th>Method</th><th>Triangles</th><th>Textures</th><th>PSNR (dB) ↑</th><th>FLIP ↓</th>"
            f"<th>Gain</th>{'<th>Error near outline</th>' if outline else ''}"
            f"{'<th>Silhouette IoU ↑</th>' if iou else ''}"
            f"{'<th>Map noise ↓ (colour / specular / normal)</th>' if noise else ''}</tr>")
    reference = (f'<tr><td>Reference (input)</td><td>{data.input_triangles:,}</td><td>input\'s own</td>'
                 f"<td>—</td><td>—</td><td>—</td>{'<td>—</td>' if outline else ''}{'<td>—</td>' if iou else ''}"
                 f"{'<td>—</td>' if noise else ''}</tr>")
    table = f'<div class="scroll"><table>{head}{reference}{"".join(row(m) for m in data.methods)}</table></div>'
    if outline:
        table += (f'<p class="notes">Error near outline: the share of a method\'s squared error (tone-mapped) that lies '
                  f"within {SILHOUETTE_WIDTH_PX} pixels of the reference's outline. Error there comes mostly from the "
                  "outline's shape, which more triangles improve; elsewhere mostly from shading, which textures "
                  "improve.</p>")
    if iou:
        table += ('<p class="notes">Silhouette IoU: the overlap of a method\'s coverage with the reference\'s over all '
                  "views, sum min / sum max of the antialiased coverages (1 is the same outline).</p>")
    if noise:
        table += ('<p class="notes">Map noise: the RMS of each map\'s discrete Laplacian over the texels inside its '
                  "charts (linear base colour; roughness and metalness; the normal's x and y). Grain that the "
                  "reference does not have raises it; 0 is a constant.</p>")
    return table


LEVEL_COLUMNS = {"level": "Level", "triangles": "Triangles", "bytes": "Bytes", "gpu_bytes": "GPU bytes",
                 "lod_gpu_bytes": "GPU bytes untessellated", "psnr": "PSNR (dB) ↑", "flip": "FLIP ↓",
                 "start_psnr": "Classic displacement bake: PSNR (dB) ↑", "start_flip": "FLIP ↓",
                 "bake_triangles": "Classic decimate + bake: triangles", "bake_bytes": "bytes",
                 "bake_gpu_bytes": "GPU bytes", "bake_psnr": "PSNR (dB) ↑", "bake_flip": "FLIP ↓"}
"""The columns of a report's levels table (``RunRecord.levels``), in order."""


def _levels_section(data: RunRecord, files: Path) -> str:
    """The levels table and its plot (``plot_levels``), or nothing where the run has none."""
    if not data.levels:
        return ""
    plot_levels(data.levels, files / "levels.png")
    columns = [key for key in LEVEL_COLUMNS if any(key in row for row in data.levels)]

    def cell(value) -> str:
        if value is None:
            return "—"
        return f"{value:,}" if isinstance(value, int) else f"{value:.4f}" if abs(value) < 1 else f"{value:.2f}"

    head = "".join(f"<th>{LEVEL_COLUMNS[key]}</th>" for key in columns)
    body = "".join("<tr>" + "".join(f"<td>{cell(row.get(key))}</td>" for key in columns) + "</tr>"
                   for row in data.levels)
    return (f'<h2>Levels</h2><div class="two"><div class="scroll"><table><tr>{head}</tr>{body}</table></div>'
            f'<div class="plot"><img src="{FILES_DIR}/levels.png" alt="PSNR against triangles and bytes"></div></div>')


def _flatten(config: dict, prefix: str = "") -> list[tuple[str, object]]:
    items = []
    for key, value in config.items():
        name = f"{prefix}{key}"
        items.extend(_flatten(value, name + ".") if isinstance(value, dict) else [(name, value)])
    return items


def _key_value_table(pairs, mono: bool = False) -> str:
    rows = "".join(f"<tr><td>{_esc(k)}</td><td>{_esc(v)}</td></tr>" for k, v in pairs)
    return f'<table class="kv{" mono" if mono else ""}">{rows}</table>'


def judge_section(result: dict, renderers: dict[str, str], views_picture: str | None) -> str:
    """The HTML of the judge's scores: one row per judged method, PSNR over the covered pixels
    and FLIP in each renderer, and the map noise of the files as written.

    Args:
        result: ``lookalike.jobs.judge.judge_run``'s result (``"scores"``: ``{renderer: {key:
            {"psnr", "flip"}}}``, ``"labels"``, ``"views"``, ``"resolution"``, ``"map_noise"``).
        renderers: ``{renderer key: column title}``, in column order.
        views_picture: a link, relative to the page, to the judge's contact sheet, if any.
    """
    labels, noise = result["labels"], result.get("map_noise", {})
    head = "".join(f'<th colspan="2">{_esc(title)}</th>' for title in renderers.values())
    sub = "<th>PSNR (dB) ↑</th><th>FLIP ↓</th>" * len(renderers)

    def row(key: str) -> str:
        cells = "".join(f"<td>{result['scores'][r][key]['psnr']:.2f}</td><td>{result['scores'][r][key]['flip']:.4f}</td>"
                        for r in renderers)
        maps = " / ".join(f"{noise[key][c]:.4f}" for c in MAP_NOISE_CHANNELS) if key in noise else "—"
        return f'<tr class="{"ours" if key == "ours" else ""}"><td>{_esc(labels[key])}</td>{cells}<td>{maps}</td></tr>'

    table = (f'<div class="scroll"><table><tr><th rowspan="2">Method</th>{head}<th rowspan="2">Map noise ↓</th></tr>'
             f'<tr>{sub}</tr>{"".join(row(key) for key in labels)}</table></div>')
    link = f' <a href="{_esc(views_picture)}">The first views in each renderer.</a>' if views_picture else ""
    return (f"<h2>Scores in Blender Cycles</h2>{table}<p class=\"notes\">The input and every method rendered in Blender "
            f"Cycles (32 samples, direct light) and in our renderer from {result['views']} held-out views at "
            f"{result['resolution']}², each scored against the same renderer's picture of the input: PSNR over the "
            f"pixels either picture covers, FLIP over the whole picture.{link}</p>")


def add_judge_section(report_path: str | Path, section: str) -> None:
    """Put ``section`` (``judge_section``) into the written page at ``report_path``, in place
    of what its judge slot (``JUDGE_SLOT``) held; the page is rewritten atomically. Nothing
    where there is no page or it has no slot (written by an older version)."""
    path = Path(report_path)
    if not path.is_file():
        return
    page = path.read_text(encoding="utf-8")
    start, end = page.find(JUDGE_SLOT[0]), page.find(JUDGE_SLOT[1])
    if start < 0 or end < start:
        return
    write_text_atomic(path, page[:start + len(JUDGE_SLOT[0])] + section + page[end:])


def _start_distance_note(data: RunRecord) -> str:
    """One line on how far the start strays from the input (``RunRecord.start_distance``), or
    nothing where it was not measured."""
    d = data.start_distance
    if not d:
        return ""
    setting = f" by {_esc(d['setting'])}" if d.get("setting") else ""
    return (f'<p class="notes">How far the start strays: {_esc(d["of"])}{setting}, {d["triangles"]:,} triangles: '
            f'{100 * d["far_area"]:.2f} % of the area lies farther than {100 * d["far"]:g} % of the bounding radius '
            f'from the other surface (both ways); mean distance {100 * d["mean"]:.3f} %, 99th percentile '
            f'{100 * d["p99"]:.2f} % of the radius.</p>')


def write_report(outdir: str | Path, data: RunRecord) -> Path:
    """Write ``outdir/report.html`` and its pictures under ``outdir/report_files/``.

    The page shows: the asset name; cards with triangles, PSNR and FLIP of ours with their
    change against plain decimation, and the run time; a table with every method's triangles,
    textures, PSNR, FLIP and PSNR gain; every held-out view as reference, each method's render
    (PSNR under it), a red/blue difference of ours and each method's FLIP map; for an animated
    input, each view's clip and time and a moving picture over a clip (``report_files/motion.gif``);
    the application's levels table and plot (``RunRecord.levels``) where it has one; the loss
    curve and stage timings; the configuration. Also writes ``report_files/comparison.png`` (the first
    views in one picture) and ``report_files/loss.png``.

    Args:
        outdir: folder to write into (created if missing).
        data: what to show.

    Returns:
        The path of ``report.html``.
    """
    outdir = Path(outdir)
    files = outdir / FILES_DIR
    files.mkdir(parents=True, exist_ok=True)
    views = _write_view_pictures(data, files)
    plot_loss(data.loss_history, files / "loss.png", title=f"Training loss, {data.asset_name}",
              validation=data.validation_history, validation_metric=data.validation_metric)

    figures = [_view_figure(data, i, paths) for i, paths in enumerate(views)]
    views_div = f'<div class="views" style="--fig:{(len(data.methods) + 1) * _MIN_CELL_PX}px">{{}}</div>'
    shown, hidden = figures[:EXPANDED_VIEWS], figures[EXPANDED_VIEWS:]
    more = (f"<details><summary>Show the other {len(hidden)} views</summary>{views_div.format(''.join(hidden))}</details>"
            if hidden else "")
    ours = data.ours
    texture = f", {ours.texture_size}² textures" if ours.texture_size else ""
    notes = "".join(f"<li>{_esc(n)}</li>" for n in data.notes)
    timings = [(stage, _minutes(seconds)) for stage, seconds in data.timings.items()]
    timings += [("total", _minutes(data.wall_time)), ("iterations", f"{data.iterations:,}"),
                ("seconds per iteration", f"{data.seconds_per_iteration:.3f}"), ("device", data.device)]
    body = f"""
<main>
<header>
  <div class="eyebrow">lookalike · appearance-driven simplification</div>
  <h1>{_esc(data.asset_name)}</h1>
  <p class="lede">{data.input_triangles:,} → {ours.triangles:,} triangles{texture}, compared with the input on
  {data.num_views} held-out views that training never saw.</p>
</header>
{_summary_cards(data)}
<h2>Scores on the held-out views</h2>
{_methods_table(data)}
{f'<ul class="notes">{notes}</ul>' if notes else ''}
{_start_distance_note(data)}
{_levels_section(data, files)}
{"".join(JUDGE_SLOT)}
<h2>Held-out views</h2>
<div class="legend">
  <span>FLIP error<span class="bar" style="background:linear-gradient(90deg, {_magma_css()})"></span>0 → 1</span>
  <span>{_esc(ours.label)} vs reference: dimmer<span class="bar"
    style="background:linear-gradient(90deg, rgb(49,99,199), #fff, rgb(214,48,38))"></span>brighter
    (full colour at ±{DIFFERENCE_FULL_SCALE:g} tone-mapped)</span>
  <span><a href="{FILES_DIR}/comparison.png">all in one picture</a></span>
</div>
{views_div.format(''.join(shown))}
{more}
{_motion_section(data, files)}
<h2>Training</h2>
<div class="two">
  <div class="plot"><img src="{FILES_DIR}/loss.png" alt="loss curve"></div>
  {_key_value_table(timings)}
</div>
<h2>Configuration</h2>
{_key_value_table(_flatten(data.config), mono=True)}
<footer>PSNR and FLIP compare whole images after the paper's tone map x ↦ sRGB(log(x + 1)), clamped to [0, 1];
identical images score {PSNR_CAP_DB:g} dB. FLIP is NVIDIA's FLIP (LDR, 67 pixels per degree), lower is better.
Written by lookalike {_esc(__version__)} on {_dt.datetime.now().strftime("%Y-%m-%d %H:%M")}.</footer>
</main>"""
    page = (f'<!doctype html>\n<html lang="en"><head><meta charset="utf-8">'
            f'<meta name="viewport" content="width=device-width, initial-scale=1">'
            f"<title>{_esc(data.asset_name)} · lookalike report</title><style>{PAGE_CSS}</style></head>"
            f"<body>{body}</body></html>\n")
    path = outdir / "report.html"
    partial = path.with_suffix(".html.partial")
    partial.write_text(page, encoding="utf-8")
    os.replace(partial, path)
    return path
