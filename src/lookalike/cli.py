"""The ``lookalike`` command. Each subcommand is a thin layer over the Python API
(see ``lookalike.commands``)."""

from __future__ import annotations

import argparse
import importlib
import sys

from .commands import command_modules
from .errors import LookalikeError
from .version import __version__


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="lookalike",
        description="Turn a heavy 3D asset into a light one that looks the same.",
    )
    parser.add_argument("--version", action="version", version=f"lookalike {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    for name in command_modules():
        module = _command_module(name)
        p = sub.add_parser(name, help=module.HELP, description=module.HELP)
        module.add_arguments(p)
    return parser


def _command_module(name: str):
    return importlib.import_module(f"lookalike.commands.{command_modules()[name]}")


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        return _command_module(args.command).run(args)
    except LookalikeError as e:
        print(f"lookalike {args.command}: error: {e}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"lookalike {args.command}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
