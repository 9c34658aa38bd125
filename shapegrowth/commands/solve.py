"""``shapegrowth solve``: :func:`solve_forward` solves the state for the config's initial
growth and writes summary.json and fields.xdmf."""

from __future__ import annotations

import logging
from pathlib import Path
from typing import Any

import numpy as np

from .. import compat
from ..config import Config
from ..errors import InputError
from ..io import files as io
from ..io.summary import Dofs, LinearSolverUse, Probe, RunSummary, SolveMeasures
from ..physics import linear
from ..physics.model import ForwardModel
from ..physics.newton import NewtonSolver
from ..physics.paths import solve_watched
from ..physics.stability import describe
from ..physics.state import SolveReport
from ..status import Outcome
from ..timing import Timer, peak_memory_mb
from ..version import __version__
from .starts import start_growth

log = logging.getLogger(__name__)


def parse_probes(texts: list[str], dim: int) -> np.ndarray:
    points = []
    for text in texts:
        try:
            values = [float(v) for v in text.split(",")]
        except ValueError:
            values = []
        if len(values) not in (dim, 3) or (len(values) == 3 and dim == 2 and values[2] != 0):
            raise InputError(f"--probe {text}: expected {dim} numbers x1,...,x{dim} "
                             "separated by commas")
        points.append(values + [0.0] * (3 - len(values)))
    return np.array(points, dtype=float).reshape(-1, 3)


def solve_forward(cfg: Config, out: Path,
                  probe_texts: list[str] | tuple[str, ...] = ()) -> RunSummary:
    """Forward solve with the config's initial growth, written to ``out``; returns its
    summary (``status``: converged, or failed with the reason)."""
    with linear.counting() as tally:
        return _solve_forward(cfg, out, probe_texts, tally)


def linear_use(newton: NewtonSolver, tally: linear.FallbackTally) -> LinearSolverUse:
    """summary.json's ``linear_solver``: the preset of the model's Newton solver, why, and the
    fallbacks and Krylov iterations counted in ``tally``."""
    return LinearSolverUse(newton.linear, tally.state + tally.adjoint, tally.state,
                           tally.adjoint, tuple(tally.reasons), reason=newton.linear_reason,
                           krylov_solves=tally.krylov_solves,
                           krylov_iterations=tally.krylov_iterations)


def _solve_forward(cfg: Config, out: Path, probe_texts: list[str] | tuple[str, ...],
                   tally: linear.FallbackTally) -> RunSummary:
    timer = Timer()
    section = cfg.section
    n_probe = 3 if section.reduced else cfg.dim  # a section's probes are the 3D body's points
    probes = parse_probes(list(probe_texts), n_probe)
    on_mesh = probes
    if section.reduced and len(probes):
        on_mesh = np.zeros_like(probes)
        on_mesh[:, :2] = section.coordinates_of(probes)
    with timer("forward"):
        model = ForwardModel.build(cfg)
        start_growth(model, cfg)  # growth.start: run or lifted
    if len(probes):
        outside = np.isnan(compat.evaluate_at_points(model.state.u, on_mesh)[:, 0])
        if outside.any():
            bad = ",".join(f"{v:g}" for v in probes[np.argmax(outside)][:n_probe])
            raise InputError(f"--probe {bad}: the point is outside the reference body")
    log.info("solving %s: %d state DOFs, growth %s", cfg.name,
             compat.global_size(model.state.V), cfg.growth.frame)
    with timer("forward"):  # the path watched, and the stability of the state found
        report, stability, stability_problem = solve_watched(model.state, cfg.solver.branch)
    if stability is not None:
        log.info("stability: %s", describe(stability))
    status = Outcome.converged() if report.converged else Outcome.failed(report.reason)
    log.info("%s after %d load steps, %d Newton iterations (%.2f s)", status, report.steps,
             report.newton_iterations, report.seconds)

    vol_ref, vol_def = model.volumes()
    shape: dict[str, Any] = {}
    if cfg.target is not None:
        from ..optim.objective import Objective

        with timer("hausdorff"):
            objective = Objective(cfg, model.state)
            value, _ = objective.evaluate(gradient=False)
            exact = value.hausdorff  # computed with rho_H
        shape = {"objective_initial": value.total, "objective_final": value.total,
                 "rho_H_initial": value.rho_H, "rho_H_final": value.rho_H,
                 "hausdorff_initial": exact, "hausdorff_final": exact,
                 "target_size": objective.target_size}
        log.info("rho_H = %.6g, Hausdorff distance %.6g (%.3g of the target size)", value.rho_H,
                 exact, exact / objective.target_size)
    deformed: np.ndarray = np.zeros((0, 3))
    if len(probes):
        u = compat.evaluate_at_points(model.state.u, on_mesh)
        deformed = (section.deformed_points(probes, u) if section.reduced
                    else probes[:, :cfg.dim] + u)
    measures = SolveMeasures(
        volume_reference=vol_ref, volume_deformed=vol_def, stress_l2=model.stress_norm(),
        residual_strain=model.residual_strain_norm(),
        probes=tuple(Probe(tuple(map(float, p[:n_probe])), tuple(map(float, d)))
                     for p, d in zip(probes, deformed)))
    summary = base_summary(cfg, model, report, status, timer, solve=measures,
                           linear_solver=linear_use(model.state.newton, tally),
                           stability=stability, **shape)
    # summary.json before the fields: a writer that fails (dolfinx 0.5.2's XDMF pull-back on
    # badly distorted curved cells) leaves the numbers
    io.write_json(out / "summary.json", summary.to_json())
    fields = io.write_fields(out / "fields.xdmf", model.state.u, model.state.applied,
                             extra=[model.residual_strain_field(), stability_problem.mode])
    for p, d in zip(probes, deformed):
        log.info("probe X = (%s) -> Phi(X) = (%s)", ", ".join(f"{v:.6g}" for v in p[:n_probe]),
                 ", ".join(f"{v:.6g}" for v in d))
    if fields:
        log.info("wrote %s and %s", out / "summary.json", out / "fields.xdmf")
        log.info("view: paraview %s, then Filters > Warp By Vector (displacement)",
                 out / "fields.xdmf")
    else:
        log.info("wrote %s", out / "summary.json")
    return summary


def base_summary(cfg: Config, model: ForwardModel, report: SolveReport, status: Outcome,
                 timer: Timer, **measured: Any) -> RunSummary:
    """The summary's common keys for ``model`` after ``report``; ``measured`` sets or
    overrides any of :class:`RunSummary`'s fields."""
    values: dict[str, Any] = {
        "name": cfg.name,
        "status": status,
        "iterations": 0,
        "objective_initial": None,
        "objective_final": None,
        "rho_H_initial": None,
        "rho_H_final": None,
        "hausdorff_initial": None,
        "hausdorff_final": None,
        "target_size": None,
        "wall_time_s": timer.wall,
        "time_split": timer.split(),
        "newton_iterations_total": report.newton_iterations,
        "continuation_steps": report.steps,
        "failed_steps": report.failed_steps,
        "growth_reached": report.reached,
        "dofs": Dofs(compat.global_size(model.state.V), model.design_dofs()),
        "mpi_size": model.comm.size,
        "version": __version__,
        "dolfinx_version": compat.DOLFINX_VERSION,
        "mesh": str(model.domain.path),
        "config": cfg.to_dict(),
        "peak_memory_mb": peak_memory_mb(model.comm),
    }
    values.update(measured)
    return RunSummary(**values)
