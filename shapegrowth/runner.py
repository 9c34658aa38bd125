"""``shapegrowth run``: build the model, optimise, and write every output.

Outputs in the run folder: summary.json, history.csv, history.png, shape.png (the
deformed body coloured by lambda_hat_1, the target as dots), frame.png (a free 2D frame:
its eigenvectors on the deformed body), fields.xdmf (+ .h5:
displacement, Phi, the filtered growth fields lambda_hat_i/theta_hat_i, the
eigenvectors v_i, residual_strain) and checkpoint.h5.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from . import compat, io
from .forward import ForwardModel, base_summary
from .plotting import write_frame_png, write_shape_png
from .optimize import Optimizer
from .problem import ReducedFunctional, StateSolveError
from .state import SolveReport
from .timing import Timer

log = logging.getLogger(__name__)


@dataclass
class RunResult:
    summary: dict[str, Any]
    exit_status: int  # 0, or 1 for a failed run
    model: ForwardModel  # left at the best design


def run_optimization(cfg, out: Path, resume: bool = False) -> RunResult:
    timer = Timer()
    with timer("forward"):
        model = ForwardModel.build(cfg)
    rf = ReducedFunctional(model, timer)
    optimizer = Optimizer(rf, out, resume=resume)
    status, best = optimizer.run()
    history = optimizer.history
    # leave the state at the best design for the fields and the final numbers
    final = None
    if status.startswith("failed"):
        model.state.reset()  # not a warm start from the state that failed
    try:
        final = rf.evaluate(optimizer.vec.local(best), gradient=False)
    except StateSolveError as err:
        log.warning("could not re-solve the best design: %s", err)
    with timer("io"):
        io.write_history(out, history)
        phi = io.deformation_field(model.state.u)
        io.write_fields(out / "fields.xdmf", model.state.u, model.state.applied,
                        extra=[phi, model.residual_strain_field()])
        applied = model.state.applied
        write_shape_png(out / "shape.png", model.state.u, applied.eigenvalues[0],
                        rf.objective.target.points, "lambda_hat_1")
        if applied.frame == "free" and applied.dim == 2:
            write_frame_png(out / "frame.png", model.state.u, applied.eigenvalues,
                            applied.angles[0], rf.objective.target.points)
    report = final.report if final else SolveReport(converged=False, reason="no state")
    summary = base_summary(cfg, model, report, status, timer)
    first = history[0] if history else None
    # with rho_H at the best design; without a state there, from the clouds as they are
    exact = final.value.hausdorff if final else rf.objective.exact_hausdorff()
    summary.update({
        "iterations": len(history),
        "objective_initial": first.objective if first else None,
        "objective_final": final.value.total if final else None,
        "rho_H_initial": first.rho_H if first else None,
        "rho_H_final": final.value.rho_H if final else None,
        "hausdorff_initial": first.hausdorff if first else None,
        "hausdorff_final": exact,
        "target_size": rf.objective.target_size,
        "newton_iterations_total": sum(r.newton_iterations for r in history),
        "dofs": {"state": compat.global_size(model.state.V), "design": optimizer.vec.size},
        "evaluations": rf.evaluations,
        "residual_strain": model.residual_strain_norm(),
        "resumed": resume,
    })
    io.write_json(out / "summary.json", summary)
    rel = exact / rf.objective.target_size
    log.info("%s after %d iterations: rho_H %.4g -> %.4g, Hausdorff distance %.4g "
             "(%.3g %% of the target size)", status, len(history),
             summary["rho_H_initial"] or float("nan"), summary["rho_H_final"] or float("nan"),
             exact, 100 * rel)
    log.info("results in %s: summary.json, history.csv, history.png, shape.png, fields.xdmf",
             out)
    log.info("view: paraview %s, Filters > Warp By Vector (displacement), colour by lambda_hat_1",
             out / "fields.xdmf")
    return RunResult(summary, 0 if not status.startswith("failed") else 1, model)

