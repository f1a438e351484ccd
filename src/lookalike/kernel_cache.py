"""Where Numba caches the compiled kernels, and whether it can. It writes them beside the
modules (``__pycache__``) or, where that folder is read-only, in the user's cache folder; where
neither is writable (an unprivileged user without a writable home, on a read-only install) a
kernel declared with ``cache=True`` fails with "cannot cache function".

So every kernel declares ``cache=CACHE``: ``CACHE`` is evaluated once, when this module is first
imported, and is False where no folder Numba would use can be written, so that the kernels then
compile in each process instead of failing. Importing lookalike sets no environment variable:
the ``lookalike`` command (``lookalike.cli.main``) and the worker programs it starts call
``choose`` before Numba is first imported, which points ``NUMBA_CACHE_DIR`` at a private
temporary folder where it is needed, so that the command's kernels are cached everywhere. A
library user may do the same by calling ``lookalike.kernel_cache.choose()`` before importing
anything else of lookalike."""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

PACKAGE = Path(__file__).parent


def _writable(folder: Path) -> bool:
    """Whether ``folder`` (or, where it does not exist yet, its nearest existing parent) can be
    written."""
    while not folder.exists() and folder != folder.parent:
        folder = folder.parent
    return os.access(folder, os.W_OK)


def fallback_folder(package: Path, user_cache: Path, environ) -> str | None:
    """The folder to set as ``NUMBA_CACHE_DIR``, or ``None`` where Numba's own choice works: it
    is set already, or ``package`` (beside the modules) or ``user_cache`` can be written."""
    if environ.get("NUMBA_CACHE_DIR") or _writable(package) or _writable(user_cache):
        return None
    return str(Path(tempfile.gettempdir()) / f"lookalike-kernels-{os.getuid() if hasattr(os, 'getuid') else 0}")


def _user_cache(environ) -> Path:
    """The user's cache folder, where Numba keeps kernels whose ``__pycache__`` is read-only."""
    try:
        home = Path.home()
    except RuntimeError:  # no HOME and no password entry
        home = Path(tempfile.gettempdir()) / "no-home"
    return Path(environ.get("XDG_CACHE_HOME") or home / ".cache")


def cache_writable(packages: list[Path], user_cache: Path, environ) -> bool:
    """Whether Numba can cache kernels: ``NUMBA_CACHE_DIR`` in ``environ`` is set and writable,
    or the ``__pycache__`` folders of all ``packages`` are, or ``user_cache``'s ``numba`` folder."""
    provided = environ.get("NUMBA_CACHE_DIR")
    return ((bool(provided) and _writable(Path(provided)))
            or all(_writable(package / "__pycache__") for package in packages)
            or _writable(user_cache / "numba"))


def _kernel_packages() -> list[Path]:
    """The folders of lookalike's subpackages, beside whose modules Numba caches kernels."""
    return [folder for folder in PACKAGE.iterdir() if (folder / "__init__.py").is_file()]


def choose() -> None:
    """Set ``NUMBA_CACHE_DIR`` to ``fallback_folder(...)`` where one is needed, and ``CACHE``
    anew; call it before Numba and the kernels are first imported (it changes the process)."""
    global CACHE
    folder = fallback_folder(PACKAGE / "render", _user_cache(os.environ), os.environ)
    if folder is not None:
        os.environ["NUMBA_CACHE_DIR"] = folder
    CACHE = cache_writable(_kernel_packages(), _user_cache(os.environ), os.environ)


CACHE = cache_writable(_kernel_packages(), _user_cache(os.environ), os.environ)
"""The ``cache`` argument of every compiled kernel: False where Numba could not write its cache."""
