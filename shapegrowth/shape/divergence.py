"""A shape divergence that vanishes exactly when the shapes coincide: rho_H debiased.

rho_H of (2.9) is positive on identical clouds: every soft distance exceeds the true
one by about (dim/alpha) log(alpha size), so rho_H(A, A) > 0, and a body that packs its
points closer (its own soft distances shrink) can lower rho_H without coming nearer the
target.  In the spirit of the debiased Sinkhorn divergences (Feydy et al., AISTATS 2019)
the self terms are subtracted:

    S(B, T) = rho_H(B, T) - (rho_H(B, B) + rho_H(T, T)) / 2,

so S(T, T) = 0 exactly, and a body is charged for the bias it would create by itself.
rho_H(T, T) is a constant, computed once per target; rho_H(B, B) is one pair sum over
the body's own points on the same kernels and cell grid as rho_H (see
``SmoothHausdorff.self_distance``).  ``objective.hausdorff.form: paper`` minimises
rho_H itself.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
from mpi4py import MPI

from .hausdorff import HausdorffResult, PointCloud, SmoothHausdorff

FORMS = ("debiased", "paper")


@dataclass
class ShapeTerm:
    """The minimised shape term, beside rho_H of (2.9) that it is built from."""

    value: float  # S(B, T), or rho_H(B, T) for form 'paper'
    pair: HausdorffResult  # rho_H(B, T), its directed terms and the exact Hausdorff distance
    body_self: float  # rho_H(B, B) (0 for form 'paper')
    target_self: float  # rho_H(T, T) (0 for form 'paper')
    grad_points: np.ndarray | None = None  # d value / d body points (own)
    grad_weights: np.ndarray | None = None  # d value / d body weights (own)


class ShapeDivergence:
    """S(B, T) (``form='debiased'``) or rho_H(B, T) (``form='paper'``); the target's self
    term is kept for the target it was computed for."""

    def __init__(self, rho: SmoothHausdorff, form: str = "debiased"):
        if form not in FORMS:
            raise ValueError(f"form must be one of {FORMS}, not {form!r}")
        self.rho, self.form = rho, form
        self._target_self: tuple[int, int, float] | None = None

    @property
    def debiased(self) -> bool:
        return self.form == "debiased"

    def with_alpha(self, alpha: float) -> ShapeDivergence:
        """The same divergence at another sharpness (alpha continuation)."""
        return ShapeDivergence(dataclasses.replace(self.rho, alpha=alpha), self.form)

    def target_self(self, target: PointCloud, comm: MPI.Comm) -> float:
        key = (id(target), comm.py2f())
        if self._target_self is None or self._target_self[:2] != key:
            value = self.rho.self_distance(target, comm, gradient=False).value
            self._target_self = (*key, value)
        return self._target_self[2]

    def __call__(self, body: PointCloud, target: PointCloud, comm: MPI.Comm = MPI.COMM_SELF,
                 gradient: bool = True) -> ShapeTerm:
        pair = self.rho(body, target, comm, gradient=gradient)
        if not self.debiased:
            return ShapeTerm(pair.value, pair, 0.0, 0.0, pair.grad_points, pair.grad_weights)
        own = self.rho.self_distance(body, comm, gradient=gradient)
        t_self = self.target_self(target, comm)
        term = ShapeTerm(pair.value - 0.5 * (own.value + t_self), pair, own.value, t_self)
        if gradient:
            assert pair.grad_points is not None and own.grad_points is not None
            assert pair.grad_weights is not None and own.grad_weights is not None
            term.grad_points = pair.grad_points - 0.5 * own.grad_points
            term.grad_weights = pair.grad_weights - 0.5 * own.grad_weights
        return term
