"""The adjoint of the state equation and the sensitivities to the growth fields.

At the converged state, with K = dR/du the tangent (symmetric: R is the first
variation of an energy), the adjoint p solves (5.12)

    K p = -dJ/du,   p = 0 on the clamped DOFs,

and the derivative of the reduced objective with respect to a growth field f is

    dJ/df [mu] = dJ/df|_u [mu] + dR/df [p, mu],

the second term assembled from ``ufl.derivative`` of R(u; p) (the residual with
the test function replaced by p).

The tangent at the converged state differs from the last one Newton factored
(at the iterate before) by O(last update).  So p is first solved with the state
solver's factors and then refined against the exact tangent, applied matrix-free
(the action of K on p, a vector assembly): p += K_old^-1 (b - K p) until the
residual is below 1e-12 of b or the correction below 1e-9 of p.  Two or three
refinements suffice on a thin beam; this replaces a
matrix assembly and a factorisation by back-solves and vector assemblies.  Where
refinement stalls (the factors are of an older state) the tangent is assembled
and factored anew with the adjoint solver (``solver.linear``'s preset, options
``adjoint_...``; a failed solve falls back to the state's exact factorisation), which
``solver.adjoint_reuse: false`` always does.
"""

from __future__ import annotations

import logging

import dolfinx.fem
import dolfinx.fem.petsc
import ufl
from petsc4py import PETSc

from .. import compat
from ..errors import AdjointSolveError
from ..physics import linear
from ..physics.options import SolverOptions
from ..physics.pmultigrid import rigid_body_modes
from ..physics.state import StateProblem
from ..shape.clouds import assemble

log = logging.getLogger(__name__)


class AdjointProblem:
    role = "adjoint_"  # the prefix of this solver's keys in solver.petsc_options
    refine_rtol = 1e-12  # residual, relative to b
    step_rtol = 1e-9  # correction, relative to p
    max_refinements = 6

    def __init__(self, state: StateProblem):
        self.state = state
        self.p = dolfinx.fem.Function(state.W, name="adjoint")  # of the unknown (u, or u and p)
        self.A = dolfinx.fem.petsc.create_matrix(state.jacobian_form)
        self.rhs = self.A.createVecRight()
        self.ksp = PETSc.KSP().create(state.domain.mesh.comm)
        self.linear = state.newton.linear  # the state's preset, resolved
        # the state's p-multigrid, its coarse operator this solver's own (physics/pmultigrid.py)
        self.pmg = state.newton.pmg.sibling() if state.newton.pmg is not None else None
        defaults = linear.preset_options(self.linear, self.role)
        if self.pmg is not None:
            defaults.update(self.pmg.coarse_options())
        self.options = SolverOptions(self.role, defaults, state.cfg.solver.petsc_options)
        if self.linear in linear.MULTIGRID:
            self.A.setNearNullSpace(rigid_body_modes(state.V))
        self.ksp.setOptionsPrefix(self.options.prefix)
        with self.options.pushed():
            self.ksp.setFromOptions()
        self.reuse = state.cfg.solver.adjoint_reuse
        self._action = dolfinx.fem.form(ufl.action(state.jacobian_ufl, self.p))
        self._residual = compat.create_vector(self._action)  # ghosted
        self._correction = self.A.createVecRight()
        self.refinements = 0  # of the last solve; -1: solved with fresh factors
        mu = ufl.TestFunction(state.applied.space)
        coupled = ufl.replace(state.residual_ufl, {state.v: self.p})
        self.design_forms = [dolfinx.fem.form(ufl.derivative(coupled, f, mu))
                             for f in state.applied.fields]

    def solve(self, dJdu: PETSc.Vec, dJdw: PETSc.Vec | None = None) -> int:
        """p for the current state; returns the linear iterations (of a fresh solve) or the
        refinements (with the state's factors).  ``dJdw``: a part of dJ in the unknown's
        DOFs (a mixed body's pressure too: the stability penalty's), added."""
        st = self.state
        st.to_unknown(dJdu, self.rhs)  # zero in a mixed body's pressure: J sees u alone
        if dJdw is not None:
            self.rhs.axpy(1.0, dJdw)
        self.rhs.scale(-1.0)
        compat.set_bc(self.rhs, st.bcs, alpha=0.0)  # p = 0 where u is prescribed
        if self.reuse and self.state.jacobian_assemblies > 0:
            try:
                with self.state.newton.options.pushed():  # the state's KSP, under its options
                    if self._solve_with_state_factors():
                        return self.refinements
            except PETSc.Error as err:  # factors unusable: fall back to fresh ones
                log.debug("adjoint: the state's factors failed (PETSc error %d)",
                          linear.error_code(err))
        self.refinements = -1
        st.tangent_into(self.A)
        if self.pmg is not None:
            self.pmg.prepare(self.ksp, self.A)
        failure = self._fresh_solve(self.ksp, self.options)
        if failure and self.linear != "mumps":
            linear.record_fallback(self.role, self.linear, failure, st.newton.exact)
            linear.reset_after_failure(self.ksp)
            failure = self._fresh_solve(*self.state.newton.exact_ksp())
        if failure:
            raise AdjointSolveError(f"adjoint solve failed ({failure})")
        self.p.x.scatter_forward()
        return self.ksp.getIterationNumber()

    def _fresh_solve(self, ksp: PETSc.KSP, options: SolverOptions) -> str:
        """K p = b with the assembled tangent by ``ksp``; the failure in words ('' if none)."""
        ksp.setOperators(self.A)
        try:
            with options.pushed():
                ksp.solve(self.rhs, compat.petsc_vec(self.p))
        except PETSc.Error as err:  # e.g. a factorisation that broke down
            return f"PETSc error {linear.error_code(err)}"
        return linear.ksp_reason(ksp) if linear.reason_of(ksp) < 0 else ""

    def _solve_with_state_factors(self) -> bool:
        """p by the state solver's last factors and refinement; False if it did not converge.

        Converged when the residual is below ``refine_rtol`` of b, or when a correction is
        below ``step_rtol`` of p: the residual of a thin body's tangent stalls at about
        cond(K) x eps of b (1e-9 on the tiny beam, serial and on 2 ranks), as it does after
        a fresh factorisation, and the corrections then fall to ~2e-11 of p."""
        ksp = self.state.newton.snes.getKSP()
        p, r, dp = compat.petsc_vec(self.p), self._residual, self._correction
        b_norm = self.rhs.norm()
        p.zeroEntries()
        self.rhs.copy(r)
        r_norm = b_norm
        for k in range(self.max_refinements + 1):
            ksp.solve(r, dp)
            if linear.reason_of(ksp) < 0:
                return False
            p.axpy(1.0, dp)
            p.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
            if k > 0 and dp.norm() <= self.step_rtol * p.norm():
                self.refinements = k
                return True
            self._exact_residual(r)
            previous, r_norm = r_norm, r.norm()
            if r_norm <= self.refine_rtol * b_norm:
                self.refinements = k
                return True
            if r_norm > 0.5 * previous and k > 1:  # no longer contracting
                break
        log.debug("adjoint: refinement with the state's factors stopped at %.2e of the rhs",
                  r_norm / max(b_norm, 1e-300))
        return False

    def _exact_residual(self, r: PETSc.Vec) -> None:
        """r = b - K(u) p with the tangent at the current state, zero on prescribed DOFs."""
        with r.localForm() as local:
            local.set(0.0)
        dolfinx.fem.petsc.assemble_vector(r, self._action)
        r.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        r.aypx(-1.0, self.rhs)
        compat.set_bc(r, self.state.bcs, alpha=0.0)

    def sensitivities(self) -> list[PETSc.Vec]:
        """dR/df [p, .] for every growth field f, as vectors on the growth space."""
        return [assemble(form) for form in self.design_forms]
