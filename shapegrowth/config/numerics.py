"""The config's sections that say how a body is solved and judged: the objective, the
optimiser, the solver, the verification and the outputs (the body's own sections are
sections.py's).  Typed, frozen dataclasses whose fields carry their help, default and
range (schema.py)."""

from __future__ import annotations

from dataclasses import dataclass

from .schema import option
from .sections import FACE_ALIASES


@dataclass(frozen=True)
class HausdorffConfig:
    phi: str = option("phi of (2.9): exp(-t) or rational 1/(1+t)", "exp",
                      choices=("exp", "rational"))
    alpha: float | tuple[float, ...] = option(
        "alpha of (2.9) (sharpness; scales like 1/length), or a rising schedule such as "
        "[100, 300, 1000]: each value in turn, the next one when the optimiser stalls or the "
        "stage's share of optimizer.max_iterations is spent", 100.0, gt=0)
    form: str = option(
        "the shape term minimised: 'debiased' rho_H(B,T) - (rho_H(B,B) + rho_H(T,T))/2, zero "
        "when body and target coincide; 'paper' rho_H(B,T) of (2.9), biased by ~log(alpha)/alpha",
        "debiased", choices=("debiased", "paper"))
    beta: float = option("beta of (2.9)", 2.0, gt=0)
    gamma: float = option("gamma of (2.9)", 2.0, gt=0)
    quadrature_degree: int = option("quadrature degree of the point clouds of both bodies", 2,
                                    ge=1, le=8)
    cutoff: float = option("pairs whose term is below exp(-cutoff) of the nearest are skipped "
                           "(where that prunes); terms fade out smoothly before it, so rho_H "
                           "and its gradient stay exact for the sum they define", 14.0, ge=5)
    taper: float = option("width, in e-folds, of the smooth fade-out that ends at the cutoff "
                          "(no more than the cutoff)", 2.0, gt=0)
    precision: str = option(
        "arithmetic of each pair's distance, exponential and taper: 'float64'; 'float32' (phi "
        "exp, cutoff <= 60; sums over cells and ranks in float64): ~2x faster, within ~1e-9 "
        "of float64's rho_H; 'auto': float32 where the cell grid prunes (clouds of 2000 "
        "points and more, where the pair sums are the cost) and phi and cutoff allow, float64 "
        "elsewhere", "auto", choices=("auto", "float64", "float32"))

    @property
    def alphas(self) -> tuple[float, ...]:
        """The alpha schedule (one value without continuation)."""
        return tuple(self.alpha) if isinstance(self.alpha, tuple) else (float(self.alpha),)


@dataclass(frozen=True)
class ComplexityConfig:
    kind: str = option("complexity functional (Sect. 2.4)", "none",
                       choices=("none", "C1", "C2", "C1bar", "C2bar"))
    weight: float = option("alpha_1 of the complexity functional", 0.0, ge=0)
    gradient_weight: float = option("alpha_2: weight of the gradient penalty on C_g", 0.0, ge=0)


@dataclass(frozen=True)
class ObjectiveConfig:
    hausdorff: HausdorffConfig = option("smooth Hausdorff distance rho_H (2.9)", HausdorffConfig())
    complexity: ComplexityConfig = option("complexity terms", ComplexityConfig())
    compare: str | tuple[str, ...] = option(
        "what of the deformed body is compared with the target: volume (the whole body, "
        "its volume measure), boundary (its whole surface, with its area measure), or a "
        "named face or a list of them (box and cube: top, bottom and every boundary name; "
        "tube and cylinder_shell: outer, inner; annulus: top, bottom; rectangle: top, "
        "bottom), each area pushed forward exactly (da = |cof F N| dA); a 2D section compares "
        "the edges that stand for the faces it keeps (a meridian's edge as the surface it "
        "sweeps, 2 pi r |cof F N| dS)", "volume")
    placement: str = option(
        "where the deformed body is compared: pinned (where boundary.clamp holds it), or "
        "fitted (a free body, clamp: rigid: the compared part moved rigidly onto its own "
        "reference by its least-squares rotation and centroid, so the mesh's choice of pinned "
        "vertices does not tilt or move the compared shape; a section of a body of revolution "
        "fits its axial position only; a target.map's image is placed the same way, a target "
        "file where target.transform puts it)", "pinned", choices=("pinned", "fitted"))

    @property
    def compared(self) -> tuple[str, ...]:
        """objective.compare as given, one name or a list of them."""
        return (self.compare,) if isinstance(self.compare, str) else tuple(self.compare)

    def faces(self, kind: str) -> tuple[str, ...] | None:
        """The compared boundaries' names (() for the whole boundary, None for the
        volume), face names resolved for a body of ``kind``."""
        names = self.compared
        if names == ("volume",):
            return None
        if names == ("boundary",):
            return ()
        aliases = FACE_ALIASES.get(kind, {})
        return tuple(aliases.get(n, n) for n in names)


@dataclass(frozen=True)
class StabilityPenaltyConfig:
    min_eigenvalue: float | None = option(
        "keep the optimum stable: the tangent's lowest eigenvalues (squared angular "
        "frequencies for unit density, as summary.json stability reports them) are held above "
        "this by the penalty weight x sum_i max(0, 1 - omega_i^2 / min_eigenvalue)^2 added to "
        "J (exact gradient; an eigenproblem per evaluation; null: off)", None, gt=0)
    # measured on the 3D disk (docs/STABILITY.md, "Stability"): weight 1 outweighs the shape
    # term tenfold (J 3.76 against rho_H 0.50 at the start) and ends at 41 % verified
    weight: float = option("the penalty's weight, in the objective's units", 0.01, gt=0)
    modes: int = option("the lowest eigenvalues the penalty sees (a symmetric body's modes "
                        "come in pairs: take both)", 4, ge=1, le=20)


@dataclass(frozen=True)
class OptimizerConfig:
    algorithm: str = option(
        "NLopt algorithm: mma, slsqp (dense quasi-Newton: O(n^2) memory, O(n^3) time per "
        "iteration) or lbfgs (limited-memory quasi-Newton with bounds, O(n))", "lbfgs",
        choices=("mma", "slsqp", "lbfgs"))
    max_iterations: int = option(
        "the most iterations: a ceiling, the run's price; the window test (`ftol_rel` over "
        "`ftol_window`) stops a run at its mesh's floor first (a reachable quarter arc: "
        "converged at 396, docs/VERIFICATION.md, \"Where the stopping test stops\")", 1000, ge=0)
    ftol_rel: float = option("stop when the best objective has fallen by less than this "
                             "times |J| over the last `ftol_window` iterations (0: never)",
                             1.0e-6, ge=0)
    ftol_window: int = option("the iterations over which `ftol_rel` judges progress (one "
                              "step's change stops L-BFGS in a slow stretch, long before "
                              "its discretisation's floor: docs/VERIFICATION.md)", 20, ge=1)
    xtol_rel: float = option("stop on relative design change below this", 0.0, ge=0)
    move_limit: float = option("MMA works in a box of +- this around the current design "
                               "(0: the whole bounds); SLSQP always uses the whole bounds",
                               0.3, ge=0)
    restart_every: int = option("evaluations before the box is re-centred", 10, ge=2)
    stability: StabilityPenaltyConfig = option(
        "stable optima on request (docs/STABILITY.md, \"Stable optima on request\")",
        StabilityPenaltyConfig())
    from_rest_every: int = option(
        "the physical branch: every this many iterations the next state is solved from rest "
        "(as the body grows) and the warm starts go on from there (0: never)", 0, ge=0)
    levels: tuple[int, ...] = option(
        "coarse-to-fine: the mesh's refinements per level, rising from 0, e.g. [0, 1]: "
        "optimise on the config's mesh, carry the design exactly onto the mesh refined once "
        "and go on there (later levels at the last alpha of a schedule)", (0,))
    level_iterations: tuple[int, ...] | None = option(
        "how max_iterations is shared by the levels, one number per level (scaled down in "
        "proportion where they add up to more than max_iterations); default: equally", None)


@dataclass(frozen=True)
class ContinuationConfig:
    initial_step: float = option("first growth step from rest, as a fraction of the full growth",
                                 0.1, gt=0, le=1)
    min_step: float = option("smallest step before the solve is declared failed", 1.0e-4,
                             gt=0, le=1)
    max_steps: int = option("most continuation steps in one solve", 500, ge=1)
    step_rtol: float | None = option(
        "Newton's relative tolerance at the load steps before the full growth (their "
        "equilibria only start the next step; null: solver.rtol); the last step always "
        "converges to solver.rtol (opt-in; 1e-4 measured in docs/PERFORMANCE.md, "
        "\"Continuation from rest\")",
        None, gt=0, lt=1)


@dataclass(frozen=True)
class SolverConfig:
    linear: str = option(
        "linear solver of the Newton steps, the adjoint and the filter: mumps (LU), "
        "mumps_ldlt (symmetric LDL^T, half the factor), mumps_ooc (LDL^T with the factor on "
        "disk, in MUMPS_OOC_TMPDIR), mumps_blr (LDL^T with block low-rank "
        "compression under GMRES), gamg or hypre (algebraic multigrid with the rigid-body "
        "modes, under GMRES, for chunky bodies), pmg (a p-multigrid under MINRES for "
        "model.degree 2: P2 to P1, the P1 level factorised or by GAMG), auto (chosen by "
        "the model's size and shape: LU, LDL^T from 20 000 3D state DOFs, out of core from "
        "500 000, pmg for a solid body of degree 2, 4 cells across, from 100 000); a "
        "preset's failed solve is done again with mumps, counted in summary.json "
        "linear_solver (measurements: docs/PERFORMANCE.md, \"Linear solvers\")", "auto",
        choices=("mumps", "mumps_ldlt", "mumps_ooc", "mumps_blr", "gamg", "hypre", "pmg",
                 "auto"))
    branch: str = option(
        "past a bifurcation, a solve from rest (solve, the verification, a lift) follows the "
        "path it is on, now unstable (follow), or leaves it for a stable branch by a "
        "perturbation along the critical mode (switch), as a real body does; summary.json "
        "stability says which branch it ended on", "follow", choices=("follow", "switch"))
    line_search: str = option("SNES line search (basic is plain Newton, fastest here)", "basic",
                              choices=("basic", "bt", "l2", "cp"))
    max_newton_iterations: int = option("Newton iterations per continuation step", 15, ge=1)
    rtol: float = option("Newton relative residual tolerance", 1.0e-11, gt=0, lt=1)
    atol: float = option("Newton absolute residual tolerance, relative to the body's force "
                         "scale (mu1 + mu2 + lambda) |body|^((d-1)/d)", 1.0e-14, gt=0)
    stol: float = option("Newton stops when an update is below stol times the displacement",
                         1.0e-9, ge=0, lt=1)
    chord_steps: int = option(
        "an optimiser's step starts from this many chord steps at most on the last "
        "factored tangent (the first-order predictor -K^-1 dR/dC_g dC_g and its "
        "corrections; 0: from the last equilibrium)", 8, ge=0)
    rtol_far: float | None = option(
        "loose far from the optimum, tight near it: an optimiser's warm state solve stops at "
        "rtol x (J's relative change over the last two evaluations) / optimizer.ftol_rel, "
        "between rtol and this (null: always rtol)", None, gt=0, lt=1)
    adjoint_reuse: bool = option(
        "solve the adjoint with the last Newton step's factorization, refined against the exact "
        "tangent (false: assemble and factor the tangent anew)", True)
    continuation: ContinuationConfig = option("growth continuation and step cutting",
                                              ContinuationConfig())
    petsc_options: dict[str, str | bool | int | float] = option(
        "extra PETSc options, keys with their prefix (state_, adjoint_, filter_)", {})


@dataclass(frozen=True)
class VerifyConfig:
    enabled: bool = option(
        "after a run, solve its best growth from rest on the run's mesh refined `refine` "
        "times and lead with that shape error (summary.json `verified`)", True)
    refine: int = option(
        "uniform refinements of the run's mesh for the verification (nested: the growth "
        "carries over exactly)", 1, ge=1, le=3)
    lift: str | None = option(
        "a reduced model (dim 2 section of a 3D body): the 3D config its growth is lifted "
        "onto (extruded along X2, or revolved about X3), on that config's own verification "
        "model (its finest level refined its verify.refine times), solved from rest and "
        "measured there; the run then leads with that number (a path as for target.mesh)",
        None)
    every: int = option(
        "also verify the design of every this many iterations during the run (refined as "
        "`refine`, from rest; verified.csv: the verified error along the run, for the time "
        "to a verified error; each check costs a refined solve from rest; 0: only at the "
        "end)", 0, ge=0)
    best: str = option(
        "the growth the run ends on, writes and leads with: `self`, the optimiser's best by "
        "its own number; `verified`, the lowest verified error among `every`'s checks and "
        "the optimiser's best (each grown from rest on the refined mesh, the reduced model's "
        "own number where it is lifted), so that where a run ends on its path does not "
        "decide its verified number (a coarse-to-fine level hands its winner to the next)",
        "self", choices=("self", "verified"))
    lift_refine: int | None = option(
        "refinements of the lift config's finest level for the lift (default: that config's "
        "own verify.refine, where its runs verify; fewer where the 3D body cannot be grown "
        "from rest there in reasonable time: say so beside the number)", None, ge=0, le=3)
    lift_degree: int | None = option(
        "degree of the growth fields on the lift's 3D body (default: that config's own "
        "growth.degree): 2 holds the section's growth on a 3D mesh no finer than the "
        "section's with less interpolation (scene 2's section on its strip refined twice, "
        "149 379 DOFs: 1.25 % with 1, 1.03 % with 2, the strip leaving the section by "
        "1.04 % and 0.27 %: docs/MODELS.md)", None, ge=1, le=2)


@dataclass(frozen=True)
class OutputConfig:
    dir: str | None = option("output folder (default results/<name>)", None)
    checkpoint_every: int = option("write checkpoint.h5 every this many iterations", 5, ge=1)
