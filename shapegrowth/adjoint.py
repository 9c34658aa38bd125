"""The adjoint of the state equation and the sensitivities to the growth fields.

At the converged state, with K = dR/du the tangent (symmetric: R is the first
variation of an energy), the adjoint p solves (5.12)

    K p = -dJ/du,   p = 0 on the clamped DOFs,

and the derivative of the reduced objective with respect to a growth field f is

    dJ/df [mu] = dJ/df|_u [mu] + dR/df [p, mu],

the second term assembled from ``ufl.derivative`` of R(u; p) (the residual with
the test function replaced by p).  The linear solver has the prefix ``adjoint_``
(MUMPS LU of the tangent at the converged state by default).
"""

from __future__ import annotations

import dolfinx.fem
import dolfinx.fem.petsc
import ufl
from petsc4py import PETSc

from .clouds import assemble
from .compat import set_option
from .state import StateProblem


class AdjointProblem:
    prefix = "adjoint_"

    def __init__(self, state: StateProblem):
        self.state = state
        self.p = dolfinx.fem.Function(state.V, name="adjoint")
        self.A = dolfinx.fem.petsc.create_matrix(state.jacobian_form)
        self.rhs = self.A.createVecRight()
        self.ksp = PETSc.KSP().create(state.domain.mesh.comm)
        self.ksp.setOptionsPrefix(self.prefix)
        opts = PETSc.Options()
        defaults = {"ksp_type": "preonly", "pc_type": "lu", "pc_factor_mat_solver_type": "mumps"}
        if state.cfg.solver.linear == "gamg":
            defaults = {"ksp_type": "gmres", "ksp_rtol": 1e-12, "ksp_max_it": 5000,
                        "ksp_gmres_restart": 200, "pc_type": "gamg"}
        for key, value in defaults.items():
            opts[self.prefix + key] = value
        for key, value in state.cfg.solver.petsc_options.items():
            if key.startswith(self.prefix):
                set_option(opts, key, value)
        self.ksp.setFromOptions()
        mu = ufl.TestFunction(state.applied.space)
        coupled = ufl.replace(state.residual_ufl, {state.v: self.p})
        self.design_forms = [dolfinx.fem.form(ufl.derivative(coupled, f, mu))
                             for f in state.applied.fields]

    def solve(self, dJdu: PETSc.Vec) -> int:
        """p for the current state; returns the linear iterations."""
        st = self.state
        self.A.zeroEntries()
        dolfinx.fem.petsc.assemble_matrix(self.A, st.jacobian_form, bcs=st.bcs)
        self.A.assemble()
        dJdu.copy(self.rhs)
        self.rhs.scale(-1.0)
        dolfinx.fem.petsc.set_bc(self.rhs, st.bcs, scale=0.0)  # p = 0 where u is prescribed
        self.ksp.setOperators(self.A)
        self.ksp.solve(self.rhs, self.p.vector)
        if self.ksp.getConvergedReason() < 0:
            raise RuntimeError(f"adjoint solve failed (KSP reason {self.ksp.getConvergedReason()})")
        self.p.x.scatter_forward()
        return self.ksp.getIterationNumber()

    def sensitivities(self) -> list[PETSc.Vec]:
        """dR/df [p, .] for every growth field f, as vectors on the growth space."""
        return [assemble(form) for form in self.design_forms]
