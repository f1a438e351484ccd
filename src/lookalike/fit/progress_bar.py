"""The optimisation loop's progress bar (tqdm): its count and its postfix of step, loss and
validation scores."""

from __future__ import annotations

import time
from collections.abc import Callable

from tqdm import tqdm


def postfix(iteration: int, total: int | None, loss: float, scores: tuple[float, float] | None) -> dict[str, str]:
    """What the bar shows after the count: ``step`` (i/N, ``?`` while N is unknown), the step's
    ``loss`` and, once the validator has scored (``scores``: the latest and the best score),
    ``val`` and ``best``."""
    shown = {"step": f"{iteration}/{total or '?'}", "loss": f"{loss:.4f}"}
    if scores is not None:
        shown["val"], shown["best"] = f"{scores[0]:.2f}", f"{scores[1]:.2f}"
    return shown


class ProgressBar:
    """The loop's bar. With a fixed step count it counts steps; under a time budget it counts
    the budget's seconds elapsed since the bar started, at most the budget rounded as shown (the
    step count is re-planned as the pace changes, the seconds are not), so its ETA only ever
    counts down. The postfix shows the steps either way.

    Args:
        iteration: steps taken before this session.
        total: the step count (used without a budget).
        seconds_available: the session's time budget, or ``None`` to count steps.
        show: draw the bar (``False``: a silent one).
        clock: the time in seconds (a monotonic clock; tests give their own).
    """

    def __init__(self, iteration: int, total: int | None, seconds_available: float | None, show: bool,
                 clock: Callable[[], float] = time.monotonic):
        self.seconds_available = seconds_available
        self.clock = clock
        self.start = clock()
        if seconds_available is None:
            self.bar = tqdm(total=total, initial=iteration, disable=not show, unit="it", dynamic_ncols=True,
                            desc="optimising")
        else:
            self.bar = tqdm(total=round(seconds_available, 1), disable=not show, unit="s", dynamic_ncols=True,
                            desc="optimising", bar_format="{desc}: {percentage:3.0f}%|{bar}| {n:.0f}/{total:.0f} s "
                            "[{elapsed}<{remaining}{postfix}]")

    def step(self, iteration: int, total: int | None, loss: float, scores: tuple[float, float] | None) -> None:
        """Show a finished step (arguments as ``postfix``) and advance the count."""
        self.bar.set_postfix(postfix(iteration, total, loss, scores), refresh=False)
        self.bar.update(1 if self.seconds_available is None
                        else min(self.clock() - self.start, self.bar.total) - self.bar.n)

    def write(self, message: str) -> None:
        """Print ``message`` above the bar."""
        self.bar.write(message)

    def close(self) -> None:
        self.bar.close()


class CountedReference:
    """A reference whose views are counted on a progress bar as they are rendered (``total``
    views expected; shown where ``show``): the reference views of a run can take minutes (a
    path tracer, a deep or huge input), and the bar gives their ETA. Everything else is the
    wrapped reference's; once ``close``d it renders without counting (a pool's later refreshes).
    """

    def __init__(self, reference, total: int, show: bool):
        self.wrapped = reference
        self.bar = tqdm(total=total, disable=not show, unit="view", dynamic_ncols=True, desc="reference views")

    def render(self, camera, light, resolution: int, spp: int, pose=None):
        images = self.wrapped.render(camera, light, resolution, spp, pose)
        if self.bar is not None:
            self.bar.update(camera.batch_size)
        return images

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()
            self.bar = None

    def __getattr__(self, name: str):
        return getattr(self.wrapped, name)
