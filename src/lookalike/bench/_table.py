"""Aligned text tables for the benchmarks' terminal output."""

from __future__ import annotations


def aligned_table(header: list[str], cells: list[list[str]]) -> list[str]:
    """Lines of a table: ``header``, a rule of dashes, then one line per row of ``cells``;
    columns are two spaces apart, the first left-aligned, the others right-aligned."""
    widths = [max(len(header[c]), *(len(row[c]) for row in cells)) for c in range(len(header))]

    def line(values: list[str]) -> str:
        return "  ".join(v.ljust(w) if c == 0 else v.rjust(w) for c, (v, w) in enumerate(zip(values, widths)))

    return [line(header), line(["-" * w for w in widths])] + [line(row) for row in cells]


def runs_table(result: dict, columns: tuple, bar: str, judge_table) -> str:
    """A benchmark's runs as text: ``result["runs"]`` in ``columns`` (``(name, row key,
    format)``) with a last column saying whether each meets its bar, the line ``bar`` (the bar
    and whether every run meets it, ``result["all_meet_bar"]``, follow it), where the outputs
    are, and ``judge_table(rows)``'s lines where rows were judged."""
    header = [name for name, _, _ in columns] + ["bar"]
    cells = [[fmt.format(r[key]) for _, key, fmt in columns] + ["ok" if r["meets_bar"] else "MISSED"]
             for r in result["runs"]]
    lines = aligned_table(header, cells)
    lines.append(f"{bar}: {'met' if result['all_meet_bar'] else 'NOT met'} "
                 f"(time budget {result['time_budget_s']:g} s per run)")
    if result.get("outputs"):
        lines.append(f"outputs: {result['outputs']}")
    if any("judge" in r for r in result["runs"]):
        lines += [""] + judge_table(result["runs"])
    return "\n".join(lines)


def judged_table(rows: list[dict], first: str, methods: tuple, ours: str, gains: tuple, title: str) -> list[str]:
    """Lines of a judge's table: ``title``, then per judged row (``row["judge"]``), one line
    per renderer the row was judged in (``judge_scores.RENDERERS`` and ``THREEJS_RENDERERS``:
    Cycles with and without shadows, ours, three.js where judged) with the PSNR of each method of
    ``methods`` (``(column name, method key)``), the gains of ``ours`` over the methods
    ``gains`` (``(column name, method key)``) and each method's FLIP; ``first`` heads the
    rows' name column."""
    from ..jobs.judge_scores import RENDERERS, THREEJS_RENDERERS

    names = {**RENDERERS, **THREEJS_RENDERERS}
    order = ("cycles", "cycles_no_shadows", "ours", *THREEJS_RENDERERS)
    header = ([first, "renderer"] + [f"PSNR {name}" for name, _ in methods] + [name for name, _ in gains]
              + [f"FLIP {name}" for name, _ in methods])
    cells = []
    for row in (r for r in rows if "judge" in r):
        for i, renderer in enumerate(r for r in order if r in row["judge"]):
            scores = row["judge"][renderer]
            cells.append([row["asset"] if i == 0 else "", names[renderer]]
                         + [f"{scores[key]['psnr']:.2f}" for _, key in methods]
                         + [f"{scores[ours]['psnr'] - scores[key]['psnr']:+.2f}" for _, key in gains]
                         + [f"{scores[key]['flip']:.4f}" for _, key in methods])
    return [title] + aligned_table(header, cells)
