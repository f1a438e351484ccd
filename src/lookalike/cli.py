"""The ``lookalike`` command. Each subcommand is a thin layer over the Python API
(see ``lookalike.commands``)."""

from __future__ import annotations

import argparse
import importlib
import logging
import signal
import sys

from .commands import command_modules
from .devices import device_failure
from .errors import DeviceError, LookalikeError, UserCodeError
from .version import __version__


def build_parser(argv: list[str] | None = None) -> argparse.ArgumentParser:
    """The command line's parser. Every subcommand is listed, but only the one that ``argv``
    names (``sys.argv[1:]`` by default) gets its options: they state the defaults of the
    application it runs, which loads the numerical stack."""
    argv = sys.argv[1:] if argv is None else argv
    chosen = next((word for word in argv if not word.startswith("-")), None)
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
        if name == chosen:
            module.add_arguments(p)
    return parser


def _command_module(name: str):
    return importlib.import_module(f"lookalike.commands.{command_modules()[name]}")


class StopSignals:
    """While active, SIGTERM (what ``docker stop``, ``timeout``, Slurm and Ray send) stops the
    run the way Ctrl-C does: it raises ``KeyboardInterrupt`` (where the program is, or, in the
    optimisation loop, after the step under way: ``lookalike.interrupts``), so that the loop
    writes its checkpoint and the best model so far. ``terminated`` tells which it was."""

    def __init__(self):
        self.terminated = False

    def __enter__(self) -> "StopSignals":
        self.previous = signal.signal(signal.SIGTERM, self._stop)
        return self

    def __exit__(self, *exc) -> None:
        signal.signal(signal.SIGTERM, self.previous)

    def _stop(self, signum, frame) -> None:
        self.terminated = True
        raise KeyboardInterrupt


def _log_one_line_warnings(command: str) -> None:
    """Warnings of the library (``logging``, logger ``lookalike``) print as one line each:
    ``lookalike COMMAND: warning: ...``."""
    handler = logging.StreamHandler(sys.stderr)
    handler.setFormatter(logging.Formatter(f"lookalike {command}: warning: %(message)s"))
    logger = logging.getLogger("lookalike")
    logger.handlers[:] = [handler]
    logger.setLevel(logging.WARNING)


def main(argv: list[str] | None = None) -> int:
    """Run the command; its exit status: 0 done, 2 the user's input, an OS error on a path or a
    failing GPU (one line on stderr naming it), 130 interrupted by Ctrl-C, 143 stopped by SIGTERM (both
    after saving what the command saves when stopped)."""
    from . import heap, kernel_cache  # the program's process settings, before Numba is first imported

    kernel_cache.choose()
    heap.keep_freed_memory()
    args = build_parser(argv).parse_args(argv)
    _log_one_line_warnings(args.command)
    with StopSignals() as stop:
        try:
            status = _command_module(args.command).run(args)
        except UserCodeError as e:
            print(f"lookalike {args.command}: error in your code: {e}", file=sys.stderr)
            return 2
        except LookalikeError as e:
            print(f"lookalike {args.command}: error: {e}", file=sys.stderr)
            return 2
        except OSError as e:
            where = f"{e.filename}: " if e.filename else ""
            print(f"lookalike {args.command}: error: {where}{e.strerror or e}", file=sys.stderr)
            return 2
        except Exception as e:
            failure = device_failure(e)
            if failure is None:
                raise
            print(f"lookalike {args.command}: error: {DeviceError(failure)}", file=sys.stderr)
            return 2
        except KeyboardInterrupt:
            print(f"lookalike {args.command}: {'stopped' if stop.terminated else 'interrupted'}", file=sys.stderr)
            status = 130
    return 128 + signal.SIGTERM if status == 130 and stop.terminated else status


if __name__ == "__main__":
    sys.exit(main())
