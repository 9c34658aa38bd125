"""Designs made of real materials (``growth.levels``): the filtered eigenvalue field projected
onto a few levels g_1 < ... < g_K, each a material's growth (swelling) ratio.

Between two neighbouring levels a = g_k and b = g_k+1, with t = (x - a) / (b - a), the
smoothed Heaviside projection of topology optimisation (Wang, Lazarov and Sigmund, Struct.
Multidisc. Optim. 43 (2011) 767), centred at the interval's middle,

    P(x) = a + (b - a) H(t),   H(t) = (tanh(beta / 2) + tanh(beta (t - 1/2))) / (2 tanh(beta / 2)),

takes a to a and b to b for every sharpness beta, and its slope H'(t) = beta sech^2(beta (t -
1/2)) / (2 tanh(beta / 2)) is the same at t = 0 and t = 1: the pieces join into one
continuously differentiable map of [g_1, g_K] onto itself whose second derivative is bounded
(what a Taylor test's rate 2 needs).  beta grows over a run's stages (``growth.sharpness``);
beta = inf is the crisp design, each value sent to its nearest level.  Values outside
[g_1, g_K] (a filter's overshoot) are clipped, with slope 0.  Nodal: the projected field is
the growth space's interpolant of the projected nodal values.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import ufl


@dataclass(frozen=True)
class LevelProjection:
    """P of the module's text onto ``levels`` (increasing)."""

    levels: tuple[float, ...]

    def _split(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        g = np.asarray(self.levels, dtype=float)
        inside = (x >= g[0]) & (x <= g[-1])
        xc = np.clip(x, g[0], g[-1])
        k = np.clip(np.searchsorted(g, xc, side="right") - 1, 0, len(g) - 2)
        a, width = g[k], g[k + 1] - g[k]
        return (xc - a) / width, a, width, inside

    def value(self, x: np.ndarray, beta: float) -> np.ndarray:
        t, a, width, _ = self._split(np.asarray(x, dtype=float))
        if math.isinf(beta):  # the levels themselves, exactly
            return np.asarray(self.levels, dtype=float)[self.index(x)]
        half = math.tanh(beta / 2)
        return a + width * (half + np.tanh(beta * (t - 0.5))) / (2 * half)

    def slope(self, x: np.ndarray, beta: float) -> np.ndarray:
        """dP/dx (0 outside [g_1, g_K], and everywhere at beta = inf)."""
        t, _, _, inside = self._split(np.asarray(x, dtype=float))
        if math.isinf(beta):
            return np.zeros_like(t)
        sech2 = 1.0 - np.tanh(beta * (t - 0.5)) ** 2
        return np.where(inside, beta * sech2 / (2 * math.tanh(beta / 2)), 0.0)

    def index(self, x: np.ndarray) -> np.ndarray:
        """The crisp design's material: the index of the level each value is sent to."""
        t, a, _, _ = self._split(np.asarray(x, dtype=float))
        g = np.asarray(self.levels, dtype=float)
        return np.minimum(np.searchsorted(g, a) + (t >= 0.5), len(g) - 1)


def grey_density(p: Any, levels: tuple[float, ...]) -> Any:
    """The discreteness measure of a projected field ``p`` (UFL), 0 at each level and 1 at an
    interval's middle: 4 (p - a)(b - p) / (b - a)^2 on the interval [a, b] that p lies in
    (Sigmund's measure of non-discreteness, Struct. Multidisc. Optim. 33 (2007) 401, on each
    interval), the largest of the intervals' parabolas (the others are negative there)."""
    parts = [4.0 * (p - a) * (b - p) / (b - a) ** 2 for a, b in zip(levels, levels[1:])]
    out = parts[0]
    for part in parts[1:]:
        out = ufl.max_value(out, part)
    return out

