"""Options shared by the commands that turn one asset into a low-poly model in a folder
(``simplify``, ``bake``)."""

from __future__ import annotations

import argparse


def add_job_arguments(parser: argparse.ArgumentParser, verb: str, outdir_suffix: str) -> None:
    """``INPUT``, ``-o OUTDIR`` and the target count (``--triangles N`` or ``--ratio R``)."""
    parser.add_argument("input", help=f"the asset to {verb} (glTF/GLB, OBJ, PLY)")
    parser.add_argument("-o", "--output", metavar="OUTDIR", default=None,
                        help=f"output folder (default: INPUT's name + '{outdir_suffix}' in the current folder)")
    count = parser.add_mutually_exclusive_group()
    count.add_argument("--triangles", type=int, metavar="N", help="target triangle count")
    count.add_argument("--ratio", type=float, metavar="R", help="target count as a fraction of the input's (default 0.02)")
