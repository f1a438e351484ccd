"""Aligned text tables for the benchmarks' terminal output."""

from __future__ import annotations


def aligned_table(header: list[str], cells: list[list[str]]) -> list[str]:
    """Lines of a table: ``header``, a rule of dashes, then one line per row of ``cells``;
    columns are two spaces apart, the first left-aligned, the others right-aligned."""
    widths = [max(len(header[c]), *(len(row[c]) for row in cells)) for c in range(len(header))]

    def line(values: list[str]) -> str:
        return "  ".join(v.ljust(w) if c == 0 else v.rjust(w) for c, (v, w) in enumerate(zip(values, widths)))

    return [line(header), line(["-" * w for w in widths])] + [line(row) for row in cells]
