"""``index.html`` of a batch: one self-contained page (inline CSS and a few lines of script, no
network) with a table of every asset, sortable by any column, linking each asset's report."""

from __future__ import annotations

import html
import json
from pathlib import Path

from ..io.atomic import write_text_atomic
from .html import PAGE_CSS

_SCRIPT = """
document.querySelectorAll("th").forEach((th, column) => th.addEventListener("click", () => {
  const body = th.closest("table").tBodies[0];
  const up = th.dataset.order !== "up";
  th.closest("tr").querySelectorAll("th").forEach(h => delete h.dataset.order);
  th.dataset.order = up ? "up" : "down";
  const key = row => { const c = row.cells[column]; return c.dataset.v !== undefined ? parseFloat(c.dataset.v) : c.textContent; };
  [...body.rows].sort((a, b) => { const x = key(a), y = key(b);
    const d = typeof x === "number" && typeof y === "number" ? x - y : String(x).localeCompare(String(y));
    return up ? d : -d; }).forEach(r => body.appendChild(r));
}));
"""

_COLUMNS = ("asset", "status", "input triangles", "output triangles", "minutes", "iterations",
            "PSNR decimated", "PSNR baked", "PSNR ours", "ours − baked", "FLIP baked", "FLIP ours", "report")


def _number(value, fmt: str) -> str:
    """A cell holding a number: shown with ``fmt``, sorted by its value; a dash where absent."""
    if value is None:
        return '<td data-v="-Infinity">—</td>'
    return f'<td data-v="{value}">{fmt.format(value)}</td>'


def _row(name: str, input: Path, outdir: Path, status: str, root: Path) -> str:
    metrics_path = outdir / "metrics.json"
    m = json.loads(metrics_path.read_text(encoding="utf-8")) if metrics_path.is_file() else None
    cells = [f"<td title='{html.escape(str(input))}'>{html.escape(name)}</td>", f"<td>{html.escape(status)}</td>"]
    if m is None:
        return "<tr>" + "".join(cells) + "".join(_number(None, "") for _ in _COLUMNS[2:-1]) + "<td></td></tr>"
    heldout = m["heldout"]
    psnr = {k: heldout[k]["psnr"] if k in heldout else None for k in ("decimated", "baked", "ours")}
    gain = None if psnr["baked"] is None else psnr["ours"] - psnr["baked"]
    cells += [_number(m["triangles"]["input"], "{:,}"), _number(m["triangles"]["output"], "{:,}"),
              _number(m["seconds"]["total"] / 60, "{:.1f}"), _number(m["iterations"], "{:,}"),
              _number(psnr["decimated"], "{:.2f}"), _number(psnr["baked"], "{:.2f}"), _number(psnr["ours"], "{:.2f}"),
              _number(gain, "{:+.2f}"), _number(heldout.get("baked", {}).get("flip"), "{:.4f}"),
              _number(heldout["ours"]["flip"], "{:.4f}")]
    report = (outdir / "report.html").relative_to(root)
    cells.append(f'<td><a href="{html.escape(report.as_posix())}">report</a></td>')
    return "<tr>" + "".join(cells) + "</tr>"


def write_index(root: Path, assets: list[tuple[str, Path, Path, str]]) -> Path:
    """Write ``root/index.html`` for ``assets``: ``(name, input file, output folder, status)``
    each, the figures read from each folder's ``metrics.json``; returns its path."""
    rows = "\n".join(_row(name, input, outdir, status, root) for name, input, outdir, status in assets)
    header = "".join(f"<th>{html.escape(c)}</th>" for c in _COLUMNS)
    page = (f"<!doctype html><html lang='en'><head><meta charset='utf-8'><title>lookalike batch</title>"
            f"<style>{PAGE_CSS}th {{ cursor:pointer; }} th[data-order=up]::after {{ content:' ▲'; }} "
            f"th[data-order=down]::after {{ content:' ▼'; }}</style></head><body><main>"
            f"<header><div class='eyebrow'>lookalike batch</div><h1>{len(assets)} assets</h1>"
            f"<p class='lede'>Held-out PSNR (dB) and FLIP against each input; click a column to sort.</p></header>"
            f"<div class='scroll'><table><thead><tr>{header}</tr></thead><tbody>\n{rows}\n</tbody></table></div>"
            f"</main><script>{_SCRIPT}</script></body></html>")
    path = root / "index.html"
    write_text_atomic(path, page)
    return path
