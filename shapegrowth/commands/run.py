"""``shapegrowth run``: build the model, optimise, and write every output.

Outputs in the run folder: summary.json, history.csv, history.png, shape.png (the
deformed body coloured by lambda_hat_1, the target as dots), shape3d.png (the same in 3D
over the translucent target; a section swept back into its 3D body; not for plane
bodies), frame.png (a free 2D frame: its eigenvectors on the deformed body), fields.xdmf
(+ .h5:
displacement, Phi, the filtered growth fields lambda_hat_i/theta_hat_i, the
eigenvectors v_i, residual_strain), growth.npz (the best growth at its nodes, for
``shapegrowth lift``) and checkpoint.h5.
"""

from __future__ import annotations

import dataclasses
import logging
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from mpi4py import MPI

from ..config import Config, load
from ..errors import StateSolveError
from ..io import files as io
from ..io.fabrication import Sweep, write_fabrication
from ..io.figures3d import write_shape3d_png
from ..io.plotting import write_frame_png, write_shape_png
from ..io.records import Verified
from ..io.summary import Dofs, OptimizationMeasures, RunSummary
from ..optim.callbacks import FromRestEvery, ProgressLog, ProgressTolerance, RetryFromRest
from ..optim.checkpoint import CheckpointFile
from ..optim.driver import Driver, DriverSettings
from ..optim.interface import Callback, GlobalVector, Record
from ..optim.levels import level_config
from ..optim.lift import check_liftable, lift, verification_model
from ..optim.objective import ObjectiveValue
from ..optim.problem import Evaluation, ReducedFunctional
from ..optim.verification import Candidate, VerifyEvery, branch_changed, verify
from ..physics import linear
from ..physics.model import ForwardModel
from ..physics.stability import StabilityProblem, assess_or_none
from ..physics.state import SolveReport
from ..status import Outcome
from ..timing import Timer
from .report import report_run
from .solve import base_summary, linear_use
from .starts import start_growth

log = logging.getLogger(__name__)


@dataclass
class RunResult:
    summary: RunSummary  # summary.status says whether the run failed, and why
    model: ForwardModel  # left at the best design


@dataclass
class Optimised:
    """What the levels leave: the last level's model, reduced functional and best design
    (this rank's part), the whole history, and how the optimisation ended."""

    model: ForwardModel
    rf: ReducedFunctional
    best: np.ndarray
    design_size: int
    history: list[Record]
    status: Outcome
    candidate: Candidate | None = None  # verify.best: verified: the level's lowest check
    # and its latest, whose verification is the optimiser's best's where the designs match
    # (a run whose last iteration is a check: the scene-3 tube's 300 with verify.every 75)
    latest: Candidate | None = None


@dataclass
class Settled:
    """The best design solved again: its evaluation (None where no state was found there),
    the objective of its growth grown from rest, and the exact Hausdorff distance."""

    final: Evaluation | None
    from_rest: ObjectiveValue | None
    hausdorff: float
    size: float

    @property
    def branch_changed(self) -> bool:
        return branch_changed(self.from_rest.hausdorff if self.from_rest else None,
                              self.hausdorff, self.size)


def lift_config(cfg, overrides: list[str] | tuple[str, ...] = ()) -> Config | None:
    """The config ``verify.lift`` names, with the run's ``--set material.*`` (the body it
    lifts onto is of the same material), checked against the run before the run starts
    (ConfigError); None without a lift."""
    if cfg.verify.lift is None or not cfg.verify.enabled:
        return None
    solid = load(cfg.verify.lift, [item for item in overrides
                                   if item.partition("=")[0].strip().startswith("material.")])
    check_liftable(cfg, solid)
    return solid


def run_optimization(cfg, out: Path, resume: bool = False,
                     lift_onto: Config | None = None) -> RunResult:
    """Optimise ``cfg``'s growth and write every output to ``out`` (module doc): the levels,
    the best design settled (re-solved, and grown from rest), the outputs, the verification
    on the refined (and, for a section, the 3D) model, the summary and the closing lines.
    ``lift_onto``: the 3D config of the lift (:func:`lift_config`), else ``verify.lift``'s
    own."""
    timer = Timer()
    if not resume and MPI.COMM_WORLD.rank == 0 and (out / "verified.csv").exists():
        (out / "verified.csv").unlink()  # a new run's checks only
    with linear.counting() as tally:  # the linear solvers' fallbacks, all models
        done = optimise_levels(cfg, out, resume, timer)
        settled = settle(done)
        refined = None  # the settled growth's verification, where choosing it made one
        if cfg.verify.best == "verified":
            done, settled, refined = choose_verified(cfg, done, settled)
        stability = None  # of the state the outputs show (none without a state)
        if settled.final is not None:
            with timer("forward"):
                problem = StabilityProblem(done.model.state)
                stability = assess_or_none(problem)
        with timer("io"):
            write_outputs(out, done, extra=[problem.mode] if stability else [])
        verified = verify_best(cfg, done.model, settled, refined, lift_onto)
        fabrication = None
        if cfg.growth.levels is not None:
            with timer("io"):
                fabrication = write_design(out, cfg, done.rf, verified)
    summary = dataclasses.replace(summarise(cfg, done, settled, verified, timer, resume),
                                  linear_solver=linear_use(done.model.state.newton, tally),
                                  stability=stability, fabrication=fabrication)
    io.write_json(out / "summary.json", summary.to_json())
    report_run(summary, settled, out, done.history, cfg.optimizer.ftol_window)
    return RunResult(summary, done.model)


# ---- the levels ------------------------------------------------------------------------------
def optimise_levels(cfg, out: Path, resume: bool, timer: Timer) -> Optimised:
    """Per level of ``optimizer.levels`` (one without): the model, its reduced functional
    J(m) from the last level's design (exact: nested meshes), NLopt on J with the level's
    callbacks.  A level that finds not one state ends the run with the last level's best."""
    levels = cfg.optimizer.levels
    history: list[Record] = []
    previous: Optimised | None = None
    checked = 0.0  # seconds of verify.every's checks so far
    for k in range(len(levels)):
        level_cfg = level_config(cfg, k)
        with timer("forward"):
            model = _level_model(cfg, level_cfg, k)
        rf = ReducedFunctional(model, timer)
        if previous is not None:
            rf.carry_design(previous.rf, previous.best)
        if len(levels) > 1:
            log.info("level %d of %d: the mesh refined %d time(s), %d state DOFs, %d "
                     "iterations", k + 1, len(levels), levels[k], model.state_dofs(),
                     level_cfg.optimizer.max_iterations)
        callbacks, along = _level_callbacks(cfg, out, resume, timer, k, rf, model, len(history),
                                            checked)
        driver = Driver(rf, DriverSettings.from_config(level_cfg), callbacks)
        result = driver.run()
        checked = along.spent if along is not None else checked
        timer.totals["optimizer"] += result.optimizer_seconds
        if result.outcome.is_failure and not result.history and previous is not None:
            # not one state on this level: the last level's result is the run's (no
            # computed result is lost), the run is reported failed with the reason
            log.warning("level %d of %d: %s; the run ends with level %d's best design",
                        k + 1, len(levels), result.outcome.reason, k)
            return dataclasses.replace(previous, history=history, status=Outcome.failed(
                f"level {k + 1} of {len(levels)}: {result.outcome.reason}"))
        history += [dataclasses.replace(r, iteration=len(history) + i, level=k)
                    for i, r in enumerate(result.history)]
        previous = Optimised(model, rf, driver.local(result.best), driver.design_size, history,
                             result.outcome, along.best if along is not None else None,
                             along.last if along is not None else None)
        if result.outcome.is_failure:
            break
        if cfg.verify.best == "verified" and k + 1 < len(levels):
            # the next level starts from this level's lowest verified growth
            previous = choose_verified(cfg, previous, settle(previous))[0]
    assert previous is not None  # at least one level
    return previous


def _level_model(cfg, level_cfg, k: int) -> ForwardModel:
    """The level's model; the first level's growth started as ``growth.start`` asks."""
    model = ForwardModel.build(level_cfg)
    if k == 0:
        start_growth(model, cfg)
    return model


def _level_callbacks(cfg, out: Path, resume: bool, timer: Timer, k: int,
                     rf: ReducedFunctional, model: ForwardModel, done: int,
                     checked: float) -> tuple[list[Callback], VerifyEvery | None]:
    """The progress log, the checkpoint, the retry from rest and the physical branch; the
    state's tolerance from the optimiser's progress (solver.rtol_far) and the checks along
    the run (verify.every) where asked."""
    path = out / ("checkpoint.h5" if k == 0 else f"checkpoint-level{k}.h5")
    callbacks: list[Callback] = [
        ProgressLog(), CheckpointFile(path, rf, cfg.output.checkpoint_every,
                                      resume and (k == 0 or path.is_file()), timer),
        RetryFromRest(rf), FromRestEvery(rf, cfg.optimizer.from_rest_every)]
    if cfg.solver.rtol_far is not None:
        callbacks.append(ProgressTolerance(rf, cfg.solver.rtol, cfg.solver.rtol_far,
                                           cfg.optimizer.ftol_rel))
    along = None
    if cfg.verify.every:
        local = GlobalVector(rf.comm, rf.size).local if cfg.verify.best == "verified" \
            else None
        along = VerifyEvery(model, cfg.verify.refine, cfg.verify.every, rf.target_size,
                            out / "verified.csv", timer, k, done, checked, local)
        callbacks.append(along)
    return callbacks, along


# ---- the best design, settled ----------------------------------------------------------------
def settle(done: Optimised) -> Settled:
    """The state left at the best design (for the fields and the final numbers), and that
    growth grown from rest (what a body grown so takes)."""
    rf, failed = done.rf, done.status.is_failure
    rf.set_sharpness(math.inf)  # growth.levels: the crisp design (physics/projection.py)
    if failed:
        rf.restart_from_rest()  # not a warm start from the state that failed
    final = None
    try:
        final = rf.evaluate(done.best, gradient=False)
    except StateSolveError as err:
        log.warning("could not re-solve the best design: %s", err)
    from_rest = None
    if final is not None:  # a failed run's final state was already solved from rest
        from_rest = final.value if failed else _value_from_rest(rf)
    # with rho_H at the best design; without a state there, from the clouds as they are
    exact = final.value.hausdorff if final else rf.exact_hausdorff()
    return Settled(final, from_rest, exact, rf.target_size)


def _value_from_rest(rf: ReducedFunctional) -> ObjectiveValue | None:
    value, report = rf.value_from_rest()
    if value is None:
        log.warning("the best growth could not be solved from rest: %s", report.reason)
    return value


# ---- outputs, verification, summary ----------------------------------------------------------
def write_outputs(out: Path, done: Optimised, extra: list | None = None) -> None:
    """history.csv/png, fields.xdmf (with ``extra`` fields), growth.npz, shape.png,
    shape3d.png (frame.png for a free 2D frame) at the state the best design left."""
    model, target = done.model, done.rf.target_points
    u, applied = model.displacement, model.applied
    io.write_history(out, done.history)
    io.write_fields(out / "fields.xdmf", u, applied,
                    extra=[io.deformation_field(u), model.residual_strain_field(),
                           *(extra or [])])
    io.write_growth(out / "growth.npz", applied, model.cfg.mesh.refine)
    places = done.rf.objective.placements()  # objective.placement: fitted
    write_shape_png(out / "shape.png", u, applied.eigenvalues[0], target, "lambda_hat_1",
                    places[0])
    write_shape3d_png(out / "shape3d.png", model.cfg, u, applied.eigenvalues[0], target,
                      "lambda_hat_1", places=places)
    if applied.frame == "free" and applied.dim == 2:
        write_frame_png(out / "frame.png", u, applied.eigenvalues, applied.angles[0], target)


def write_design(out: Path, cfg, rf: ReducedFunctional, verified: Verified | None) -> str:
    """growth.levels: fabrication/ (io/fabrication.py) for the crisp design the run settled
    on; its fabrication.json's path in the run folder (summary.json's ``fabrication``)."""
    names, crisp, filtered = rf.level_fields()
    write_fabrication(out, rf.projections, crisp, filtered, names, cfg.growth.filter_length,
                      cfg.growth.sharpness[-1] if cfg.growth.sharpness else None,
                      verified.headline if verified is not None else None,
                      verified.status if verified is not None else "not verified (verify off)",
                      sweep_of(cfg))
    return "fabrication/fabrication.json"


def sweep_of(cfg) -> Sweep | None:
    """How a 2D model's regions become 3D parts: a body of revolution's section revolved, a
    plane section extruded through the body's extent across it (a box's length, width or
    thickness), a plane body through geometry.thickness; None for a 3D model, or a plane
    body without a thickness."""
    section = cfg.section
    if cfg.model.dim == 3:
        return None
    axes = (section.axes[0], section.axes[1])
    if section.axisymmetric:
        return Sweep("revolve", axes, section.out_of_plane)
    geo = cfg.geometry
    extent = ({0: geo.length, 1: geo.width, 2: geo.thickness}.get(section.out_of_plane)
              if geo.kind == "box" else geo.thickness)
    if extent is None:
        log.info("fabrication: the plane body has no geometry.thickness: its regions are in "
                 "material.xdmf, without STL files")
        return None
    return Sweep("extrude", axes, section.out_of_plane, float(extent))


def choose_verified(cfg, done: Optimised, settled: Settled
                    ) -> tuple[Optimised, Settled, Verified | None]:
    """``verify.best: verified``: the optimiser's best design verified (not again where it
    is a check's design: the lowest's or the latest's) against the lowest of the level's
    checks; the run goes on with the lower, settled there, and its verification (None
    without checks)."""
    best = done.candidate
    if best is None:
        return done, settled, None
    comm = done.model.comm
    same = _designed(best, done.best, comm)
    if same and best.verified is not None:
        return done, settled, dataclasses.replace(best.verified,
                                                  branch_changed=settled.branch_changed)
    changed, refine = settled.branch_changed, cfg.verify.refine
    latest = done.latest
    if latest is not None and latest.verified is not None and _designed(latest, done.best,
                                                                         comm):
        # the optimiser's best is the latest check's design: verified there already
        own = dataclasses.replace(latest.verified, branch_changed=changed)
    elif settled.final is not None:
        own = verify(done.model, refine, changed)
    else:
        own = Verified(None, None, refine, 0, 0.0, changed, "failed: no state at the best design")
    own_relative = float("inf") if own.relative is None else own.relative
    if same or own_relative <= best.relative:
        return done, settled, own
    log.info("verify.best: iteration %d's growth verifies at %.3g %%, the optimiser's best "
             "at %s: the run goes on with iteration %d's", best.check.iteration,
             100 * best.relative, f"{100 * own_relative:.3g} %" if own.relative is not None
             else own.status, best.check.iteration)
    done = dataclasses.replace(done, best=best.design)
    settled = settle(done)
    verified = best.verified if best.verified is not None else verify(done.model, refine)
    return done, settled, dataclasses.replace(verified, branch_changed=settled.branch_changed,
                                              iteration=best.check.iteration)


def _designed(check: Candidate, design: np.ndarray, comm) -> bool:
    """Whether the check's design is ``design`` on every rank (collective)."""
    return comm.allreduce(bool(np.array_equal(check.design, design)), op=MPI.LAND)


def verify_best(cfg, model: ForwardModel, settled: Settled, refined: Verified | None = None,
                lift_onto: Config | None = None) -> Verified | None:
    """The best growth on the mesh refined ``verify.refine`` times, grown from rest there
    (``refined`` where it was already), and for a section lifted onto its 3D body
    (``verify.lift``); None with verify off."""
    if not cfg.verify.enabled:
        return None
    changed = settled.branch_changed
    if settled.final is None:
        return Verified(None, None, cfg.verify.refine, 0, 0.0, changed,
                        "failed: no state at the best design")
    if refined is not None:
        verified = refined
    else:
        log.info("verifying: the best growth on the mesh refined %d time(s), grown from rest",
                 cfg.verify.refine)
        verified = verify(model, cfg.verify.refine, changed)
    if cfg.verify.lift is not None:
        onto = lift_onto if lift_onto is not None else load(cfg.verify.lift)
        solid = verification_model(onto, cfg.verify.lift_refine, cfg.verify.lift_degree)
        log.info("lifting: the best growth onto the 3D body of %s (its mesh refined %d "
                 "time(s)), grown from rest", cfg.verify.lift, solid.mesh.refine)
        verified = dataclasses.replace(verified, lifted=lift(model, solid))
    return verified


def summarise(cfg, done: Optimised, settled: Settled, verified: Verified | None, timer: Timer,
              resume: bool) -> RunSummary:
    model, history, final, from_rest = done.model, done.history, settled.final, settled.from_rest
    first = history[0] if history else None
    report = final.report if final else SolveReport(converged=False, reason="no state")
    return base_summary(
        cfg, model, report, done.status, timer,
        iterations=len(history),
        objective_initial=first.objective if first else None,
        objective_final=final.value.total if final else None,
        rho_H_initial=first.rho_H if first else None,
        rho_H_final=final.value.rho_H if final else None,
        hausdorff_initial=first.hausdorff if first else None,
        hausdorff_final=settled.hausdorff,
        target_size=settled.size,
        newton_iterations_total=sum(r.newton_iterations for r in history),
        dofs=Dofs(model.state_dofs(), done.design_size),
        optimization=OptimizationMeasures(
            evaluations=done.rf.evaluations,
            residual_strain=model.residual_strain_norm(),
            # the best growth applied to the body at rest: the shape a body grown so takes
            rho_H_from_rest=from_rest.rho_H if from_rest else None,
            hausdorff_from_rest=from_rest.hausdorff if from_rest else None,
            resumed=resume),
        verified=verified)
