"""Ctrl-C and SIGTERM acted on between a loop's steps, not inside one.

Python runs a signal's handler wherever the program is. Inside a step that can be in the
middle of a compiled kernel's dispatch: a ``KeyboardInterrupt`` raised while Numba loads a
cached function comes out of it as a ``SystemError``, and the run died with a traceback
instead of saving (seen once in the suite: SIGTERM during the first steps of a fresh
checkout). It can also cut a step in half, with the optimiser's state half updated.

``BetweenSteps`` holds SIGINT and SIGTERM while it is active and ``deliver()``, called
between steps, hands a held signal to the handler that was installed before: Python's
``KeyboardInterrupt`` for Ctrl-C, the command line's SIGTERM handler, or the default
action (the process ends as it would have, one step later). A step's length is the most a
stop waits.
"""

from __future__ import annotations

import os
import signal
import threading
from typing import Self

HELD_SIGNALS = (signal.SIGINT, signal.SIGTERM)


class BetweenSteps:
    """While active (in the main thread; elsewhere it does nothing, as signals only reach the
    main thread), SIGINT and SIGTERM are held until ``deliver()``."""

    def __enter__(self) -> Self:
        self.held: list[int] = []
        self.previous = {}
        if threading.current_thread() is threading.main_thread():
            self.previous = {number: signal.signal(number, self._hold) for number in HELD_SIGNALS}
        return self

    def __exit__(self, kind, value, traceback) -> None:
        for number, handler in self.previous.items():
            signal.signal(number, handler)
        if kind is None:
            self.deliver()

    def _hold(self, number: int, frame) -> None:
        self.held.append(number)

    def deliver(self) -> None:
        """Act on the first held signal, as its earlier handler would have (which may raise
        ``KeyboardInterrupt``); the others held with it are dropped."""
        if not self.held:
            return
        number = self.held[0]
        self.held.clear()
        handler = self.previous.get(number, signal.SIG_DFL)
        if callable(handler):
            handler(number, None)
        elif handler == signal.SIG_DFL:
            signal.signal(number, signal.SIG_DFL)
            os.kill(os.getpid(), number)
