"""The linear solvers of the Newton steps, the adjoint and the filter: named presets
(``solver.linear``), ``auto``, and the exact factorisation a failed solve falls back to.

Presets (the PETSc options of each, without a prefix, are in :func:`preset_options`):

``mumps``
    LU by MUMPS (the exact factorisation; what the project always used).
``mumps_ldlt``
    LDL^T by MUMPS (PETSc's Cholesky on the AIJ matrix, MUMPS ``sym = 2``: symmetric
    indefinite, with pivoting): the tangent of an energy is symmetric, and a prestressed
    one can be indefinite.  Half of LU's factor.
``mumps_blr``
    ``mumps_ldlt`` with MUMPS's block low-rank compression of the factor and of the
    contribution blocks (``icntl_35 2``, ``icntl_37 1``, ``cntl_7`` = 1e-8) as the
    preconditioner of GMRES to ``ksp_rtol`` 1e-10: the factor compressed where the wall is
    thin and the blocks far apart, the Krylov iterations make up what it drops.
``mumps_ooc``
    ``mumps_ldlt`` with the factor out of core (``icntl_22 1``): MUMPS writes the factor to
    files as it computes it and reads it back at each solve, so that a process holds its
    working fronts, not the factor (scene 1's 149k-DOF tangent: 341 MB in core against 972).
    The files go to the directory ``MUMPS_OOC_TMPDIR`` names (MUMPS's own variable; /tmp
    where it is unset), which must be on disk: in a memory file system (tmpfs) the factor
    costs the same memory, and the solver says so (:func:`out_of_core_directory`).
``gamg``
    PETSc's smoothed-aggregation multigrid with the rigid-body near-nullspace (the
    matrix's block size is the space's), tuned for elasticity as the PETSc manual's
    troubleshooting section has it: a negative threshold (every edge kept), Chebyshev
    smoothing with Jacobi, the eigenvalue estimates by CG, and a direct coarse solve of up
    to 2000 equations; GMRES outside (the prestressed tangent may be indefinite).
``hypre``
    hypre's BoomerAMG with nodal coarsening and vector interpolation (the near-nullspace),
    under GMRES.
``pmg``
    a p-multigrid (physics/pmultigrid.py) under MINRES: P2 (Q2) smoothed by Chebyshev with
    Jacobi, the Galerkin P1 (Q1) operator with the P1 nodes' rigid-body modes factorised
    where it is small and solved by GAMG beyond; for solid bodies of degree 2.

``auto`` picks one from the model's kind, size and shape (:func:`choose`): LU for 2D models
and small 3D ones, the p-multigrid for a solid 3D body of degree 2 from :data:`AUTO_PMG_DOFS`
state DOFs (:func:`solid`), else LDL^T from :data:`AUTO_LDLT_DOFS`, out of core from
:data:`AUTO_OOC_DOFS`; :func:`why` says which rule chose.
A failed linear solve (a Krylov breakdown, divergence, a zero pivot) is logged in one line with
PETSc's reason and repeated with the exact factorisation :func:`exact_preset` gives the model's
size (LU, LDL^T, or LDL^T out of core: the sizes ``auto`` factorises by); after
:data:`GIVE_UP_AFTER` such failures in a row, a model's state solves use it (said in one
line).  The fallbacks are counted per run (:func:`counting`, summary.json ``linear_solver``).
"""

from __future__ import annotations

import atexit
import contextvars
import functools
import logging
import os
import shutil
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from petsc4py import PETSc

from ..config import ConfigError
from .options import SolverOptions

log = logging.getLogger(__name__)

PRESETS = ("mumps", "mumps_ldlt", "mumps_ooc", "mumps_blr", "gamg", "hypre", "pmg")
CHOICES = (*PRESETS, "auto")
ITERATIVE = ("mumps_blr", "gamg", "hypre", "pmg")  # a Krylov method outside
MULTIGRID = ("gamg", "hypre")  # need the rigid-body near-nullspace

# After this many failed solves in a row a model's state solves use the exact
# factorisation (each failed GAMG solve on the thin beam costs 1000 GMRES iterations).
GIVE_UP_AFTER = 3

EXACT: dict[str, object] = {"ksp_type": "preonly", "pc_type": "lu",
                            "pc_factor_mat_solver_type": "mumps"}

# auto (the default): below this many state DOFs, and for every 2D model, the LU every
# recorded number of a small model was measured with (its factor is small: 140 MB at 21k 3D
# DOFs); from there on the LDL^T factorisation, the same states to round-off with half the
# factor and 0.6x its time (docs/PERFORMANCE.md, "Linear solvers").
AUTO_LDLT_DOFS = 20_000
# ... and from this many on, the LDL^T with its factor out of core: at scene 1's 149k DOFs it
# cost 1.12x the time of a solve from rest and took its peak from 3.93 GB to 1.65 GB (both
# ranks); below, the in-core factor fits this 24 GB machine many times over (the tube's 231k:
# 1.3 GB), and above it the factor outgrows the rest of the model (docs/PERFORMANCE.md,
# "Out of core").
AUTO_OOC_DOFS = 500_000
# ... and from this many on, a solid 3D body of degree 2 (at least AUTO_PMG_ACROSS cells
# across: physics/pmultigrid.py, elements_across) goes to the p-multigrid: a clamped P2
# cube of 206 763 DOFs from rest took 217 s and 1.4 GB against the LDL^T's 1 344 s and
# 7.0 GB (its tolerance following Newton's, 8 MINRES iterations a Newton step); on the bent
# beam, 0.87 and (refined once) 1.74 cells across, solves ran into 1000 iterations and fell
# back to LU, at 3.3x the LDL^T's time (docs/PERFORMANCE.md, "A p-multigrid for solid
# bodies").
AUTO_PMG_DOFS = 100_000
AUTO_PMG_ACROSS = 4.0


def exact_preset(dofs: int) -> str:
    """The exact factorisation a failed solve of an iterative preset falls back to on a model
    of ``dofs`` unknowns: LU below :data:`AUTO_LDLT_DOFS`, LDL^T below :data:`AUTO_OOC_DOFS`,
    LDL^T out of core beyond (measured: the slender block's LU fallback at 1.12M DOFs was
    killed for memory at 12.4 GB a rank; docs/PERFORMANCE.md, "A p-multigrid for solid
    bodies"); the factorisation ``auto`` gives a body the p-multigrid does not take."""
    return ("mumps" if dofs < AUTO_LDLT_DOFS else
            "mumps_ldlt" if dofs < AUTO_OOC_DOFS else "mumps_ooc")


def preset_options(name: str, role: str) -> dict[str, object]:
    """The KSP/PC options of preset ``name`` for a solver of ``role`` (``state_``,
    ``adjoint_`` or ``filter_``), without a prefix."""
    if role == "filter_":
        return _filter_options(name)
    rtol = 1e-10 if role == "state_" else 1e-12
    krylov: dict[str, object] = {"ksp_type": "gmres", "ksp_gmres_restart": 100,
                                 "ksp_rtol": rtol, "ksp_atol": 0.0, "ksp_max_it": 1000}
    if name == "mumps":
        return dict(EXACT)
    # ICNTL(14) 30 (the working space's margin over its estimate; MUMPS's default 20): MUMPS
    # 5.8 (the pip wheel's) ran out of it on two ranks in the LDL^T of a stretched P2 cube
    # (INFO(1) = -9, 2640 entries short); 30 holds there
    if name == "mumps_ldlt":
        return {"ksp_type": "preonly", "pc_type": "cholesky",
                "pc_factor_mat_solver_type": "mumps", "mat_mumps_icntl_14": 30}
    if name == "mumps_ooc":
        return {**preset_options("mumps_ldlt", role), "mat_mumps_icntl_22": 1}
    if name == "mumps_blr":
        return {**krylov, "ksp_max_it": 200, "pc_type": "cholesky",
                "pc_factor_mat_solver_type": "mumps", "mat_mumps_icntl_14": 30,
                "mat_mumps_icntl_35": 2, "mat_mumps_icntl_37": 1, "mat_mumps_cntl_7": 1e-8}
    if name == "gamg":
        return {**krylov, "pc_type": "gamg", "pc_gamg_type": "agg",
                "pc_gamg_agg_nsmooths": 1, "pc_gamg_threshold": -1.0,
                "pc_gamg_coarse_eq_limit": 2000, "pc_gamg_reuse_interpolation": True,
                "mg_levels_ksp_type": "chebyshev", "mg_levels_pc_type": "jacobi",
                "mg_levels_ksp_max_it": 3,
                # PETSc 3.18 reads the first name, 3.19 and later the second
                "pc_gamg_esteig_ksp_type": "cg", "mg_levels_esteig_ksp_type": "cg"}
    if name == "pmg":
        # to 1e-10, not a tolerance that follows Newton's (Eisenstat-Walker): that leaves each
        # state at Newton's tolerance, and a resumed run left the uninterrupted one by 3e-5
        # in J (tests/test_optimize.py); solver.petsc_options can ask for it (PERFORMANCE.md)
        return {**krylov, **PMG_OPTIONS, "ksp_type": "minres"}
    if name == "hypre":
        return {**krylov, "pc_type": "hypre", "pc_hypre_type": "boomeramg",
                "pc_hypre_boomeramg_nodal_coarsen": 6,
                "pc_hypre_boomeramg_vec_interp_variant": 3,
                "pc_hypre_boomeramg_strong_threshold": 0.5,
                "pc_hypre_boomeramg_coarsen_type": "HMIS",
                "pc_hypre_boomeramg_interp_type": "ext+i",
                "pc_hypre_boomeramg_P_max": 4, "pc_hypre_boomeramg_agg_nl": 1}
    raise ValueError(f"unknown linear solver preset {name!r}")


# The p-multigrid (physics/pmultigrid.py) under MINRES: two levels, the coarse operator set
# by the solver (pc_mg_galerkin none), the fine level smoothed by two Chebyshev steps with
# Jacobi, the coarse level one V-cycle of GAMG tuned as the gamg preset (factorised instead
# where it is small: PMultigrid.coarse_options).  MINRES, not CG: a
# Newton iterate's tangent can be indefinite where the state is stable (the tiny cube under
# dead traction: CG stopped on "indefinite matrix", with Jacobi alone after 266 iterations
# too), and MINRES takes a symmetric indefinite operator with the V-cycle, which is
# symmetric positive definite, in a few vectors (GMRES(100) would hold 100).
PMG_OPTIONS: dict[str, object] = {
    "pc_type": "mg", "pc_mg_levels": 2, "pc_mg_galerkin": "none",
    "mg_levels_ksp_type": "chebyshev", "mg_levels_pc_type": "jacobi",
    "mg_levels_ksp_max_it": 2, "mg_levels_ksp_chebyshev_esteig_steps": 20,
    "mg_levels_esteig_ksp_type": "cg",
    "mg_coarse_ksp_type": "preonly", "mg_coarse_pc_type": "gamg",
    "mg_coarse_pc_gamg_type": "agg", "mg_coarse_pc_gamg_agg_nsmooths": 1,
    "mg_coarse_pc_gamg_threshold": -1.0, "mg_coarse_pc_gamg_coarse_eq_limit": 2000,
    "mg_coarse_mg_levels_ksp_type": "chebyshev", "mg_coarse_mg_levels_pc_type": "jacobi",
    "mg_coarse_pc_gamg_esteig_ksp_type": "cg", "mg_coarse_mg_levels_esteig_ksp_type": "cg",
}


def _filter_options(name: str) -> dict[str, object]:
    """The Helmholtz filter's system is SPD and about as well conditioned as a mass matrix:
    CG, with Jacobi for the direct presets (as always) and the multigrid where asked."""
    opts: dict[str, object] = {"ksp_type": "cg", "pc_type": "jacobi", "ksp_rtol": 1e-13,
                               "ksp_atol": 1e-30, "ksp_max_it": 2000}
    if name in ("gamg", "pmg"):
        opts.update({"pc_type": "gamg", "pc_gamg_threshold": -1.0})
    elif name == "hypre":
        opts.update({"pc_type": "hypre", "pc_hypre_type": "boomeramg"})
    return opts


def missing_package(name: str) -> str | None:
    """The external package preset ``name`` needs and this PETSc lacks (None: all there);
    every preset needs MUMPS at least for the LU its failed solves fall back to."""
    need = {"mumps": "mumps", "mumps_ldlt": "mumps", "mumps_ooc": "mumps", "mumps_blr": "mumps",
            "gamg": "mumps", "hypre": "hypre", "pmg": "mumps"}[name]
    return None if has_package(need) else need


OWN_PREFIX = "shapegrowth-ooc-"


def out_of_core_directory() -> Path:
    """Where ``mumps_ooc`` writes its factors: a directory of this process's own in the one
    ``MUMPS_OOC_TMPDIR`` names, else in /tmp (MUMPS's own rule), removed when the process
    ends (MUMPS leaves the files of the factors still held at exit: measured, two a rank
    and run, up to 1.9 GB each); ``MUMPS_OOC_TMPDIR`` then names it, as MUMPS reads it.  A
    directory that is missing or not writable is refused in one line; one in a memory file
    system is said in one line (once), as the factor then saves no memory."""
    path = Path(os.environ.get("MUMPS_OOC_TMPDIR") or "/tmp")
    if path.name.startswith(OWN_PREFIX) and path.is_dir():  # made below, by this process
        return path
    if not (path.is_dir() and os.access(path, os.W_OK | os.X_OK)):
        raise ConfigError([f"solver.linear: mumps_ooc writes its factor to {path} "
                           "(MUMPS_OOC_TMPDIR), which is not a writable directory; set "
                           "MUMPS_OOC_TMPDIR to one on disk"])
    base = str(path.resolve())
    _say_if_in_memory(base)
    own = _own_directory(base)
    os.environ["MUMPS_OOC_TMPDIR"] = own
    return Path(own)


@functools.cache
def _own_directory(base: str) -> str:
    own = tempfile.mkdtemp(prefix=OWN_PREFIX, dir=base)
    atexit.register(shutil.rmtree, own, ignore_errors=True)
    return own


@functools.cache
def _say_if_in_memory(path: str) -> None:
    kind = file_system(path)
    if kind in ("tmpfs", "ramfs"):
        log.warning("solver.linear: mumps_ooc writes its factor to %s, which is in memory "
                    "(%s): it saves no memory there; set MUMPS_OOC_TMPDIR to a directory "
                    "on disk", path, kind)


def file_system(path: str, table: str = "/proc/mounts") -> str:
    """The type of the file system ``path`` (absolute) lies on: that of its longest mount
    point in the mount ``table`` ("" where none is listed or the table cannot be read)."""
    best, kind = "", ""
    try:
        with open(table, encoding="utf-8") as mounts:
            for line in mounts:
                fields = line.split()
                if len(fields) < 3:
                    continue
                point = fields[1].replace("\\040", " ")
                inside = path == point or path.startswith(point.rstrip("/") + "/")
                if inside and len(point) >= len(best):
                    best, kind = point, fields[2]
    except OSError:
        return ""
    return kind


def has_package(name: str) -> bool:
    """Whether this PETSc was built with the external package ``name``."""
    return bool(PETSc.Sys.hasExternalPackage(name))


def choose(requested: str, dofs: int, dim: int, across: float | None = None) -> str:
    """The preset ``requested`` stands for on a model of ``dofs`` state DOFs in ``dim``
    dimensions, ``across`` cells across where the p-multigrid could take it (a 3D body of
    degree 2 displacements alone; physics/pmultigrid.py, :func:`elements_across`):
    ``auto`` resolved (measured: docs/PERFORMANCE.md, "Linear solvers"), and a preset whose
    package this PETSc lacks replaced, with one line, by the nearest one it has."""
    name = requested
    if requested == "auto":
        name = "mumps" if dim < 3 else "pmg" if solid(dofs, across) else exact_preset(dofs)
    missing = missing_package(name)
    if missing is not None:
        fallback = "mumps_ldlt" if missing == "hypre" else None
        if fallback is None or missing_package(fallback) is not None:
            raise ConfigError([f"solver.linear: {name} needs PETSc with {missing}, which "
                               "this PETSc lacks; install a PETSc built with MUMPS"])
        log.warning("solver.linear: %s needs PETSc with %s, which this PETSc lacks; using %s",
                    name, missing, fallback)
        name = fallback
    if name == "mumps_ooc":
        out_of_core_directory()
    return name


def solid(dofs: int, across: float | None) -> bool:
    """Whether ``auto`` gives a model of ``dofs`` state DOFs, ``across`` cells across, to the
    p-multigrid: large enough that a factor costs more than its iterations, and thick enough
    that its P1 level does not lock (:data:`AUTO_PMG_DOFS`, :data:`AUTO_PMG_ACROSS`)."""
    return across is not None and dofs >= AUTO_PMG_DOFS and across >= AUTO_PMG_ACROSS


def _count(n: int) -> str:
    return f"{n:,}".replace(",", " ")


def why(requested: str, chosen: str, dofs: int, dim: int, across: float | None) -> str:
    """Why ``requested`` became ``chosen`` on a model of ``dofs`` state DOFs in ``dim``
    dimensions, ``across`` cells across (None: not a body the p-multigrid takes), in one line
    (summary.json ``linear_solver.reason``)."""
    if requested != "auto":
        return "named by solver.linear"
    size = f"{_count(dofs)} state DOFs"
    shape = "" if across is None else f", {across:.1f} cells across"
    if dim < 3:
        return f"auto: {size}, a {dim}D model"
    if chosen == "pmg":
        return (f"auto: {size}{shape}: a solid body of degree 2 (from {_count(AUTO_PMG_DOFS)} "
                f"DOFs and {AUTO_PMG_ACROSS:g} cells across)")
    if chosen == "mumps":
        return f"auto: {size}{shape}: LU below {_count(AUTO_LDLT_DOFS)} DOFs"
    return (f"auto: {size}{shape}: factorised (the p-multigrid takes a body of degree 2 "
            f"displacements from {_count(AUTO_PMG_DOFS)} DOFs and {AUTO_PMG_ACROSS:g} cells "
            "across)")


# ---- fallbacks, counted per run ------------------------------------------------------------
@dataclass
class FallbackTally:
    """Solves that fell back to the exact factorisation, by role, and the first reasons."""

    state: int = 0
    adjoint: int = 0
    reasons: list[str] = field(default_factory=list)
    krylov_solves: int = 0  # linear solves of an iterative preset (the state's Newton steps)
    krylov_iterations: int = 0  # ... and their Krylov iterations

    def record(self, role: str, reason: str) -> None:
        if role == "adjoint_":
            self.adjoint += 1
        else:
            self.state += 1
        if len(self.reasons) < 5:
            self.reasons.append(f"{role.rstrip('_')}: {reason}")


_TALLY: contextvars.ContextVar[FallbackTally | None] = contextvars.ContextVar(
    "shapegrowth_linear_fallbacks", default=None)


@contextmanager
def counting() -> Iterator[FallbackTally]:
    """Count the fallbacks of every solver used inside the block (a run, a solve)."""
    tally = FallbackTally()
    token = _TALLY.set(tally)
    try:
        yield tally
    finally:
        _TALLY.reset(token)


def count_krylov(solves: int, iterations: int) -> None:
    """Count an iterative preset's linear solves and their Krylov iterations where a run
    counts (summary.json ``linear_solver``)."""
    tally = _TALLY.get()
    if tally is not None:
        tally.krylov_solves += solves
        tally.krylov_iterations += iterations


EXACT_WORDS = {"mumps": "MUMPS LU", "mumps_ldlt": "MUMPS LDL^T",
               "mumps_ooc": "MUMPS LDL^T out of core"}


def give_up(role: str, preset: str, exact: str = "mumps") -> None:
    log.warning("%s solve: solver.linear %s failed %d solves in a row; this model's later "
                "solves use %s", role.rstrip("_"), preset, GIVE_UP_AFTER, EXACT_WORDS[exact])


def record_fallback(role: str, preset: str, reason: str, exact: str = "mumps") -> None:
    """Log a preset's failed solve in one line and count it where a run counts."""
    log.warning("%s solve: solver.linear %s failed (%s); this solve falls back to %s",
                role.rstrip("_"), preset, reason, EXACT_WORDS[exact])
    tally = _TALLY.get()
    if tally is not None:
        tally.record(role, reason)


KSP_REASONS = {  # PETSc's KSPConvergedReason, the failures
    -2: "null", -3: "maximum Krylov iterations", -4: "diverged (dtol)", -5: "breakdown",
    -6: "breakdown (BiCG)", -7: "nonsymmetric", -8: "indefinite preconditioner",
    -9: "NaN or Inf", -10: "indefinite matrix", -11: "preconditioner failed (e.g. a zero "
    "pivot)",
}


def free_factorisation(ksp: PETSc.KSP) -> None:
    """Free the KSP's preconditioner (a factorisation, its memory), its operators kept, so
    that the next solve builds it anew from them: the state's chord predictor solves with
    its KSP directly (measured: a warm solve after KSP.reset() alone stopped on PETSc
    error 56, the reset KSP's matrix of type null)."""
    A, P = ksp.getOperators()
    ksp.reset()
    ksp.setOperators(A, P)


def reset_after_failure(ksp: PETSc.KSP) -> None:
    """Forget a failed preconditioner (a factorisation that failed stays failed, and GAMG's
    reused interpolation with it: PETSc error 76 at every later solve), so that the next
    solve builds it anew from its operators (:func:`free_factorisation`)."""
    free_factorisation(ksp)


def reason_of(solver: Any) -> int:
    """A KSP's or SNES's converged reason as an int (petsc4py 3.25 types it as a class of its
    own, which its type hints do not let int() take)."""
    return int(solver.getConvergedReason())


def error_code(err: PETSc.Error) -> int:
    """PETSc's error code of ``err`` (its first argument on every petsc4py served; 3.25's
    type hints leave out the ``ierr`` attribute)."""
    return int(err.args[0]) if err.args else -1


def ksp_reason(ksp: PETSc.KSP) -> str:
    reason = reason_of(ksp)
    return f"KSP {KSP_REASONS.get(reason, str(reason))} after {ksp.getIterationNumber()} " \
           "iterations"


# MUMPS's factorisation is refused before it allocates anything when its estimated working
# memory exceeds ICNTL(23) MB per rank (INFO(1) = -19): with a cap of 1 MB only the analysis
# runs, and its estimates stay to be read
_REFUSED = -19
DIRECT_MUMPS = ("mumps", "mumps_ldlt", "mumps_ooc")


@dataclass(frozen=True)
class FactorEstimate:
    """What MUMPS's analysis says a factorisation of a matrix would need, nothing factored:
    a mesh too large to factor here measured before it is tried (``benchmarks/
    linear_factors.py --analyse``; docs/PERFORMANCE.md, 'What a refined-twice check would
    need')."""

    entries: int                      # the factor's entries (INFOG(3))
    mb_in_core: tuple[int, int]       # working memory in core: largest rank, all ranks
    mb_out_of_core: tuple[int, int]   # the same with the factor out of core
    flops: float                      # the elimination's operations (RINFOG(1))
    ordering: int                     # the ordering MUMPS chose (INFOG(7))


def _entries(infog: int) -> int:
    """MUMPS's count of entries: a negative one is in millions."""
    return infog if infog >= 0 else -infog * 1_000_000


def factor_estimate(F: PETSc.Mat) -> FactorEstimate:
    """The analysis's estimates held by MUMPS's factor matrix ``F`` (after an analysis, a
    factorisation or a refused one)."""
    return FactorEstimate(_entries(F.getMumpsInfog(3)),
                          (F.getMumpsInfog(16), F.getMumpsInfog(17)),
                          (F.getMumpsInfog(26), F.getMumpsInfog(27)),
                          float(F.getMumpsRinfog(1)), F.getMumpsInfog(7))


@contextmanager
def preset_ksp(A: PETSc.Mat, name: str, prefix: str,
               extra: dict[str, object] | None = None) -> Iterator[PETSc.KSP]:
    """A KSP of preset ``name`` (with ``extra`` options) on ``A`` under its own options
    ``prefix``, its options in PETSc's table for the block's time (MUMPS reads them at the
    factorisation, the block's ``setUp``), destroyed at the block's end."""
    opts = SolverOptions("state_", {**preset_options(name, "state_"), "ksp_type": "preonly",
                                    **(extra or {})}, prefix=prefix)
    ksp = PETSc.KSP().create(A.getComm())
    try:
        ksp.setOptionsPrefix(opts.prefix)
        with opts.pushed():
            ksp.setFromOptions()
            ksp.setOperators(A)
            yield ksp
    finally:
        ksp.destroy()


def analyse(A: PETSc.Mat, name: str = "mumps_ldlt") -> FactorEstimate:
    """MUMPS's analysis of ``A`` by the direct preset ``name``, its factorisation refused
    (a working-memory cap of 1 MB): what the factor would take, in the time of an ordering."""
    if name not in DIRECT_MUMPS:
        raise ValueError(f"analyse needs a direct MUMPS preset ({', '.join(DIRECT_MUMPS)}), "
                         f"not {name!r}")
    with preset_ksp(A, name, "analyse_", {"mat_mumps_icntl_23": 1}) as ksp:
        try:
            ksp.setUp()
        except PETSc.Error:  # a PETSc that raises on the refused factorisation
            pass
        F = ksp.getPC().getFactorMatrix()
        if F.getMumpsInfog(1) != _REFUSED:
            raise RuntimeError(f"MUMPS's analysis ended with INFOG(1) = {F.getMumpsInfog(1)}, "
                               f"not the refusal ({_REFUSED}) it was asked for")
        return factor_estimate(F)
