"""Where Numba caches the compiled kernels. It writes them beside the modules (``__pycache__``)
or, where that folder is read-only, in the user's cache folder; where neither is writable (an
unprivileged user without a writable home, on a read-only install) it fails with "cannot cache
function". Then the kernels go to a private temporary folder instead: ``NUMBA_CACHE_DIR`` is
set before Numba is first imported (``lookalike/__init__.py`` calls ``choose``)."""

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


def choose() -> None:
    """Set ``NUMBA_CACHE_DIR`` to ``fallback_folder(...)`` where one is needed."""
    try:
        home = Path.home()
    except RuntimeError:  # no HOME and no password entry
        home = Path(tempfile.gettempdir()) / "no-home"
    user_cache = Path(os.environ.get("XDG_CACHE_HOME") or home / ".cache")
    folder = fallback_folder(PACKAGE / "render", user_cache, os.environ)
    if folder is not None:
        os.environ["NUMBA_CACHE_DIR"] = folder
