"""The state's Newton solver: PETSc's SNES with the linear solver's preset and its exact
fallback, its PETSc options, the near-nullspace an iterative linear solver needs, and
PETSc's convergence reasons in words."""

from __future__ import annotations

import weakref
from typing import Protocol

import dolfinx.fem
import numpy as np
from mpi4py import MPI
from petsc4py import PETSc

from .. import compat
from ..config import Config, ConfigError
from . import linear
from .linear import preset_options
from .options import SolverOptions
from .pmultigrid import PMultigrid, elements_across, rigid_body_modes


def solver_options(cfg: Config, force_scale: float, linear: str) -> dict[str, object]:
    """PETSc options of the state solver (without a prefix).

    The absolute tolerance is ``solver.atol`` times the body's force scale, so that
    it means the same for a beam of volume 0.002 and a square of area 16: thin bodies
    are soft in bending (a residual of 1e-10 left displacement errors of 1e-6 on the
    beam), while the residual of a body at rest is round-off, ~1e-16 of that scale.
    ``linear``: the linear solver's preset (physics/linear.py), resolved."""
    s = cfg.solver
    opts: dict[str, object] = {
        "snes_type": "newtonls",
        "snes_linesearch_type": s.line_search,
        "snes_max_it": s.max_newton_iterations,
        "snes_rtol": s.rtol,
        "snes_atol": s.atol * force_scale,
        "snes_stol": s.stol,
        "snes_error_if_not_converged": False,
    }
    opts.update(preset_options(linear, "state_"))
    return opts


SNES_REASONS = {  # PETSc's SNESConvergedReason
    2: "converged (atol)", 3: "converged (rtol)", 4: "converged (step)", 5: "converged (its)",
    -1: "function domain error", -2: "too many function evaluations",
    -3: "linear solve failed", -4: "NaN residual", -5: "maximum Newton iterations",
    -6: "line search failed", -7: "inner solve failed", -8: "local minimum",
    -9: "diverged (dtol)", -10: "Jacobian domain error", -11: "trust region collapsed",
}


class _Equations(Protocol):
    """What the Newton solver asks of the problem it solves (physics/state.py's
    StateProblem): the residual and the tangent into PETSc's objects, the unknown, and the
    sample points where the deformation is inverted."""

    w: dolfinx.fem.Function  # the unknown: the displacement, or (u, p) of a mixed body

    def assemble_residual(self, x: PETSc.Vec, b: PETSc.Vec) -> None: ...

    def assemble_tangent(self, x: PETSc.Vec, A: PETSc.Mat) -> None: ...

    def inverted_points(self) -> int: ...


def _alive(ref: weakref.ref[_Equations]) -> _Equations:
    """The problem a solver callback belongs to (a solver outliving its problem is a bug)."""
    problem = ref()
    if problem is None:
        raise RuntimeError("a solver callback outlived its state problem")
    return problem


def _tangent_callback(owner: weakref.ref[_Equations], pmg: PMultigrid | None):
    """SNES's Jacobian callback: the tangent, and where the preset is the p-multigrid, its
    coarse operator (the callback holds the problem weakly: see NewtonSolver)."""
    def tangent(snes: PETSc.SNES, x: PETSc.Vec, J: PETSc.Mat, _P: PETSc.Mat) -> None:
        _alive(owner).assemble_tangent(x, J)
        if pmg is not None:
            pmg.prepare(snes.getKSP(), J)
    return tangent


class NewtonSolver:
    """PETSc SNES for R(u) = 0 (options prefix ``role``): Newton's method with the linear
    solver's preset (physics/linear.py), and where the preset's linear solve fails, the same
    solve again from the same start with the exact factorisation (its own KSP, made at the
    first fallback).  ``A`` and ``b`` hold the tangent and the residual."""

    def __init__(self, role: str, problem: _Equations, cfg: Config, force_scale: float,
                 A: PETSc.Mat, b: PETSc.Vec):
        V = problem.w.function_space  # the unknown's: the displacement's, or (u, p)
        comm = V.mesh.comm
        self.role, self.comm = role, comm
        self._problem = weakref.ref(problem)
        self.snes = PETSc.SNES().create(comm)
        dofs, dim = compat.global_size(V), V.mesh.geometry.dim
        # cells across, where auto could give the body to the p-multigrid: 3D, degree 2
        # displacements alone (a mixed unknown's block size is 1), large enough
        across = (elements_across(V.mesh)
                  if cfg.solver.linear == "auto" and dim == 3 and dofs >= linear.AUTO_PMG_DOFS
                  and V.dofmap.index_map_bs == 3 and compat.space_degree(V) == 2 else None)
        self.linear = linear.choose(cfg.solver.linear, dofs, dim, across)
        # an iterative preset's failed solve falls back to the factorisation its size takes;
        # a direct one's to LU
        self.exact = linear.exact_preset(dofs) if self.linear in linear.ITERATIVE else "mumps"
        self.linear_reason = linear.why(cfg.solver.linear, self.linear, dofs, dim, across)
        # the p-multigrid's interpolation and coarse operator (physics/pmultigrid.py)
        self.pmg = PMultigrid.of(V) if self.linear == "pmg" else None
        defaults = solver_options(cfg, force_scale, self.linear)
        if self.pmg is not None:
            defaults.update(self.pmg.coarse_options())
        self.options = SolverOptions(role, defaults, cfg.solver.petsc_options)
        self.snes.setOptionsPrefix(self.options.prefix)
        # the SNES holds its callbacks, and petsc4py 3.25 does not show them to Python's
        # garbage collector: callbacks holding the state would keep it (its mesh, matrices
        # and MPI communicators) alive for ever.  Measured with dolfinx 0.11's wheel: 17
        # communicators a model, and MPICH's 2048 ran out in a long session (MUMPS then
        # crashed in its symmetric scaling)
        owner = self._problem
        self.snes.setFunction(lambda _snes, x, r: _alive(owner).assemble_residual(x, r), b)
        self.snes.setJacobian(_tangent_callback(owner, self.pmg), A)
        try:
            with self.options.pushed():
                self.snes.setFromOptions()
        except PETSc.Error as err:
            code = linear.error_code(err)
            raise ConfigError([f"solver.petsc_options: PETSc rejected "
                               f"{self.options.user_keys} (error code {code})"]) from None
        if self.linear in linear.MULTIGRID:
            A.setNearNullSpace(rigid_body_modes(V))
        self._exact: tuple[PETSc.KSP, SolverOptions] | None = None  # made at a fallback
        self._preset_failures = 0  # the preset's failed solves in a row
        self.factored_by_preset = False  # the last solve's factors are the preset's

    def exact_ksp(self) -> tuple[PETSc.KSP, SolverOptions]:
        """The exact factorisation a failed solve of another preset falls back to (MUMPS LU,
        LDL^T or LDL^T out of core by the model's size: :func:`linear.exact_preset`): a KSP
        of its own (options prefix ``<state prefix>exact_``), made once, at the first
        fallback."""
        if self._exact is None:
            if self.exact == "mumps_ooc":
                linear.out_of_core_directory()
            ksp = PETSc.KSP().create(self.comm)
            options = SolverOptions(self.role, linear.preset_options(self.exact, self.role),
                                    prefix=self.options.prefix + "exact_")
            ksp.setOptionsPrefix(options.prefix)
            with options.pushed():
                ksp.setFromOptions()
            self._exact = (ksp, options)
        return self._exact

    def solve(self, reference: float | None = None,
              rtol: float | None = None) -> tuple[bool, int, str]:
        """Newton's method from the problem's unknown ``w``; ``reference``: the residual norm its
        relative tolerance is taken of (default: the residual at the start); ``rtol``: that
        tolerance (default solver.rtol).  Converged, iterations, reason."""
        self.factored_by_preset = False
        if self._preset_failures >= linear.GIVE_UP_AFTER:  # the preset does not hold here
            return self._exact_solve(reference, rtol)
        w = _alive(self._problem).w
        start = w.x.array.copy() if self.linear != "mumps" else None
        ok, its, reason, linear_failed = self._snes_solve(reference, rtol)
        if not linear_failed or start is None:
            self._preset_failures = 0
            self.factored_by_preset = its > 0
            return ok, its, reason
        linear.record_fallback(self.role, self.linear, reason, self.exact)
        linear.reset_after_failure(self.snes.getKSP())
        self._preset_failures += 1
        if self._preset_failures == linear.GIVE_UP_AFTER:
            linear.give_up(self.role, self.linear, self.exact)
        w.x.array[:] = start
        ok, more, reason = self._exact_solve(reference, rtol)
        return ok, its + more, reason

    def release_factors(self) -> None:
        """Free the factorisations the last solve left (the preset's and the exact
        fallback's): the next solve factors anew.  For a solver about to factor another
        operator of the same size (paths.descend; measured: the cube at x2 in core, the
        Newton, eigensolve and descent factors held at once, 12.8 GB on rank 0 of 2,
        killed for memory on this 24 GB machine)."""
        linear.free_factorisation(self.snes.getKSP())
        if self._exact is not None:
            linear.free_factorisation(self._exact[0])
        self.factored_by_preset = False

    def inertia(self) -> int | None:
        """The number of negative pivots of the last Newton step's factorisation where it is
        MUMPS's LDL^T of the tangent (its inertia: the tangent's negative eigenvalues, at
        the state one step before the converged one), else None (collective)."""
        pc = self.snes.getKSP().getPC()
        if not self.factored_by_preset or pc.getType() != "cholesky" or \
                pc.getFactorSolverType() != "mumps":
            return None
        return int(pc.getFactorMatrix().getMumpsInfog(12))

    def _exact_solve(self, reference: float | None, rtol: float | None) -> tuple[bool, int, str]:
        """:meth:`_snes_solve` with the exact factorisation in place of the preset's KSP."""
        ksp, options = self.exact_ksp()
        preset = self.snes.getKSP()
        self.snes.setKSP(ksp)
        try:
            with options.pushed():
                ok, its, reason, _ = self._snes_solve(reference, rtol)
        finally:
            self.snes.setKSP(preset)
        return ok, its, reason

    def _snes_solve(self, reference: float | None,
                    rtol: float | None) -> tuple[bool, int, str, bool]:
        """One SNES solve (see :meth:`solve`); the last: whether its linear solver failed
        (PETSc's reason in the third)."""
        problem = _alive(self._problem)
        x = compat.petsc_vec(problem.w)
        tolerances = self.snes.getTolerances()  # rtol, atol, stol, max_it
        rtol = tolerances[0] if rtol is None else rtol
        if reference is not None:  # the same stopping residual as without the predictor
            self.snes.setTolerances(rtol=0.0, atol=max(rtol * reference, tolerances[1]))
        elif rtol != tolerances[0]:
            self.snes.setTolerances(rtol=rtol)
        try:
            with self.options.pushed():
                self.snes.solve(None, x)
        except PETSc.Error as err:  # e.g. a factorisation that broke down
            failure = f"PETSc error {linear.error_code(err)}"
            return False, self.snes.getIterationNumber(), failure, True
        finally:
            if reference is not None or rtol != tolerances[0]:
                self.snes.setTolerances(rtol=tolerances[0], atol=tolerances[1])
        reason = linear.reason_of(self.snes)
        its = self.snes.getIterationNumber()
        by_preset = self._exact is None or self.snes.getKSP() is not self._exact[0]
        if self.linear in linear.ITERATIVE and by_preset:
            linear.count_krylov(its, self.snes.getLinearSolveIterations())
        problem.w.x.scatter_forward()
        ok = self.comm.allreduce(
            bool(reason > 0 and np.isfinite(problem.w.x.array).all()), MPI.LAND)
        if not ok:
            if reason == PETSc.SNES.ConvergedReason.DIVERGED_LINEAR_SOLVE:
                return False, its, linear.ksp_reason(self.snes.getKSP()), True
            return False, its, SNES_REASONS.get(reason, str(reason)), False
        inverted = problem.inverted_points()
        if inverted:
            return False, its, f"det F <= 0 at {inverted} sample points", False
        return True, its, SNES_REASONS[reason], False
