"""Subcommands of ``lookalike``, discovered from the modules of this package.

Each module ``lookalike.commands.NAME`` is the command ``NAME`` (underscores become
dashes) and defines ``HELP`` (one line), ``add_arguments(parser)`` and
``run(args) -> int``: a thin layer over the Python API. Modules import heavy dependencies
(torch, numba) inside ``run`` so that ``lookalike --help`` starts fast.
"""

from __future__ import annotations

import pkgutil


def command_modules() -> dict[str, str]:
    """``{command name: module name}`` for every module in this package."""
    return {m.name.replace("_", "-"): m.name for m in pkgutil.iter_modules(__path__) if not m.name.startswith("_")}
