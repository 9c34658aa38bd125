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
``lowest``, in increasing order: near a threshold, the ones that decide it.  A state far past
one can have more negative eigenvalues than ``lowest`` holds, and all of them farther from 0
than its positive ones (measured: the unfiltered shell's lift, 111 negative, ``lowest``
0.16, ...): ``negative`` says so.

Along a growth path (:class:`PathWatch`, called at each converged load step of a solve from
rest) the lowest eigenvalue is followed; where it first crosses zero the path has met a
bifurcation, and ``lost_at`` is the load fraction of the crossing, linear between the two
steps around it.  Where the state's own factorisation is an LDL^T (``solver.linear``
mumps_ldlt, mumps_blr, and auto on large 3D models) its inertia comes free with every Newton
step: the path is then watched by it, and the eigenproblem is solved only at the first step,
where the inertia turns negative and at the end; ``lost_at`` is then the first load step found
unstable (the crossing lies within the step before it).  A path that ends short of its growth
with its lowest eigenvalue fallen to near zero (below ``LIMIT_RATIO`` of its first value) met a
limit point, there.

Past a bifurcation the path from rest goes on along the equilibrium it followed, now unstable
(``solver.branch: follow``), or leaves it for a stable one (``switch``), as a real body with
its imperfections would: the state is moved along the critical mode by the amplitude that
lowers the energy most (doubling from 1e-3 of the body's size while the energy falls, both
signs tried), shifted Newton steps (K + shift M) du = R carry it away from the unstable
equilibrium towards a stable one (:meth:`StabilityProblem.descend`), Newton's method
converges there, and the equilibrium found is kept where it has fewer negative eigenvalues
than the one left (else the path is followed, and tried again at the next step,
``MAX_SWITCHES`` tries in all).  ``branch`` says where the solve ended: ``followed``
(the path from rest) or ``switched`` (at ``switched_at``).
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
from .boundary import body_box
from .options import SolverOptions
from .state import SolveReport

log = logging.getLogger(__name__)

LIMIT_RATIO = 1e-2  # a failed path whose lowest eigenvalue fell below this share of its first
# MUMPS's workspace relaxation (ICNTL(14), % over its estimate), raised where the LDL^T's
# delayed pivots outgrow it (INFOG(1) = -9, seen on PETSc 3.22 with 2 ranks on a cube)
WORKSPACE = (50, 200, 800)
MAX_SWITCHES = 3  # tries at leaving an unstable path, per solve
FIRST_AMPLITUDE = 1e-3  # of the body's size: the first perturbation along the critical mode
LARGEST_AMPLITUDE = 0.25  # of the body's size
STEP_CAP = 0.02  # of the body's size: the largest nodal move of a shifted step (descend)
BRANCHES = ("follow", "switch")


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
    branch: str = "followed"  # "followed" (the path from rest) or "switched"
    switched_at: float | None = None  # load fraction where the solve left the path

    @property
    def stable(self) -> bool:
        return self.negative == 0

    def to_json(self) -> dict[str, object]:
        return {"lowest": list(self.lowest), "stable": self.stable, "negative": self.negative,
                "lost_at": self.lost_at, "kind": self.kind, "branch": self.branch,
                "switched_at": self.switched_at}


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
        self.M = compat.assemble_matrix(mass, state.bcs, diagonal=0.0)
        self.M.assemble()
        self.K = dolfinx.fem.petsc.create_matrix(state.jacobian_form)
        self.mode = dolfinx.fem.Function(V, name="stability_mode")
        self._energy: dolfinx.fem.Form | None = None
        self._order: list[int] = []  # the last solve's eigenpairs, lowest first
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

    def energy(self) -> float:
        """The state's total energy Pi(u) at its current displacement (collective)."""
        if self._energy is None:
            self._energy = dolfinx.fem.form(self.state.energy)
        self.state.u.x.scatter_forward()
        local = dolfinx.fem.assemble_scalar(self._energy)
        return float(self.state.domain.mesh.comm.allreduce(local, MPI.SUM))

    def descend(self, shift: float, cap: float, iterations: int = 100,
                rtol: float = 1e-9) -> bool:
        """Shifted Newton steps from the state's current displacement, (K + shift M) du = R,
        u -= du, each step at most ``cap`` at any node.  About an equilibrium whose negative
        eigenvalues lie above -shift, the iteration moves away from it along their modes (by
        shift / (shift + omega^2), beyond 1 in size, a step) and towards it along the rest,
        so it leaves an unstable equilibrium for a stable one nearby, where Newton's method
        from a perturbed state can return to the unstable one (measured: the hexahedral
        disk).  The shift is controlled by the inertia of K + shift M (MUMPS's LDL^T): halved
        after a step where it is positive definite, doubled where not, so that near the
        stable equilibrium the steps become Newton's; a body of revolution's buckled
        equilibria form a circle, whose tangent is singular along it, where plain Newton
        diverges and these steps do not.  Converged (True) where the residual falls to
        ``rtol`` of the largest it had, or to Newton's absolute tolerance (collective)."""
        state = self.state
        A = self.K.duplicate()
        ksp = PETSc.KSP().create(state.domain.mesh.comm)
        ksp.setOptionsPrefix(self.options.prefix + "descent_")
        ksp.setType("preonly")
        pc = ksp.getPC()
        pc.setType("cholesky")
        pc.setFactorSolverType("mumps")
        ksp.setFromOptions()
        r = compat.create_vector(state.residual_form)
        du = self.K.createVecRight()
        x = compat.petsc_vec(state.u)
        atol = state.snes.getTolerances()[1]
        largest_residual = 0.0
        try:
            for step in range(iterations):
                state.assemble_residual(x, r)
                norm = r.norm()
                largest_residual = max(largest_residual, norm)
                log.debug("    shifted step %d: residual %.3e, shift %.3g", step, norm, shift)
                if not np.isfinite(norm):
                    return False
                if norm <= max(rtol * largest_residual, atol):
                    return True
                state.tangent_into(A)
                A.axpy(shift, self.M, structure=PETSc.Mat.Structure.SUBSET_NONZERO_PATTERN)
                ksp.setOperators(A)
                ksp.solve(r, du)
                definite = int(pc.getFactorMatrix().getMumpsInfog(12)) == 0
                largest = du.norm(PETSc.NormType.INFINITY)
                x.axpy(-min(1.0, cap / largest) if largest > 0 else 0.0, du)
                state.u.x.scatter_forward()
                shift = shift / 2.0 if definite else shift * 2.0
        finally:
            ksp.destroy()
            A.destroy()
        return False

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
        self._order = [i for _, i in pairs[:self.count]]
        lowest = tuple(float(value) for value, _ in pairs[:self.count])
        if pairs:
            self.eps.getEigenpair(pairs[0][1], compat.petsc_vec(self.mode))
            self.mode.x.scatter_forward()
            scale = _global_max(self.mode, np.abs(self.mode.x.array).max(initial=0.0))
            if scale > 0:
                self.mode.x.array[:] /= scale
        return Stability(lowest, negative)


    def modes_into(self, modes: list[dolfinx.fem.Function]) -> list[float]:
        """The last :meth:`assess`'s lowest eigenpairs: their eigenvalues, and their modes
        into ``modes`` (as many as both have), normalised in the mass (phi^T M phi = 1), the
        normalisation under which d(omega^2) = phi^T dK phi (collective)."""
        values = []
        vr, mv = self.K.createVecRight(), self.K.createVecRight()
        for i, f in zip(self._order, modes):
            values.append(float(self.eps.getEigenpair(i, vr).real))
            self.M.mult(vr, mv)
            norm = vr.dot(mv)
            vr.scale(1.0 / np.sqrt(norm) if norm > 0 else 1.0)
            vr.copy(compat.petsc_vec(f))
            f.x.scatter_forward()
        return values


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
    """Follows the stability along a solve from rest (``StateProblem.solve``'s ``watch``,
    called with the load fraction of each converged step; it returns True where it moved the
    state onto another branch).  ``switch``: leave an unstable path (module doc)."""

    def __init__(self, problem: StabilityProblem, switch: bool = False):
        self.problem, self.switch = problem, switch
        self.path: list[tuple[float, float, int]] = []  # (t, lowest or NaN, negative)
        self._last: tuple[float, Stability] | None = None  # the last full assessment
        self.switched_at: float | None = None
        self._tries = 0

    def __call__(self, t: float) -> bool:
        state = self.problem.state
        negative = state.inertia() if self.path and state is not None else None
        if negative == 0:  # stable, known from the Newton step's own LDL^T
            self.path.append((t, float("nan"), 0))
            log.debug("  stability at t = %.4f: no negative pivot", t)
            return False
        try:
            s = self.problem.assess()
        except StabilityError as err:
            log.warning("stability at t = %.4f not assessed: %s", t, err)
            return False
        self._last = (t, s)
        lowest = s.lowest[0] if s.lowest else float("nan")
        self.path.append((t, lowest, s.negative))
        log.debug("  stability at t = %.4f: lowest eigenvalue %.4g, %d negative", t, lowest,
                  s.negative)
        if s.stable or not self.switch or self._tries >= MAX_SWITCHES:
            return False
        self._tries += 1
        after = switch_branch(self.problem, s)
        if after is None:
            log.info("  stability lost at t = %.4f; no stable branch found along the critical "
                     "mode: the path is followed", t)
            return False
        log.info("  stability lost at t = %.4f (lowest eigenvalue %.4g, %d negative): switched "
                 "along the critical mode to a branch with %d negative", t, lowest, s.negative,
                 after.negative)
        self._last = (t, after)
        self.switched_at = t
        return True

    def at(self, reached: float, converged: bool) -> Stability | None:
        """The stability where the solve ended (load fraction ``reached``), with where the
        path lost it and the branch it ended on: the last step's assessment where that step
        ended the solve (the problem's mode is then that state's), else assessed now."""
        now = (self._last[1] if self._last is not None and self._last[0] == reached
               else assess_or_none(self.problem))
        if now is None:
            return None
        lost_at, kind = self.lost(reached, converged, now)
        return dataclasses.replace(
            now, lost_at=lost_at, kind=kind,
            branch="followed" if self.switched_at is None else "switched",
            switched_at=self.switched_at)

    def lost(self, reached: float, converged: bool,
             end: Stability | None = None) -> tuple[float | None, str | None]:
        """(lost_at, kind) of the path watched, ending at ``reached`` (converged or not) in
        the state ``end`` (default: the last step's)."""
        previous: tuple[float, float, int] | None = None
        for t, lowest, negative in self.path:
            if negative > 0:
                if previous is None:
                    return t, "bifurcation"
                t0, l0, _ = previous
                if not (np.isfinite(l0) and np.isfinite(lowest)) or l0 == lowest:
                    return t, "bifurcation"  # known from the inertia: within (t0, t]
                crossing = t0 + (t - t0) * l0 / (l0 - lowest)
                return float(min(max(crossing, t0), t)), "bifurcation"
            previous = (t, lowest, negative)
        first = self.path[0][1] if self.path else float("nan")
        last = end.lowest[0] if end is not None and end.lowest else (
            self.path[-1][1] if self.path else float("nan"))
        if not converged and len(self.path) >= 2 and first > 0 and \
                0 <= last < LIMIT_RATIO * first:
            return reached, "limit_point"
        return None, None


def switch_branch(problem: StabilityProblem, before: Stability) -> Stability | None:
    """Move the state's equilibrium, unstable as ``before`` says, along the problem's lowest
    mode by the amplitude that lowers the energy most, and find the equilibrium there; keep it
    where it has fewer negative eigenvalues (returned), else put the state back (None)."""
    state = problem.state
    if not before.lowest or before.lowest[0] >= 0.0:  # the negative ones lie beyond those found
        return None
    start = state.u.x.array.copy()
    mode = problem.mode.x.array.copy()
    e0 = problem.energy()
    lo, hi = body_box(state.domain.mesh)
    size = float(np.linalg.norm(hi - lo))
    best = (e0, 0.0)
    for sign in (1.0, -1.0):
        amplitude = FIRST_AMPLITUDE * size
        previous = np.inf
        while amplitude <= LARGEST_AMPLITUDE * size:
            state.u.x.array[:] = start + sign * amplitude * mode
            e = problem.energy()
            if not np.isfinite(e) or e >= previous:
                break
            previous = e
            if e < best[0]:
                best = (e, sign * amplitude)
            amplitude *= 2.0
    if best[1] == 0.0:  # the energy does not fall along the mode (to round-off)
        best = (e0, FIRST_AMPLITUDE * size)
    state.u.x.array[:] = start + best[1] * mode
    # Newton's method from there can return to the unstable equilibrium (measured: the
    # hexahedral disk, its pair of modes): shifted steps first, which leave it
    if problem.descend(2.0 * -min(before.lowest), STEP_CAP * size):
        ok, reason = True, ""
    else:
        ok, _, reason = state.equilibrate()
    log.debug("  branch switch: amplitude %.3g along the mode; %s", best[1],
              "an equilibrium" if ok else reason)
    after = None
    if ok:
        try:
            after = problem.assess()
        except StabilityError as err:
            log.warning("stability after a branch switch not assessed: %s", err)
    if after is not None and after.negative < before.negative:
        return after
    state.u.x.array[:] = start
    state.u.x.scatter_forward()
    if after is not None:  # the problem's mode back to the state kept
        problem.assess()
    return None


def solve_watched(state, branch: str = "follow") -> tuple[SolveReport, Stability | None,
                                                         StabilityProblem]:
    """``state.solve()`` with its path watched (and, ``branch`` "switch", left where it
    loses stability): the report, the stability where it ended (None where not assessed)
    and the problem, whose ``mode`` is that state's lowest mode (collective)."""
    problem = StabilityProblem(state)
    watch = PathWatch(problem, switch=branch == "switch")
    report = state.solve(watch=watch)
    return report, watch.at(report.reached, report.converged), problem


def describe(stability: Stability | None) -> str:
    """One line on a stability, for the log."""
    if stability is None:
        return "not assessed"
    lowest = f"{stability.lowest[0]:.4g}" if stability.lowest else "none"
    text = (f"lowest eigenvalue {lowest}, {stability.negative} negative "
            f"({'stable' if stability.stable else 'unstable'})")
    if stability.lost_at is not None:
        text += f"; lost at {stability.lost_at:.4f} of the growth ({stability.kind})"
    if stability.switched_at is not None:
        text += f"; switched branch at {stability.switched_at:.4f}"
    return text
