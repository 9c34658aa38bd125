"""``shapegrowth run`` of a shell model (``model: {dim: 2, reduction: shell}``): optimise the
growth of the thin body's mid-surface shell, then verify it on the 3D body the config
describes.

The shell's design is its four stretch fields (physics/shell_bodies.py), the target the
config's map sampled where the shell samples its wall (``ShellCloud.mapped``), the driver
the one every run uses.  The best growth is then carried onto the 3D body (linear through
the wall, optim/shell_lift.py) on the 3D config's verification mesh (its mesh refined
``verify.refine`` times), grown from rest there and measured as every verified number
is: that is the run's headline; the shell's own number is reported beside it, labelled.

Outputs in the run folder: summary.json (``verified.lifted``: the 3D body's number, its
DOFs and its departure from the shell), history.csv and history.png, and the verified 3D
body's fields.xdmf (its displacement, the growth lifted onto it) and growth.npz (that
growth at its nodes, on the 3D config's mesh refined ``verify.refine`` times).
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass
from pathlib import Path

from mpi4py import MPI

from .. import compat
from ..config import Config
from ..config.shell_checks import SHELL_KINDS, solid_config
from ..errors import StateSolveError
from ..io import files as io
from ..io.records import Lifted, Verified
from ..io.summary import Dofs, OptimizationMeasures, RunSummary
from ..optim.callbacks import ProgressLog
from ..optim.driver import Driver, DriverSettings
from ..optim.lift import verification_model
from ..optim.objective import measure_verified
from ..optim.shell_lift import lift_shell
from ..optim.shell_objective import ShellCloud
from ..optim.shell_problem import ShellDesign
from ..physics.model import ForwardModel
from ..physics.shell_bodies import design_bounds, shell_body
from ..shape.hausdorff import SmoothHausdorff
from ..shape.targets import mapped_points
from ..status import Outcome
from ..timing import Timer, peak_memory_mb
from ..version import __version__

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class ShellRun:
    """What a shell run leaves: its summary (status, the verified 3D number first)."""

    summary: RunSummary


def _fixed_fields(cfg: Config) -> tuple[int, ...]:
    """The design fields held where they start: an eigenvalue that growth.eigenvalues.design
    leaves out keeps its stretches on both faces."""
    design = cfg.growth.eigenvalues.design
    chosen = set(design) if design is not None else {1, 2, 3}
    tangents = SHELL_KINDS[cfg.geometry.kind].tangents
    return tuple(f for i in (0, 1) if tangents[i] + 1 not in chosen for f in (i, i + 2))


def _verify(cfg: Config, body, shell_dofs: int, comm: MPI.Comm
            ) -> tuple[Verified | None, ForwardModel | None]:
    """The shell's best growth on the 3D body of ``cfg`` (its verification mesh), grown from
    rest and measured, and that 3D body where it reached an equilibrium (collective); None
    with verify off."""
    if not cfg.verify.enabled:
        return None, None
    tic = time.perf_counter()
    solid_cfg = verification_model(solid_config(cfg))
    log.info("verifying: the shell's growth on the 3D %s (its mesh refined %d time(s)), grown "
             "from rest", cfg.geometry.kind, solid_cfg.mesh.refine)
    solid = ForwardModel.build(solid_cfg, comm)
    lifted = lift_shell(body.shell, body.stretches(), solid)
    if lifted.converged:
        measured = measure_verified(solid_cfg, solid.state)
        record = Lifted(measured.hausdorff, measured.relative, lifted.dofs,
                        time.perf_counter() - tic, "solved", f"{cfg.name} (3D)",
                        lifted.departure, surface=measured.surface)
    else:
        record = Lifted(None, None, lifted.dofs, time.perf_counter() - tic,
                        "failed: no equilibrium of the 3D body from rest", cfg.name)
    verified = Verified(None, None, cfg.verify.refine, shell_dofs, 0.0, False,
                        "not refined: a shell is verified on its 3D body (lifted)",
                        lifted=record)
    return verified, solid if lifted.converged else None


def run_shell(cfg: Config, out: Path) -> ShellRun:
    """Optimise ``cfg``'s shell, verify its best growth on the 3D body, write summary.json
    and history.csv to ``out`` (collective)."""
    timer = Timer()
    comm = MPI.COMM_WORLD
    with timer("forward"):
        body = shell_body(cfg, comm)
        start = body.shell.solve()
    shell_dofs = compat.global_size(body.shell.V)
    log.info("shell of the %s: %d DOFs, %d design DOFs", cfg.geometry.kind, shell_dofs,
             compat.global_size(body.faces.function_space))
    h = cfg.objective.hausdorff
    cloud = ShellCloud(body.shell)
    target = cloud.mapped(lambda X: mapped_points(cfg, X)[0])
    rho = SmoothHausdorff(alpha=h.alphas[0], beta=h.beta, gamma=h.gamma, phi=h.phi,
                          cutoff=h.cutoff, taper=h.taper, precision=h.precision)
    lower, upper = design_bounds(cfg)
    history, status = [], Outcome.failed("no equilibrium of the shell at its initial growth")
    final = None
    if start.converged:
        problem = ShellDesign(body.shell, target, rho, lower, upper, cloud,
                              cfg.growth.filter_length, h.form, _fixed_fields(cfg), timer)
        driver = Driver(problem, DriverSettings.from_config(cfg), [ProgressLog()])
        result = driver.run()
        timer.totals["optimizer"] += result.optimizer_seconds
        history, status = result.history, result.outcome
        if history:
            try:
                final = problem.evaluate(driver.local(result.best))  # the shell at the best
            except StateSolveError as err:
                log.warning("shell: the best design's state is not found again (%s); the "
                            "history is kept, nothing is verified", err.report.reason)
    else:
        log.warning("shell: no equilibrium at the initial growth (reached %.3g of it)",
                    start.level)
    size = target.extent(comm)
    verified, solid = None, None
    if final is not None:
        with timer("forward", "verification"):
            verified, solid = _verify(cfg, body, shell_dofs, comm)
    if solid is not None:  # the 3D body's fields: what the verified number measured
        with timer("io"):
            applied = solid.applied
            io.write_fields(out / "fields.xdmf", solid.displacement, applied,
                            extra=[io.deformation_field(solid.displacement)])
            io.write_growth(out / "growth.npz", applied, solid.cfg.mesh.refine)
    first = history[0] if history else None
    summary = RunSummary(
        name=cfg.name, status=status, iterations=len(history),
        objective_initial=first.objective if first else None,
        objective_final=final.value.total if final else None,
        rho_H_initial=first.rho_H if first else None,
        rho_H_final=final.value.rho_H if final else None,
        hausdorff_initial=first.hausdorff if first else None,
        hausdorff_final=final.value.hausdorff if final else None,
        target_size=size, wall_time_s=timer.wall, time_split=timer.split(),
        newton_iterations_total=sum(r.newton_iterations for r in history),
        # the best design's last solve (the start's from rest where none was evaluated)
        continuation_steps=final.report.steps if final else start.steps,
        failed_steps=final.report.failed_steps if final else start.failed_steps,
        growth_reached=final.report.reached if final else start.level,
        dofs=Dofs(shell_dofs, compat.global_size(body.faces.function_space)),
        mpi_size=comm.size, version=__version__, dolfinx_version=compat.DOLFINX_VERSION,
        mesh=f"shell: the mid-surface of the {cfg.geometry.kind}",
        config=cfg.to_dict(),
        optimization=OptimizationMeasures(len(history), None, None, None, False),
        verified=verified, peak_memory_mb=peak_memory_mb(comm))
    io.write_history(out, history, comm)
    io.write_json(out / "summary.json", summary.to_json(), comm)
    _report(summary, out)
    return ShellRun(summary)


def _report(summary: RunSummary, out: Path) -> None:
    """The closing lines: the 3D body's verified number first, the shell's own labelled."""
    verified = summary.verified
    lifted = verified.lifted if verified is not None else None
    own = summary.relative_error
    own_text = "n/a" if own is None else f"{100 * own:.3g} %"
    if lifted is None:
        first = "not verified (verify.enabled: false)" if summary.verified is None and \
            summary.hausdorff_final is not None else "not verified"
    elif lifted.relative is None:
        first = f"verification on the 3D body {lifted.status}"
    else:
        departure = ("" if lifted.departure is None
                     else f", leaving the shell by {100 * lifted.departure:.3g} %")
        first = (f"verified shape error {100 * lifted.relative:.3g} % (the 3D body, "
                 f"{lifted.dofs} DOFs, grown from rest{departure})")
    log.info("%s after %d iterations: %s; self-reported %s (the shell's wall, its own "
             "path)", summary.status, summary.iterations, first, own_text)
    written = [name for name in ("summary.json", "history.csv", "history.png", "fields.xdmf",
                                 "growth.npz") if (out / name).exists()]
    log.info("results in %s: %s", out, ", ".join(written))

