"""Stable optima on request (``optimizer.stability``): a penalty on the tangent's lowest
eigenvalues, with its exact derivatives.

At an equilibrium, each eigenpair of K phi = omega^2 M phi (physics/stability.py), phi
normalised in the mass (phi^T M phi = 1), has the sensitivity

    d(omega^2) = phi^T dK phi,

the mode's quadratic form of the tangent's total derivative (M does not depend on the
design; a simple eigenvalue).  K = K(u, C_g): with Q(u, C_g) = K(u, C_g)[phi, phi], phi held,
d(omega^2)/dC_g = dQ/dC_g|_u + dQ/du . du/dC_g, the second term by the state's adjoint, as
for the shape term.  So the penalty

    P = weight sum_i max(0, 1 - omega_i^2 / eps)^2      (i over the lowest ``modes``)

is one more functional of (u, C_g): its u-derivative joins dJ/du before the adjoint solve
and its C_g-derivative joins the explicit growth derivatives, both from UFL (the third
variation of the energy, contracted with the modes).  The square of the ramp is C^1 where a
mode crosses eps, and the sum over all modes below eps stays smooth where a symmetric body's
pairs of equal eigenvalues split (their sum is a trace).

Why a penalty and not a constraint: L-BFGS, the default optimiser, takes none, and a penalty
serves the three optimisers alike (docs/STABILITY.md, "Stability").
"""

from __future__ import annotations

import dolfinx.fem
import numpy as np
import ufl
from petsc4py import PETSc

from .. import compat
from ..config import StabilityPenaltyConfig
from ..physics.stability import StabilityProblem
from ..physics.state import StateProblem
from ..shape.clouds import assemble


class StabilityPenalty:
    """P and its partial derivatives at the state's current equilibrium (collective)."""

    def __init__(self, state: StateProblem, settings: StabilityPenaltyConfig):
        assert settings.min_eigenvalue is not None
        self.eps, self.weight = settings.min_eigenvalue, settings.weight
        self.problem = StabilityProblem(state, settings.modes)
        self.modes = [dolfinx.fem.Function(state.W, name=f"mode_{i}")
                      for i in range(settings.modes)]
        mesh = state.domain.mesh
        self.coefficients = [compat.constant(mesh, 0.0)
                             for _ in self.modes]
        test, trial = state.jacobian_ufl.arguments()
        quadratic = sum(c * ufl.replace(state.jacobian_ufl, {test: phi, trial: phi})
                        for c, phi in zip(self.coefficients, self.modes))
        mu = ufl.TestFunction(state.applied.space)
        self._du = dolfinx.fem.form(ufl.derivative(quadratic, state.w, state.v))
        self._dgrowth = [dolfinx.fem.form(ufl.derivative(quadratic, f, mu))
                         for f in state.applied.fields]
        self.lowest: tuple[float, ...] = ()

    def value(self) -> float:
        """P at the current state (an eigenproblem); the eigenvalues kept in ``lowest``."""
        self.problem.assess()
        values = self.problem.modes_into(self.modes)
        self.lowest = tuple(values)
        ramps = [max(0.0, 1.0 - v / self.eps) for v in values]
        for c, ramp in zip(self.coefficients, ramps):
            c.value = -2.0 * self.weight * ramp / self.eps  # dP/d(omega_i^2)
        for c in self.coefficients[len(values):]:
            c.value = 0.0
        return self.weight * float(np.sum(np.square(ramps)))

    def active(self) -> bool:
        return any(float(c.value) != 0.0 for c in self.coefficients)

    def derivative_w(self) -> PETSc.Vec:
        """dP/dw at fixed C_g (of the last :meth:`value`): w the state's unknown, a mixed
        body's (u, p)."""
        return assemble(self._du)

    def derivatives_growth(self) -> list[PETSc.Vec]:
        """dP/d(growth field) at fixed u, per growth field."""
        return [assemble(form) for form in self._dgrowth]
