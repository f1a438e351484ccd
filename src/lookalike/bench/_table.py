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
