"""Ctrl-C at a chosen step of the loop, for the tests of interrupted and resumed runs."""

from __future__ import annotations

from lookalike.fit.loop import Fitter


def ctrl_c_at(monkeypatch, iteration: int) -> None:
    """From now on, ``Fitter.step`` raises ``KeyboardInterrupt`` when it would take step
    ``iteration`` (as Ctrl-C there does); ``monkeypatch.undo()`` restores it."""
    step = Fitter.step

    def interrupted_step(self):
        if self.progress.iteration == iteration:
            raise KeyboardInterrupt
        return step(self)

    monkeypatch.setattr(Fitter, "step", interrupted_step)
