"""Growth paths from rest: where they lose stability, and the stable branch past it.

Along a growth path (:class:`PathWatch`, called at each converged load step of a solve from
rest) the lowest eigenvalue is followed; where it first crosses zero the path has met a
bifurcation, and ``lost_at`` is the load fraction of the crossing, linear between the two
steps around it.  Where the state's own factorisation is an LDL^T (``solver.linear``
mumps_ldlt, mumps_ooc, mumps_blr, and auto on large 3D models) its inertia comes free with
every Newton step: the path is then watched by it, and the eigenproblem is solved only at the
first step, where the inertia turns negative and at the end; ``lost_at`` is then the first
load step found unstable (the crossing lies within the step before it).  A path that ends
short of its growth with its lowest eigenvalue fallen to near zero (below ``LIMIT_RATIO`` of
its first value) met a limit point, there.

Past a bifurcation the path from rest goes on along the equilibrium it followed, now unstable
(``solver.branch: follow``), or leaves it for a stable one (``switch``), as a real body with
its imperfections would: the state is moved along the critical mode by the amplitude that
lowers the energy most (doubling from 1e-3 of the body's size while the energy falls, both
signs tried), shifted Newton steps (K + shift M) du = R carry it away from the unstable
equilibrium towards a stable one (:func:`descend`), Newton's method
converges there, and the equilibrium found is kept where it has fewer negative eigenvalues
than the one left (else the path is followed, and tried again at the next step,
``MAX_SWITCHES`` tries in all).  A mixed body's unknown (u, p) moves along the whole
eigenvector, and its shifted steps count the inertia less its pressure DOFs, as
StabilityProblem does.  ``branch`` says where the solve ended: ``followed``
(the path from rest) or ``switched`` (at ``switched_at``).

A state carried from a coarser mesh (a check continued onto a finer one) is solved by
Newton's method at the full growth; where that finds no equilibrium, the same shifted steps
take it from the carried start (:func:`settle_carried`).
"""

from __future__ import annotations

import dataclasses
import gc
import logging
import time
from collections.abc import Callable
from dataclasses import dataclass

import dolfinx.fem
import numpy as np
from mpi4py import MPI
from petsc4py import PETSc

from .. import compat, heap
from .boundary import body_box
from .options import SolverOptions
from .stability import Stability, StabilityError, StabilityProblem, assess_or_none
from .state import SolveReport, StateProblem

log = logging.getLogger(__name__)

LIMIT_RATIO = 1e-2  # a failed path whose lowest eigenvalue fell below this share of its first
MAX_SWITCHES = 3  # tries at leaving an unstable path, per solve
FIRST_AMPLITUDE = 1e-3  # of the body's size: the first perturbation along the critical mode
LARGEST_AMPLITUDE = 0.25  # of the body's size
STEP_CAP = 0.02  # of the body's size: the largest nodal move of a shifted step (descend)


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
        negative = self.problem.state.newton.inertia() if self.path else None
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
    # assess() looks below 0 for the unstable modes; none found there: no mode to follow
    if not before.lowest or before.lowest[0] >= 0.0:
        return None
    # the unknown moves along the whole eigenvector: a mixed body's pressure with its
    # displacement (the mode's pressure is the linearised response to its displacement, so
    # the Lagrangian along it is the energy with the pressure eliminated, to second order)
    start = state.w.x.array.copy()
    mode = problem.unknown_mode.x.array.copy()
    e0 = problem.energy()
    size = _body_size(state)
    best = (e0, 0.0)
    for sign in (1.0, -1.0):
        amplitude = FIRST_AMPLITUDE * size
        previous = np.inf
        while amplitude <= LARGEST_AMPLITUDE * size:
            state.w.x.array[:] = start + sign * amplitude * mode
            e = problem.energy()
            if not np.isfinite(e) or e >= previous:
                break
            previous = e
            if e < best[0]:
                best = (e, sign * amplitude)
            amplitude *= 2.0
    if best[1] == 0.0:  # the energy does not fall along the mode (to round-off)
        best = (e0, FIRST_AMPLITUDE * size)
    state.w.x.array[:] = start + best[1] * mode
    state.sync()
    # Newton's method from there can return to the unstable equilibrium (measured: the
    # hexahedral disk, its pair of modes): shifted steps first, which leave it
    if descend(problem, 2.0 * -min(before.lowest), STEP_CAP * size)[0]:
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
    state.w.x.array[:] = start
    state.w.x.scatter_forward()
    state.sync()
    if after is not None:  # the problem's mode back to the state kept
        problem.assess()
    return None


def solve_watched(state: StateProblem, branch: str = "follow"
                  ) -> tuple[SolveReport, Stability | None, StabilityProblem]:
    """``state.solve()`` with its path watched (and, ``branch`` "switch", left where it
    loses stability): the report, the stability where it ended (None where not assessed)
    and the problem, whose ``mode`` is that state's lowest mode (collective).  A carried
    start (``state.carry``) where Newton's method finds no equilibrium is taken again by
    shifted Newton steps (:func:`settle_carried`)."""
    problem = StabilityProblem(state, shared_tangent=True)  # a solve from rest
    watch = PathWatch(problem, switch=branch == "switch")
    start = state.snapshot() if state.carried else None
    report = state.solve(watch=watch)
    if start is not None and not report.converged:
        report = settle_carried(problem, start, report)
    return report, watch.at(report.reached, report.converged), problem


def settle_carried(problem: StabilityProblem, start: np.ndarray, failed: SolveReport
                   ) -> SolveReport:
    """The equilibrium nearest the carried start ``start`` (owned DOFs) of a state whose
    Newton's method from it ``failed`` (the state holds the full growth): shifted Newton
    steps (:func:`descend`) from it, the shift twice the magnitude of the start's lowest
    eigenvalue.  Measured: scene 4's cone, its equilibrium on the mesh refined once carried
    onto the mesh refined twice, is a start with 9 negative eigenvalues there (the lowest
    -0.034) from which Newton's method diverged (dtol) in 4 iterations.  The report: the
    failed one's with the steps taken, converged where they found an equilibrium without an
    inverted point; else the state back at ``start`` (collective)."""
    state = problem.state
    tic = time.perf_counter()
    _put_back(state, start)
    state.newton.release_factors()  # the failed Newton's, before the eigensolve's
    try:
        lowest = problem.assess().lowest
    except StabilityError as err:
        log.warning("no equilibrium near the carried state, whose stability is not assessed "
                    "(%s): no shifted steps", err)
        return failed
    shift = 2.0 * abs(lowest[0]) if lowest and lowest[0] != 0.0 else 1.0
    log.info("  %s: shifted Newton steps from it (its lowest eigenvalue %.4g, shift %.3g)",
             failed.reason, lowest[0] if lowest else float("nan"), shift)
    converged, steps = descend(problem, shift, STEP_CAP * _body_size(state))
    inverted = state.inverted_points() if converged else 0
    report = dataclasses.replace(failed, shifted_steps=steps,
                                 seconds=failed.seconds + time.perf_counter() - tic)
    if converged and not inverted:
        log.info("  an equilibrium after %d shifted Newton steps", steps)
        return dataclasses.replace(report, converged=True, reason="", reached=1.0)
    _put_back(state, start)
    why = f"det F <= 0 at {inverted} sample points" if inverted else \
        f"no equilibrium in {steps} shifted Newton steps"
    return dataclasses.replace(report, reason=f"{failed.reason}; {why}")


def _body_size(state: StateProblem) -> float:
    """The diagonal of the body's box: the scale of a branch switch's moves (collective)."""
    lo, hi = body_box(state.domain.mesh)
    return float(np.linalg.norm(hi - lo))


def _put_back(state: StateProblem, owned: np.ndarray) -> None:
    """The state's displacement back to ``owned`` (a :meth:`StateProblem.snapshot`), its
    equilibrium bookkeeping untouched."""
    state.put_back(owned)


@dataclass(frozen=True)
class Continued:
    """The start of a check continued onto a finer mesh (``shapegrowth verify --continued``):
    the displacement of the same body's equilibrium on a coarser mesh, grown from rest
    there; the check's refinement it was made at, and that solve's wall time (counted in
    the check's)."""

    displacement: dolfinx.fem.Function
    refine: int
    seconds: float


def equilibrium_from_rest(build: Callable[[], StateProblem], refine: int,
                          branch: str = "follow") -> tuple[Continued | None, SolveReport]:
    """The state ``build`` makes (a growth at rest, on the mesh of the check's refinement
    ``refine``) grown from rest with its path watched (:func:`solve_watched`): the start of
    a check continued onto a finer mesh, and the solve's report; None where it found no
    equilibrium.  Only the displacement is kept: the state's factors are freed before the
    caller factors another (collective).

    From rest on a mesh refined twice a check takes a factorisation of a million DOFs or
    more per Newton iteration, and 74-107 of them on the verification's meshes
    (docs/PERFORMANCE.md, 'What a refined-twice check would need'): hours.  Continued, the
    path from rest - and with it the branch - is the coarser mesh's, and the finer mesh takes
    the few Newton iterations from its equilibrium to its own, its stability assessed
    there."""
    tic = time.perf_counter()
    state = build()
    log.info("grown from rest on %d DOFs, to be continued on a finer mesh",
             compat.global_size(state.V))
    report, _, _ = solve_watched(state, branch)
    u = state.u if report.converged else None
    del state
    gc.collect()  # its factors, before the finer mesh's
    if u is None:
        return None, report
    return Continued(u, refine, time.perf_counter() - tic), report


def descend(problem: StabilityProblem, shift: float, cap: float, iterations: int = 100,
            rtol: float = 1e-9) -> tuple[bool, int]:
    """Shifted Newton steps from the state's current displacement, (K + shift M) du = R,
    u -= du, each step at most ``cap`` at any node.  About an equilibrium whose negative
    eigenvalues lie above -shift, the iteration moves away from it along their modes (by
    shift / (shift + omega^2), beyond 1 in size, a step) and towards it along the rest,
    so it leaves an unstable equilibrium for a stable one nearby, where Newton's method
    from a perturbed state can return to the unstable one (measured: the hexahedral
    disk).  The shift is controlled by the inertia of K + shift M (MUMPS's LDL^T): halved
    after a step where it is positive definite, raised where not, so that near the
    stable equilibrium the steps become Newton's; a body of revolution's buckled
    equilibria form a circle, whose tangent is singular along it, where plain Newton
    diverges and these steps do not.  No step is taken with an indefinite K + shift M (its
    direction is no descent of the energy): the shift is raised 4x and the operator
    factored again.  Measured: a start whose eigenvalues found lie nearest 0 while others
    lie far below (scene 4's cone carried from its own mesh onto x1: the lowest found
    -0.0087, K + 284 M still indefinite), stepped with the indefinite operator, was driven
    to a shift of 35 and a residual 18x its start's in 12 steps; without those steps it
    settled on the equilibrium from rest in 35 factorisations, 15 of them the shift's
    doublings (4x: 8 of them).
    Converged where the residual falls to ``rtol`` of the largest it had, or to Newton's
    absolute tolerance; and the factorisations made (collective).  Its factor is out of
    core where the state's is (mumps_ooc)."""
    state = problem.state
    # one factorisation in memory at a time: Newton's and the eigensolve's are freed first
    state.newton.release_factors()
    problem.release_factor()
    A = problem.K.duplicate()
    options = SolverOptions(problem.role, {
        "ksp_type": "preonly", "pc_type": "cholesky", "pc_factor_mat_solver_type": "mumps",
        "mat_mumps_icntl_14": 30,
        **({"mat_mumps_icntl_22": 1} if state.newton.linear == "mumps_ooc" else {}),
    }, prefix=problem.options.prefix + "descent_")
    ksp = PETSc.KSP().create(state.domain.mesh.comm)
    ksp.setOptionsPrefix(options.prefix)
    with options.pushed():
        ksp.setFromOptions()
    pc = ksp.getPC()
    r = compat.create_vector(state.residual_form)
    du = problem.K.createVecRight()
    x = compat.petsc_vec(state.w)
    moved_by = dolfinx.fem.Function(state.V)  # du's displacement: the step cap is of u
    atol = state.newton.snes.getTolerances()[1]
    largest_residual = 0.0
    moved = True  # the residual (and the tangent) are those of the current state otherwise
    try:
        for step in range(iterations):
            if moved:
                state.assemble_residual(x, r)
                norm = r.norm()
                largest_residual = max(largest_residual, norm)
                # each a factorisation (minutes on a million DOFs): in the progress log
                log.info("    shifted step %d: residual %.3e, shift %.3g", step, norm, shift)
                if not np.isfinite(norm):
                    return False, step
                if norm <= max(rtol * largest_residual, atol):
                    return True, step
                state.tangent_into(A)
                A.axpy(shift, problem.M, structure=PETSc.Mat.Structure.SUBSET_NONZERO_PATTERN)
            else:  # the same tangent, the shift raised 4x since
                A.axpy(0.75 * shift, problem.M,
                       structure=PETSc.Mat.Structure.SUBSET_NONZERO_PATTERN)
            ksp.setOperators(A)
            with options.pushed():  # MUMPS reads its options at the factorisation
                ksp.solve(r, du)
            # a mixed body's pressure DOFs are as many negative pivots (StabilityProblem)
            negative = int(pc.getFactorMatrix().getMumpsInfog(12)) - problem.constraints
            moved = negative == 0
            if moved:
                state.displacement_of(du, moved_by)
                largest = state.domain.mesh.comm.allreduce(
                    float(np.abs(moved_by.x.array).max(initial=0.0)), MPI.MAX)
                x.axpy(-min(1.0, cap / largest) if largest > 0 else 0.0, du)
                state.w.x.scatter_forward()
                state.sync()
                shift /= 2.0
            else:
                log.info("    shifted step %d: K + %.3g M has %d negative eigenvalues: no "
                         "step, the shift raised 4x", step, shift, negative)
                shift *= 4.0
    finally:
        ksp.destroy()
        A.destroy()
        heap.trim()
    return False, iterations
