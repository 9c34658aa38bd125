"""The target map Phi_d of ``target.map`` and its derivatives at points of the reference
body: grad Phi_d, the metric C_d = grad Phi_d^T grad Phi_d, and the factor |det grad Phi_d|
of the target's own volume measure."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from .expressions import evaluate
from .sections import resolved

if TYPE_CHECKING:
    from .root import Config

# |det grad Phi_d| below this is a map without volume there (scenes 2 and 5)
DEGENERATE = 1e-6


def map_jacobian(cfg: Config, X: np.ndarray, weights: str) -> np.ndarray:
    """The factor on the reference weights w_q of a target map's cloud: |det grad Phi_d|
    (``volume``: the target's own volume measure, which the deformed body's J w_q matches
    where it takes the target shape) where that is positive, 1 (the push-forward of the
    reference measure) where the map has no volume and for ``pushforward``."""
    if weights == "pushforward":
        return np.ones(X.shape[1])
    grad = target_gradient(cfg, X)
    section = cfg.section
    if section.reduced and not section.axisymmetric:  # a plane section's area measure
        axes = list(section.axes)
        grad = grad[:, axes][:, :, axes]
    det = np.abs(np.linalg.det(grad))
    return np.where(det > DEGENERATE, det, 1.0)


def target_gradient(cfg: Config, X: np.ndarray) -> np.ndarray:
    """grad Phi_d of ``target.map`` at the points X (3, n), by central differences:
    (n, dim, dim).  The step, 1e-5 of each point's distance to the origin (at least 1e-8),
    depends on the point alone, so every partition gets the same values."""
    dim = cfg.growth_dim  # a section's map is the 3D body's
    params, axis = cfg.expression_params, cfg.cylinder_axis
    step = 1e-5 * np.maximum(np.abs(X[:dim]).max(axis=0), 1e-3)
    grad = np.empty((X.shape[1], dim, dim))
    for j in range(dim):
        plus, minus = X.copy(), X.copy()
        plus[j] += step
        minus[j] -= step
        for i, e in enumerate(resolved(resolved(cfg.target).map)[:dim]):
            grad[:, i, j] = (evaluate(e, plus, params, axis)
                             - evaluate(e, minus, params, axis)) / (2 * step)
    return grad


def target_metric(cfg: Config, X: np.ndarray) -> np.ndarray:
    """C_d = grad Phi_d^T grad Phi_d of ``target.map`` at the points X (3, n)."""
    grad = target_gradient(cfg, X)
    return np.einsum("nki,nkj->nij", grad, grad)
