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
0.16, ...): ``negative`` says so, and the eigenproblem is then solved again about a target
below 0, moved down by doublings until negative ones are among those found, so that
``lowest`` (and the mode a branch switch follows) holds unstable modes where there are any.

A mixed body (``material.formulation: mixed``, its unknown (u, p)) has the saddle-point
tangent A = [[K, B^T], [B, -C]] (C = M_p / kappa, or 0 where incompressible); its stability
is that of the constrained tangent, K + B^T C^-1 B (or K on the displacements that keep
J = 1), the same energy's once the pressure is eliminated.  The pencil (A, diag(M, 0)) has
exactly that operator's eigenvalues (the pressure's are infinite, never among the lowest),
and by Haynsworth's inertia theorem (or, incompressible, the saddle point's, B of full rank)
A - sigma diag(M, 0) has n_p more negative pivots than it has negative eigenvalues, n_p the
number of pressure DOFs: ``negative`` is the inertia less n_p.  The mode is the eigenvector's
displacement.  Tested against a dense elimination of the pressure (tests/test_stability.py).

With ``solver.linear: pmg`` nothing is factorised: the generalised Davidson method finds the
``count`` smallest eigenvalues of the pencil, preconditioned by the state's p-multigrid on
K, in a few vectors (LOBPCG broke down where the coarse level is GAMG: its Rayleigh-Ritz
Gram matrix lost definiteness, LAPACK's sygvd info > n, on the beam of
benchmarks/beam_bend_1M.yaml).  The clamped rows' zeros of M would make the pencil singular:
they get a mass 1/(1000 b), b = max K_ii / M_ii over the free rows, so that their eigenvalue
1000 b lies above the Rayleigh quotient of every free unit vector, hence above the lowest.
``negative`` is then the number of negative ones among those found, a lower bound where all
``count`` are negative (the inertia is a factorisation's).  Tested against the LDL^T's
eigenvalues (tests/test_stability.py).

Along a growth path from rest, physics/paths.py watches it and, on request, leaves it for a
stable branch.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import dolfinx.fem
import dolfinx.fem.petsc
import numpy as np
import ufl
from mpi4py import MPI
from petsc4py import PETSc

from .. import compat, heap
from . import linear
from .options import SolverOptions

log = logging.getLogger(__name__)

# MUMPS's workspace relaxation (ICNTL(14), % over its estimate), raised where the LDL^T's
# delayed pivots outgrow it (INFOG(1) = -9, seen on PETSc 3.22 with 2 ranks on a cube)
WORKSPACE = (50, 200, 800)
RETARGETS = 12  # doublings of the target below 0 that look for negative eigenvalues (4096x)
CLAMPED_ABOVE = 1e3  # the clamped rows' eigenvalue over the free rows' largest K_ii / M_ii
DAVIDSON_TOLERANCE = 1e-8  # relative residual (measured: eigenvalues to 1e-8 of the LDL^T's)
SPARE_PAIRS = 2  # the Davidson method's eigenpairs beyond the ``count`` kept


def _holds_negative(pairs: list[tuple[float, int]]) -> bool:
    """Whether eigenpairs (value, index), lowest first, hold a negative eigenvalue."""
    return bool(pairs) and pairs[0][0] < 0.0


def without_zeros(A: PETSc.Mat) -> PETSc.Mat:
    """A copy of the assembled AIJ matrix ``A`` without its stored zeros.  The vector mass
    matrix is assembled into the tangent's pattern (3 x 3 blocks in 3D), but u . v couples no
    two components: two thirds of the stored entries are zeros (tests/test_stability.py).
    The copy's pattern is a subset of ``A``'s (what adding it to K asks)."""
    indptr, indices, values = A.getValuesCSR()
    keep = values != 0.0
    rows = np.repeat(np.arange(len(indptr) - 1), np.diff(indptr))
    counts = np.bincount(rows[keep], minlength=len(indptr) - 1)
    kept_ptr = np.concatenate([[0], np.cumsum(counts)]).astype(indptr.dtype)
    B = PETSc.Mat().createAIJ(A.getSizes(), bsize=A.getBlockSize(),
                              csr=(kept_ptr, indices[keep], values[keep]), comm=A.getComm())
    B.assemble()
    return B


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

    def __init__(self, state, count: int = 3, shared_tangent: bool = False):
        """``shared_tangent``: assemble K into the state solver's own matrix instead of one of
        its own, where no factor of that matrix is reused after an assessment (a solve from
        rest: Newton assembles and factors it anew at its next step; not an optimiser's,
        whose chord steps and adjoint reuse the state's factors of it).  Saves a matrix the
        size of the tangent (with the mass matrix without its zeros, scene 1's 149k DOFs grown
        from rest out of core: peak 1 444-1 552 MB against 1 667-1 784: docs/PERFORMANCE.md)."""
        from slepc4py import SLEPc

        self.state, self.count = state, count
        self.mode = dolfinx.fem.Function(state.V, name="stability_mode")
        # the lowest eigenvector whole, as the mode: a mixed body's with its pressure (a
        # branch switch moves the unknown along it); the displacement's mode itself otherwise
        self.unknown_mode = (dolfinx.fem.Function(state.W, name="stability_mode_unknown")
                             if state.mixed else self.mode)
        # Where the state's factor is out of core (mumps_ooc: memory before time), so is this
        # one: in core it would set the solve's peak (scene 1's 149k DOFs on 2 ranks, from
        # rest: 3.93 GB with both in core, mumps_ldlt; 2.74 GB with the state's alone out of
        # core; 1.65 GB with both: docs/PERFORMANCE.md, "Out of core")
        out_of_core = state.newton.linear == "mumps_ooc"
        V = state.V
        if state.mixed:  # the mass of the displacement alone: (A, diag(M, 0)) (module doc)
            u, v = ufl.split(ufl.TrialFunction(state.W))[0], ufl.split(ufl.TestFunction(
                state.W))[0]
            dofmap = state.W.sub(1).collapse()[0].dofmap
            self.constraints = dofmap.index_map.size_global * dofmap.index_map_bs
        else:
            u, v = ufl.TrialFunction(V), ufl.TestFunction(V)
            self.constraints = 0  # the pressure DOFs' negative pivots (module doc)
        dx = ufl.Measure("dx", domain=V.mesh, metadata={"quadrature_degree":
                                                         2 * state.cfg.model.degree})
        mass = dolfinx.fem.form(ufl.inner(u, v) * state.weight * dx)
        full = compat.assemble_matrix(mass, state.bcs, diagonal=0.0)
        full.assemble()
        # solver.linear pmg: the eigensolve preconditioned by the p-multigrid (module doc)
        self.pmg = None if state.newton.pmg is None else (
            state.newton.pmg if shared_tangent else state.newton.pmg.sibling())
        self._previous: list[PETSc.Vec] = []  # the Davidson method's last modes
        if self.pmg is not None:  # the clamped rows' diagonal kept; assess() sets it
            diagonal = full.getDiagonal()
            self._clamped = diagonal.getArray() == 0.0
            diagonal.getArray()[self._clamped] = 1.0
            full.setDiagonal(diagonal)
            full.assemble()
            diagonal.destroy()
        self.M = without_zeros(full)  # the mass couples no two components: a third of K's
        full.destroy()
        self.K = state.A if shared_tangent else dolfinx.fem.petsc.create_matrix(
            state.jacobian_form)
        self._energy: dolfinx.fem.Form | None = None
        self._order: list[int] = []  # the last solve's eigenpairs, lowest first
        if self.pmg is None:
            self.options = SolverOptions(self.role, {
                "st_ksp_type": "preonly", "st_pc_type": "cholesky",
                "st_pc_factor_mat_solver_type": "mumps",
                "st_mat_mumps_icntl_24": 1,  # a singular K (at a threshold): null pivots kept
                **({"st_mat_mumps_icntl_22": 1} if out_of_core else {}),
            })
        else:
            self.options = SolverOptions(self.role, {
                "st_ksp_type": "preonly",
                **{f"st_{key}": value for key, value in linear.PMG_OPTIONS.items()},
                **{f"st_{key}": value for key, value in self.pmg.coarse_options().items()}})
        self.eps = SLEPc.EPS().create(V.mesh.comm)
        self.eps.setOptionsPrefix(self.options.prefix)
        self.eps.setOperators(self.K, self.M)
        self.eps.setProblemType(SLEPc.EPS.ProblemType.GHEP)  # M semi-definite
        if self.pmg is None:
            self.eps.setDimensions(count)
            self.eps.setTarget(0.0)
            self.eps.setWhichEigenpairs(SLEPc.EPS.Which.TARGET_MAGNITUDE)
            self.eps.setTolerances(1e-10, 200)
            self.eps.getST().setType(SLEPc.ST.Type.SINVERT)
        else:
            self.eps.setType(SLEPc.EPS.Type.GD)
            # two pairs beyond those kept: asked for 3 alone, started from the last step's
            # modes, it missed the bar's third eigenvalue (0.981) for the fourth (1.007)
            self.eps.setDimensions(count + SPARE_PAIRS)
            self.eps.setWhichEigenpairs(SLEPc.EPS.Which.SMALLEST_REAL)
            self.eps.setTolerances(DAVIDSON_TOLERANCE, 2000)
            self.eps.getST().setType(SLEPc.ST.Type.PRECOND)
        with self.options.pushed():
            self.eps.setFromOptions()

    def energy(self) -> float:
        """The state's total energy Pi at its current unknown (collective): a mixed body's
        Lagrangian in (u, p)."""
        if self._energy is None:
            self._energy = dolfinx.fem.form(self.state.energy)
        self.state.w.x.scatter_forward()
        local = dolfinx.fem.assemble_scalar(self._energy)
        return float(self.state.domain.mesh.comm.allreduce(local, MPI.SUM))

    def assess(self) -> Stability:
        """The stability of the state's equilibrium now; ``self.mode`` the lowest mode."""
        # the freed pages of the state's last factorisations back to the system before this
        # factor is made, and this one's after it (heap.py: the peak at 21k DOFs out of core,
        # 2 ranks: 796 -> 559 MB)
        heap.trim()
        self.state.tangent_into(self.K)
        if self.pmg is not None:
            pairs = self._solve_preconditioned()
            negative = sum(value < 0.0 for value, _ in pairs)
            if negative == len(pairs) == self.count:
                log.debug("  stability: the %d eigenvalues found are negative: %d or more "
                          "negative", self.count, self.count)
            return self._keep(pairs, negative)
        factor = self._solve(0.0)
        negative = int(factor.getMumpsInfog(12)) - self.constraints
        pairs = self._pairs()
        # Negative eigenvalues that all lie beyond the ones nearest 0 (a state far past a
        # threshold; measured: the shell's lift, 4 negative, the nearest 0.020, 0.020, 0.044)
        # are looked for about a target below 0, doubled from the farthest found until one
        # is among those found: the unstable modes are what a branch switch follows.
        reach = max((abs(value) for value, _ in pairs), default=1.0)
        target = 0.0
        for _ in range(RETARGETS):
            if negative == 0 or _holds_negative(pairs):
                break
            target = 2.0 * target if target else -2.0 * reach
            below = int(self._solve(target).getMumpsInfog(12)) - self.constraints
            pairs = self._pairs()
            log.debug("  stability: %d negative beyond the %d nearest 0; about %.4g: %s",
                      negative, self.count, target, [round(v, 6) for v, _ in pairs])
            if below == 0 and not _holds_negative(pairs):
                break  # none below the target, and none found above it
        return self._keep(pairs, negative)

    def _keep(self, pairs: list[tuple[float, int]], negative: int) -> Stability:
        """The stability of the eigenpairs ``pairs`` (lowest first); the mode the lowest's."""
        self._order = [i for _, i in pairs]
        lowest = tuple(float(value) for value, _ in pairs)
        if pairs:
            vr = self.K.createVecRight()
            self.eps.getEigenpair(pairs[0][1], vr)
            self.state.displacement_of(vr, self.mode)
            if self.state.mixed:
                vr.copy(compat.petsc_vec(self.unknown_mode))
                self.unknown_mode.x.scatter_forward()
            vr.destroy()
            scale = _global_max(self.mode, np.abs(self.mode.x.array).max(initial=0.0))
            if scale > 0:
                self.mode.x.array[:] /= scale
                if self.state.mixed:
                    self.unknown_mode.x.array[:] /= scale
        heap.trim()
        return Stability(lowest, negative)

    def release_factor(self) -> None:
        """Free the eigensolve's factorisation (the next :meth:`assess` factors anew) and
        the freed pages back to the system."""
        self.eps.getST().getKSP().reset()
        heap.trim()

    def _solve(self, target: float) -> PETSc.Mat:
        """Solve the eigenproblem about ``target``; the shifted operator's factor (whose
        inertia is the number of eigenvalues below the target)."""
        failure = ""
        self.eps.setTarget(target)
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
                failure = f"PETSc error {linear.error_code(err)}"
        else:
            raise StabilityError(f"the tangent's eigenproblem failed ({failure})")
        return self.eps.getST().getKSP().getPC().getFactorMatrix()

    def _solve_preconditioned(self) -> list[tuple[float, int]]:
        """Generalised Davidson on (K, M) with the p-multigrid of K, the clamped rows' mass
        set above the lowest (module doc): the lowest ``count`` eigenpairs (collective)."""
        assert self.pmg is not None
        stiffness, mass = self.K.getDiagonal(), self.M.getDiagonal()
        k, m = stiffness.getArray(), mass.getArray()
        free = ~self._clamped
        local = float(np.max(k[free] / m[free], initial=0.0))
        bound = self.K.getComm().tompi4py().allreduce(local, MPI.MAX)
        m[self._clamped] = 1.0 / (CLAMPED_ABOVE * bound)
        self.M.setDiagonal(mass)
        self.M.assemble()
        stiffness.destroy()
        mass.destroy()
        self.eps.setOperators(self.K, self.M)
        ksp = self.eps.getST().getKSP()
        ksp.setOperators(self.K)
        with self.options.pushed():
            self.eps.setFromOptions()
            ksp.setFromOptions()
        self.pmg.prepare(ksp, self.K)
        if self._previous:  # the last assessment's modes: a path's next step starts near them
            self.eps.setInitialSpace(self._previous)
        try:
            self.eps.solve()
        except PETSc.Error as err:
            ksp.reset()
            raise StabilityError(f"the tangent's eigenproblem failed (GD: PETSc error "
                                 f"{linear.error_code(err)})") from err
        if self.eps.getConverged() < self.count:  # the spare pairs are not asked for
            raise StabilityError(f"generalised Davidson found {self.eps.getConverged()} of "
                                 f"{self.count} eigenpairs in {self.eps.getIterationNumber()} "
                                 "iterations")
        log.debug("  stability: generalised Davidson with the p-multigrid, %d iterations",
                  self.eps.getIterationNumber())
        pairs = self._pairs()
        for vec in self._previous:
            vec.destroy()
        self._previous = []
        for _, i in pairs:
            vec = self.K.createVecRight()
            self.eps.getEigenpair(i, vec)
            self._previous.append(vec)
        return pairs

    def _pairs(self) -> list[tuple[float, int]]:
        """The lowest ``count`` of the last solve's converged eigenpairs (those nearest its
        target): (value, index), lowest first."""
        pairs = []
        vr = self.K.createVecRight()
        for i in range(self.eps.getConverged()):
            pairs.append((self.eps.getEigenpair(i, vr).real, i))
        vr.destroy()
        pairs.sort()
        return pairs[:self.count]

    def modes_into(self, modes: list[dolfinx.fem.Function]) -> list[float]:
        """The last :meth:`assess`'s lowest eigenpairs: their eigenvalues, and their modes
        into ``modes`` (as many as both have, functions of the unknown's space),
        normalised in the mass (phi^T M phi = 1), the normalisation under which
        d(omega^2) = phi^T dK phi (collective).  A mixed body's mode is the whole eigenvector
        (u, p) of the pencil (K, diag(M, 0)), normalised by its displacement's mass: for a
        finite eigenvalue of a symmetric pencil the same sensitivity holds, the derivative
        of (K - omega^2 M) psi = 0 taken against psi."""
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


def unstable_since(stability: Stability | None) -> str | None:
    """None for a stable (or unassessed) state; for an unstable one, where its path lost
    stability (" since t of the growth", "" where that is not known)."""
    if stability is None or stability.stable:
        return None
    return "" if stability.lost_at is None else f" since {stability.lost_at:.3g} of the growth"


def unstable_tag(stability: Stability | None) -> str:
    """What a verified number on an unstable equilibrium says beside it: a shape a real body
    leaves (a symmetric mesh can hold the symmetric path past its bifurcation; scene 4's disk
    on hexahedra: 0.68 % unstable, docs/STABILITY.md)."""
    where = unstable_since(stability)
    if where is None:
        return ""
    return (f"; UNSTABLE{where}: a real body leaves this shape, solver.branch: switch "
            "follows it")
