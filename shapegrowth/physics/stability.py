"""Is an equilibrium stable?  The lowest eigenvalues of the tangent stiffness, and where a
growth path loses stability.

At an equilibrium u of the growth C_g, the tangent K = d^2 Pi / du^2 (5.12), restricted to
the displacements the clamps allow, decides: the equilibrium is stable when K is positive
definite there.  The eigenproblem solved is the generalised one

    K phi = omega^2 M phi,   M = int rho phi . psi dX  (rho = 1; times 2 pi R for a body of
                                                       revolution),

whose eigenvalues are the squared angular frequencies of small vibrations about the
equilibrium for unit density: a modulus over a length squared, independent of the mesh
(the eigenvalues of K alone scale with the element size).  A negative one is an unstable
mode.  The clamped DOFs are rows of the identity in K and of zeros in M: their eigenvalues
are infinite and never among the lowest.

SLEPc solves it by shift-and-invert about 0 with MUMPS's LDL^T factorisation of K, whose
inertia (the number of negative pivots, MUMPS's INFOG(12)) is the number of negative
eigenvalues, however far from 0 they are: ``negative``.  The few eigenvalues nearest 0 are
``lowest``.

Along a growth path (:class:`PathWatch`, called at each converged load step of a solve from
rest) the lowest eigenvalue is followed; where it first crosses zero the path has met a
bifurcation, and ``lost_at`` is the load fraction of the crossing, linear between the two
steps around it.  A path that ends short of its growth with its lowest eigenvalue fallen to
near zero (below ``LIMIT_RATIO`` of its first value) met a limit point, there.
"""

from __future__ import annotations

import dataclasses
import logging
from dataclasses import dataclass

import dolfinx.fem
import dolfinx.fem.petsc
import numpy as np
import ufl
from mpi4py import MPI
from petsc4py import PETSc

from .. import compat
from .options import SolverOptions

log = logging.getLogger(__name__)

LIMIT_RATIO = 1e-2  # a failed path whose lowest eigenvalue fell below this share of its first
# MUMPS's workspace relaxation (ICNTL(14), % over its estimate), raised where the LDL^T's
# delayed pivots outgrow it (INFOG(1) = -9, seen on PETSc 3.22 with 2 ranks on a cube)
WORKSPACE = (50, 200, 800)


class StabilityError(RuntimeError):
    """The eigenproblem could not be solved (reported; the solve's results are kept)."""


@dataclass(frozen=True)
class Stability:
    """summary.json ``stability``: the lowest eigenvalues (squared angular frequencies for unit
    density), the number of negative ones, and where the growth path lost stability."""

    lowest: tuple[float, ...]
    negative: int
    lost_at: float | None = None  # load fraction where the path first lost stability
    kind: str | None = None  # None, "bifurcation" or "limit_point"

    @property
    def stable(self) -> bool:
        return self.negative == 0

    def to_json(self) -> dict[str, object]:
        return {"lowest": list(self.lowest), "stable": self.stable, "negative": self.negative,
                "lost_at": self.lost_at, "kind": self.kind}


class StabilityProblem:
    """The tangent's lowest eigenpairs at the state's current equilibrium (collective)."""

    role = "stability_"

    def __init__(self, state, count: int = 3):
        from slepc4py import SLEPc

        self.state, self.count = state, count
        V = state.V
        u, v = ufl.TrialFunction(V), ufl.TestFunction(V)
        dx = ufl.Measure("dx", domain=V.mesh, metadata={"quadrature_degree":
                                                         2 * state.cfg.model.degree})
        mass = dolfinx.fem.form(ufl.inner(u, v) * state.weight * dx)
        self.M = dolfinx.fem.petsc.assemble_matrix(mass, bcs=state.bcs, diagonal=0.0)
        self.M.assemble()
        self.K = dolfinx.fem.petsc.create_matrix(state.jacobian_form)
        self.mode = dolfinx.fem.Function(V, name="stability_mode")
        self.options = SolverOptions(self.role, {
            "st_ksp_type": "preonly", "st_pc_type": "cholesky",
            "st_pc_factor_mat_solver_type": "mumps",
            "st_mat_mumps_icntl_24": 1,  # a singular K (at a threshold): null pivots kept
        })
        self.eps = SLEPc.EPS().create(V.mesh.comm)
        self.eps.setOptionsPrefix(self.options.prefix)
        self.eps.setOperators(self.K, self.M)
        self.eps.setProblemType(SLEPc.EPS.ProblemType.GHEP)  # M semi-definite
        self.eps.setDimensions(count)
        self.eps.setTarget(0.0)
        self.eps.setWhichEigenpairs(SLEPc.EPS.Which.TARGET_MAGNITUDE)
        self.eps.setTolerances(1e-10, 200)
        self.eps.getST().setType(SLEPc.ST.Type.SINVERT)
        with self.options.pushed():
            self.eps.setFromOptions()

    def assess(self) -> Stability:
        """The stability of the state's equilibrium now; ``self.mode`` the lowest mode."""
        self.state.tangent_into(self.K)
        failure = ""
        for relax in WORKSPACE:
            self.options.defaults["st_mat_mumps_icntl_14"] = relax
            self.eps.setOperators(self.K, self.M)
            try:
                with self.options.pushed():
                    self.eps.setFromOptions()
                    self.eps.solve()
                break
            except PETSc.Error as err:  # MUMPS's INFOG(1) = -9: more workspace (PETSc 3.22)
                self.eps.getST().getKSP().reset()
                failure = f"PETSc error {err.ierr}"
        else:
            raise StabilityError(f"the tangent's eigenproblem failed ({failure})")
        factor = self.eps.getST().getKSP().getPC().getFactorMatrix()
        negative = int(factor.getMumpsInfog(12))
        pairs = []
        vr = self.K.createVecRight()
        for i in range(self.eps.getConverged()):
            value = self.eps.getEigenpair(i, vr).real
            pairs.append((value, i))
        pairs.sort()
        lowest = tuple(float(value) for value, _ in pairs[:self.count])
        if pairs:
            self.eps.getEigenpair(pairs[0][1], compat.petsc_vec(self.mode))
            self.mode.x.scatter_forward()
            scale = _global_max(self.mode, np.abs(self.mode.x.array).max(initial=0.0))
            if scale > 0:
                self.mode.x.array[:] /= scale
        return Stability(lowest, negative)


def _global_max(f: dolfinx.fem.Function, local: float) -> float:
    """The largest |value| of ``f`` over all ranks."""
    return f.function_space.mesh.comm.allreduce(float(local), MPI.MAX)


def assess_or_none(problem: StabilityProblem) -> Stability | None:
    """:meth:`StabilityProblem.assess`, or None (said in one line) where it failed."""
    try:
        return problem.assess()
    except StabilityError as err:
        log.warning("stability not assessed: %s", err)
        return None


class PathWatch:
    """Follows the lowest eigenvalue along a solve from rest (``StateProblem.solve``'s
    ``watch``, called with the load fraction of each converged step)."""

    def __init__(self, problem: StabilityProblem):
        self.problem = problem
        self.path: list[tuple[float, float, int]] = []  # (t, lowest, negative)
        self._last: tuple[float, Stability] | None = None  # the last step's, whole

    def __call__(self, t: float) -> None:
        try:
            s = self.problem.assess()
        except StabilityError as err:
            log.warning("stability at t = %.4f not assessed: %s", t, err)
            return
        self._last = (t, s)
        lowest = s.lowest[0] if s.lowest else float("nan")
        self.path.append((t, lowest, s.negative))
        log.debug("  stability at t = %.4f: lowest eigenvalue %.4g, %d negative", t, lowest,
                  s.negative)

    def at(self, reached: float, converged: bool) -> Stability | None:
        """The stability where the solve ended (load fraction ``reached``), with where the
        path lost it: the last step's assessment where that step ended the solve (the
        problem's mode is then that state's), else assessed now."""
        now = (self._last[1] if self._last is not None and self._last[0] == reached
               else assess_or_none(self.problem))
        if now is None:
            return None
        lost_at, kind = self.lost(reached, converged)
        return dataclasses.replace(now, lost_at=lost_at, kind=kind)

    def lost(self, reached: float, converged: bool) -> tuple[float | None, str | None]:
        """(lost_at, kind) of the path watched, ending at ``reached`` (converged or not)."""
        previous: tuple[float, float, int] | None = None
        for t, lowest, negative in self.path:
            if negative > 0:
                if previous is None:
                    return t, "bifurcation"
                t0, l0, _ = previous
                crossing = t0 + (t - t0) * l0 / (l0 - lowest) if l0 != lowest else t
                return float(min(max(crossing, t0), t)), "bifurcation"
            previous = (t, lowest, negative)
        if not converged and len(self.path) >= 2:
            first, last = self.path[0][1], self.path[-1][1]
            if first > 0 and 0 <= last < LIMIT_RATIO * first:
                return reached, "limit_point"
        return None, None
