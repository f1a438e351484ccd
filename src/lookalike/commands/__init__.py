"""Subcommands of ``lookalike``. Each is a module with ``HELP`` (one line),
``add_arguments(parser)`` and ``run(args) -> int``, a thin layer over the Python API.

Modules are imported only when their command runs, so ``lookalike --help`` starts fast.
"""

COMMANDS: dict[str, str] = {
    # name: module under lookalike.commands
    "bench": "bench",
}
