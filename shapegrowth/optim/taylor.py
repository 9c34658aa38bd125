"""The Taylor test of a gradient, shipped with the package and asserted in the tests.

For a direction h, the remainder r(eps) = |J(m + eps h) - J(m) - eps dJ(m) . h| is
O(eps^2) when dJ is the exact derivative: each halving of eps divides it by 4,
a rate of 2 (a wrong gradient gives 1).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np


@dataclass
class TaylorResult:
    eps: list[float]
    residuals: list[float]
    rates: list[float]

    @property
    def min_rate(self) -> float:
        return min(self.rates) if self.rates else float("nan")


def taylor_test(J: Callable[[np.ndarray], float], dJ: Callable[[np.ndarray], np.ndarray],
                m: np.ndarray, h: np.ndarray, eps0: float = 1e-2, steps: int = 4,
                dot: Callable[[np.ndarray, np.ndarray], float] = np.dot) -> TaylorResult:
    """Remainders and convergence rates for eps = eps0, eps0/2, ..., eps0/2^steps.

    ``dot`` is the inner product of design vectors (an MPI reduction for
    distributed ones)."""
    J0 = J(m)
    slope = dot(dJ(m), h)
    eps = [eps0 / 2**k for k in range(steps + 1)]
    residuals = [abs(J(m + e * h) - J0 - e * slope) for e in eps]
    rates = [float(np.log2(residuals[k] / residuals[k + 1]))
             if residuals[k + 1] > 0 else float("inf") for k in range(steps)]
    return TaylorResult(eps, residuals, rates)


def smooth_direction(coords: np.ndarray, seed: int, length: float,
                     scale: float = 1.0) -> np.ndarray:
    """A smooth pseudo-random field at the given points (n, 3), varying over ``length``,
    the same for every partition of the mesh (it depends on the coordinates only)."""
    rng = np.random.default_rng(seed)
    x = coords / length
    value = np.zeros(len(coords))
    for _ in range(6):
        k = rng.normal(size=3) * 2.0
        value += rng.normal() * np.cos(2 * np.pi * (x @ k) + rng.uniform(0, 2 * np.pi))
    return scale * value / 6.0
