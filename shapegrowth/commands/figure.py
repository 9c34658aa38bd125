"""``shapegrowth figure RUN_DIR``: the 3D view of a finished run (shape3d.png).

The run's own config (summary.json) rebuilds its model on its last level's mesh, its
growth.npz sets the best growth, which is grown from rest there; the deformed body is
drawn over its translucent target (io/figures3d.py).  A run writes the same picture when
it ends; this command makes it again for runs made before, or from another angle.
"""

from __future__ import annotations

import logging
from pathlib import Path

from ..errors import InputError
from ..io.figures3d import View, write_shape3d_png
from ..optim.objective import Objective
from .lift import reduced_run

log = logging.getLogger(__name__)


def figure(run_dir: Path, out: Path, view: View) -> Path:
    """shape3d.png of the run in ``out`` (collective)."""
    cfg, _, model = reduced_run(run_dir, solve=False, command="figure")
    report = model.state.solve()
    if not report.converged:  # a picture at rest would pass for the run's shape
        raise InputError(f"figure: the run's best growth finds no equilibrium from rest on its "
                         f"mesh ({report.reason}); its fields.xdmf holds the run's last state")
    applied = model.state.applied
    objective = Objective(cfg, model.state)
    target = objective.target.points
    path = out / "shape3d.png"
    out.mkdir(parents=True, exist_ok=True)
    if not write_shape3d_png(path, cfg, model.state.u, applied.eigenvalues[0], target,
                             "lambda_hat_1", view, objective.placements()):
        raise InputError(f"figure: {cfg.name} is a plane body; its picture is shape.png")
    log.info("wrote %s", path)
    return path
