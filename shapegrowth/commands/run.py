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
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from mpi4py import MPI

from .. import compat
from ..config import load, resolved
from ..io import files as io
from ..io.along import VerifyEvery
from ..io.checkpoint import CheckpointFile
from ..io.figures3d import write_shape3d_png
from ..io.plotting import write_frame_png, write_shape_png
from ..io.summary import Dofs, OptimizationMeasures, RunSummary
from ..optim.callbacks import FromRestEvery, ProgressLog, ProgressTolerance, RetryFromRest
from ..optim.driver import Driver, DriverSettings
from ..optim.interface import DriverResult, Record
from ..optim.levels import level_config
from ..optim.lift import check_liftable, lift, lift_growth, verification_model
from ..optim.problem import ReducedFunctional, StateSolveError
from ..optim.refined import (
    TOLERATED,
    Verified,
    branch_changed,
    likely_cause,
    verify,
)
from ..physics.model import ForwardModel
from ..physics.state import SolveReport
from ..status import Outcome
from ..timing import Timer
from .solve import InputError, base_summary

log = logging.getLogger(__name__)


@dataclass
class RunResult:
    summary: RunSummary
    exit_status: int  # 0, or 1 for a failed run
    model: ForwardModel  # left at the best design


def _from_rest(model: ForwardModel, rf: ReducedFunctional):
    """The objective at the current growth solved again from rest (load steps from C_g = I),
    or None if that fails.  The optimiser reaches its equilibria by warm starts along its own
    path; a thin body can have several, and the one reached from rest is what growing the
    body with this growth does.  The optimiser's state is put back afterwards."""
    state = model.state
    kept = state.snapshot()
    state.reset()
    try:
        report = state.solve()
        value = rf.objective.evaluate(gradient=False)[0] if report.converged else None
    finally:
        state.restore(kept)
    if value is None:
        log.warning("the best growth could not be solved from rest: %s", report.reason)
    return value


def _start_lifted(model: ForwardModel, run_dir: Path) -> None:
    """growth.start: lifted: the 2D section run's best growth, extruded or revolved onto
    ``model``'s 3D body (its initial growth and design)."""
    from .lift import reduced_run

    reduced_cfg, summary, reduced = reduced_run(run_dir, solve=False)
    check_liftable(reduced_cfg, model.cfg)
    lift_growth(reduced_cfg, reduced.state.applied, model)
    log.info("growth.start: lifted from %s (its verified error %s)", run_dir,
             f"{100 * summary.verified.relative:.3g} %" if summary.verified and
             summary.verified.relative is not None else "not measured")


def _start_from_run(model: ForwardModel, run_dir: Path) -> None:
    """growth.start: run: the best growth of a finished run on the same mesh, field by field
    (fields it lacks, such as a fixed frame's angles, keep their initial values)."""
    applied = model.state.applied
    try:
        names = io.read_growth(run_dir / "growth.npz", applied, partial=True)
    except ValueError as err:
        raise InputError(f"growth.from_run: {err}; start: run needs the same body and the "
                         "mesh of this run's first level") from None
    model.growth.assign(applied.values())
    log.info("growth.start: %s from %s", ", ".join(names), run_dir)


def run_optimization(cfg, out: Path, resume: bool = False) -> RunResult:
    """Optimise ``cfg``'s growth and write every output to ``out`` (module doc).  Per level
    of ``optimizer.levels`` (one without): the model, its reduced functional J(m) from the
    last level's design, NLopt on J with the progress log, the checkpoint, the retry from
    rest and the physical branch as callbacks; then the best growth verified."""
    timer = Timer()
    levels = cfg.optimizer.levels
    history: list[Record] = []
    previous: tuple[ReducedFunctional, np.ndarray] | None = None
    reached: tuple[ForwardModel, ReducedFunctional, Driver, DriverResult] | None = None
    failure: Outcome | None = None
    checked = 0.0  # seconds of verify.every's checks so far
    if not resume and MPI.COMM_WORLD.rank == 0 and (out / "verified.csv").exists():
        (out / "verified.csv").unlink()  # a new run's checks only
    for k in range(len(levels)):
        level_cfg = level_config(cfg, k)
        with timer("forward"):
            model = ForwardModel.build(level_cfg)
            if k == 0 and cfg.growth.start == "lifted":
                _start_lifted(model, Path(resolved(cfg.growth.from_run)))
            if k == 0 and cfg.growth.start == "run":
                _start_from_run(model, Path(resolved(cfg.growth.from_run)))
        rf = ReducedFunctional(model, timer)
        if previous is not None:
            rf.carry_design(*previous)  # exact: the level's mesh is nested in the last one's
        if len(levels) > 1:
            log.info("level %d of %d: the mesh refined %d time(s), %d state DOFs, %d "
                     "iterations", k + 1, len(levels), levels[k],
                     compat.global_size(model.state.V), level_cfg.optimizer.max_iterations)
        path = out / ("checkpoint.h5" if k == 0 else f"checkpoint-level{k}.h5")
        callbacks = [ProgressLog(), CheckpointFile(path, rf, cfg.output.checkpoint_every,
                                                   resume and (k == 0 or path.is_file()), timer),
                     RetryFromRest(rf), FromRestEvery(rf, cfg.optimizer.from_rest_every)]
        if cfg.solver.rtol_far is not None:
            callbacks.append(ProgressTolerance(rf, cfg.solver.rtol, cfg.solver.rtol_far,
                                               cfg.optimizer.ftol_rel))
        along = None
        if cfg.verify.every:
            along = VerifyEvery(model, cfg.verify.refine, cfg.verify.every,
                                rf.objective.target_size, out / "verified.csv", timer, k,
                                len(history), checked)
            callbacks.append(along)
        driver = Driver(rf, DriverSettings.from_config(level_cfg), callbacks)
        result = driver.run()
        checked = along.spent if along is not None else checked
        timer.totals["optimizer"] += result.optimizer_seconds
        history += [dataclasses.replace(r, iteration=len(history) + i, level=k)
                    for i, r in enumerate(result.history)]
        if result.outcome.is_failure and not result.history and reached is not None:
            # not one state on this level: the last level's result is the run's (no
            # computed result is lost), the run is reported failed with the reason
            log.warning("level %d of %d: %s; the run ends with level %d's best design",
                        k + 1, len(levels), result.outcome.reason, k)
            failure = Outcome.failed(f"level {k + 1} of {len(levels)}: "
                                     f"{result.outcome.reason}")
            model, rf, driver, result = reached
            break
        reached = (model, rf, driver, result)
        previous = (rf, driver.vec.local(result.best))
        if result.outcome.is_failure:
            break
    status = failure or result.outcome
    # leave the state at the best design for the fields and the final numbers
    final = None
    failed = status.is_failure
    if failed:
        rf.restart_from_rest()  # not a warm start from the state that failed
    try:
        final = rf.evaluate(driver.vec.local(result.best), gradient=False)
    except StateSolveError as err:
        log.warning("could not re-solve the best design: %s", err)
    with timer("io"):
        io.write_history(out, history)
        phi = io.deformation_field(model.state.u)
        io.write_fields(out / "fields.xdmf", model.state.u, model.state.applied,
                        extra=[phi, model.residual_strain_field()])
        io.write_growth(out / "growth.npz", model.state.applied, model.cfg.mesh.refine)
        applied = model.state.applied
        write_shape_png(out / "shape.png", model.state.u, applied.eigenvalues[0],
                        rf.objective.target.points, "lambda_hat_1")
        write_shape3d_png(out / "shape3d.png", model.cfg, model.state.u,
                          applied.eigenvalues[0], rf.objective.target.points, "lambda_hat_1")
        if applied.frame == "free" and applied.dim == 2:
            write_frame_png(out / "frame.png", model.state.u, applied.eigenvalues,
                            applied.angles[0], rf.objective.target.points)
    # a failed run's final state was already solved from rest
    from_rest = (final.value if failed else _from_rest(model, rf)) if final else None
    report = final.report if final else SolveReport(converged=False, reason="no state")
    first = history[0] if history else None
    # with rho_H at the best design; without a state there, from the clouds as they are
    exact = final.value.hausdorff if final else rf.objective.exact_hausdorff()
    size = rf.objective.target_size
    changed = branch_changed(from_rest.hausdorff if from_rest else None, exact, size)
    verified = None
    if cfg.verify.enabled:
        if final is None:
            verified = Verified(None, None, cfg.verify.refine, 0, 0.0, changed,
                                "failed: no state at the best design")
        else:
            log.info("verifying: the best growth on the mesh refined %d time(s), grown from rest",
                     cfg.verify.refine)
            verified = verify(model, cfg.verify.refine, changed)
            if cfg.verify.lift is not None:
                solid = verification_model(load(cfg.verify.lift), cfg.verify.lift_refine)
                log.info("lifting: the best growth onto the 3D body of %s (its mesh refined %d "
                         "time(s)), grown from rest",
                         cfg.verify.lift, solid.mesh.refine)
                verified = dataclasses.replace(verified, lifted=lift(model, solid))
    summary = base_summary(
        cfg, model, report, status, timer,
        iterations=len(history),
        objective_initial=first.objective if first else None,
        objective_final=final.value.total if final else None,
        rho_H_initial=first.rho_H if first else None,
        rho_H_final=final.value.rho_H if final else None,
        hausdorff_initial=first.hausdorff if first else None,
        hausdorff_final=exact,
        target_size=size,
        newton_iterations_total=sum(r.newton_iterations for r in history),
        dofs=Dofs(compat.global_size(model.state.V), driver.vec.size),
        optimization=OptimizationMeasures(
            evaluations=rf.evaluations,
            residual_strain=model.residual_strain_norm(),
            # the best growth applied to the body at rest: the shape a body grown so takes
            rho_H_from_rest=from_rest.rho_H if from_rest else None,
            hausdorff_from_rest=from_rest.hausdorff if from_rest else None,
            resumed=resume),
        verified=verified)
    io.write_json(out / "summary.json", summary.to_json())
    rel = exact / size
    if from_rest and changed:
        log.warning("the best growth applied from rest reaches another equilibrium: Hausdorff "
                    "%.4g (%.3g %%) against the optimiser's %.4g: the shape depends on the "
                    "growth path (hausdorff_from_rest in summary.json)", from_rest.hausdorff,
                    100 * from_rest.hausdorff / size, exact)
    _report_verified(verified, rel)
    log.info("%s after %d iterations: %s; self-reported %.3g %% (own mesh, the optimiser's "
             "path); rho_H %.4g -> %.4g", status, len(history), _verified_text(verified),
             100 * rel, summary.rho_H_initial or float("nan"),
             summary.rho_H_final or float("nan"))
    log.info("results in %s: summary.json, history.csv, history.png, shape.png, fields.xdmf",
             out)
    log.info("view: paraview %s, Filters > Warp By Vector (displacement), colour by lambda_hat_1",
             out / "fields.xdmf")
    return RunResult(summary, 1 if failed else 0, model)


def _verified_text(verified: Verified | None) -> str:
    if verified is None:
        return "not verified (verify.enabled: false)"
    times = "once" if verified.refine == 1 else f"{verified.refine} times"
    refined = (f"verification {verified.status}" if verified.relative is None else
               f"verified shape error {100 * verified.relative:.3g} % (mesh refined {times}, "
               "grown from rest)")
    lifted = verified.lifted
    if lifted is None:
        return refined
    if lifted.relative is None:
        return f"lift to 3D {lifted.status}; the reduced model's {refined}"
    return (f"lifted to 3D: shape error {100 * lifted.relative:.3g} % ({lifted.config}, "
            f"{lifted.dofs} DOFs, grown from rest); the reduced model's {refined}")


def _report_verified(verified: Verified | None, own_relative: float) -> None:
    """The warning of a run whose verified error exceeds its own by more than a factor 2."""
    if verified is None:
        return
    lifted = verified.lifted
    if lifted is not None and lifted.relative is not None and verified.relative is not None \
            and lifted.relative > TOLERATED * max(verified.relative, own_relative):
        log.warning("the 3D body does not follow the reduced model: lifted %.3g %% against the "
                    "reduced model's %.3g %% (verified): what the reduction leaves out matters "
                    "here (anticlastic bending, the width's own stretch, buckling out of "
                    "symmetry); continue in 3D from this growth", 100 * lifted.relative,
                    100 * verified.relative)
    cause = likely_cause(own_relative, verified)
    if cause is None:
        return
    shown = (f"{100 * verified.relative:.3g} %, {verified.relative / own_relative:.1f} times"
             if verified.relative is not None and own_relative > 0 else verified.status)
    if cause == "branch":
        why = ("likely the branch: the growth grown from rest takes another equilibrium than "
               "the optimiser's path (hausdorff_from_rest in summary.json)")
    else:
        why = ("likely the mesh: the run's mesh does not resolve what its optimum leans on "
               "(refine mesh.size, grade the mesh towards the clamp, or lengthen "
               "growth.filter_length)")
    log.warning("the verified shape error (%s the run's own %.3g %%) is not the run's: %s",
                shown, 100 * own_relative, why)
