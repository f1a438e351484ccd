"""Learning-rate and regularisation schedules (paper Sec. 6.3), as pure functions of the step t.

Learning rate: lr_t = lr_0 * 10^(-k t). The paper uses k = 0.0002 on 10k-step runs, so its
learning rate ends 100 times lower than it starts. Our CPU runs are ten times shorter, and
k = 0.0002 would leave the rate nearly constant (the textures then keep jittering at the
end), so by default k is stretched over the run: k = decades / total (``learning_rate_decay``),
with the paper's two decades (its k exactly for 10k steps) from scratch and one from a warm
start (``lookalike.settings.StartDefaults``).

Laplacian weight: the paper updates lambda_t = (lambda_{t-1} - lambda_min) * 10^(-k t) + lambda_min
with k = 1e-6 and lambda_min = 0.02 lambda_0. Unrolled, that is

    lambda_t = lambda_min + (lambda_0 - lambda_min) * 10^(-k t (t + 1) / 2),

whose excess over lambda_min falls to 1 % at t ~ 2000 (a fifth of the paper's 10k-step runs).
Our CPU runs are a few hundred to a few thousand steps, where k = 1e-6 would hardly decay at
all, so we stretch the same curve over the run: k is chosen so that the excess falls to 1 %
after ``decay_fraction`` of the ``total`` steps, k = 4 / (decay_fraction * total)^2
(decay_fraction = 0.2 and total = 10 000 give the paper's k = 1e-6 exactly).
"""

from __future__ import annotations


def learning_rate(lr_0: float, t: int, k: float = 0.0002) -> float:
    """lr_t = lr_0 * 10^(-k t)."""
    return lr_0 * 10.0 ** (-k * t)


PAPER_LR_DECADES = 2.0
"""Decades the paper's learning rate falls over its run (k = 0.0002 times 10k steps)."""


def learning_rate_decay(total: int, decades: float = PAPER_LR_DECADES) -> float:
    """k = decades / total: the learning rate falls by 10^decades over ``total`` steps (a
    hundredfold by default)."""
    return decades / max(total, 1)


def laplacian_decay_rate(total: int, decay_fraction: float = 0.2) -> float:
    """k = 4 / (decay_fraction * total)^2: the rate at which the excess weight reaches 1 %
    (10^(-k t^2 / 2) = 10^-2) after ``decay_fraction * total`` steps."""
    return 4.0 / max(decay_fraction * total, 1.0) ** 2


def laplacian_weight(lambda_0: float, t: int, k: float, min_fraction: float = 0.02) -> float:
    """lambda_t = lambda_min + (lambda_0 - lambda_min) * 10^(-k t (t + 1) / 2), lambda_min =
    min_fraction * lambda_0: the closed form of the paper's recursion."""
    lambda_min = min_fraction * lambda_0
    return lambda_min + (lambda_0 - lambda_min) * 10.0 ** (-k * t * (t + 1) / 2)
