"""``shapegrowth study``: accuracy against cost over a grid of settings.

Every grid point (the product of the ``--sweep KEY=V1,V2,...`` lists) is one
optimisation run in ``OUT/point-NNN``.  Its optimal growth is then judged on a
*reference* discretisation: the growth the body was given (lambda_hat, theta_hat)
is interpolated onto the reference mesh, the state is solved there, and the exact
Hausdorff distance to the target is measured at the reference's sample points
(``hausdorff_reference``).  A coarse model is so judged by the truth, not by
itself.  The reference is the config with, for every swept resolution key, its
finest value (smallest ``mesh.size``, largest ``mesh.layers``, ``model.degree``,
``model.quadrature_degree``, ``growth.degree``), then the ``--reference``
overrides.  Settings that only steer the optimisation (alpha, the filter, the
optimiser, the linear solver) do not change the reference.

``--reference mesh.refine=N`` judges each point on its *own* mesh refined N times
instead (the mesh keys are then not replaced by the sweep's finest): the refined
mesh is nested in the point's, so the optimal growth carries over exactly and the
reference error is the discretisation error of the state alone.  On a non-nested
finer mesh a growth field with a sharp peak is itself changed by interpolation;
the nested reference leaves that out.

Every point also verifies itself as every run does (``verify.*``: its own mesh refined
``verify.refine`` times, from rest): ``relative_error_verified``.

Resumable: a point with its ``row.json`` is read, not run again; a point with a
checkpoint but no row is resumed.  Under mpirun every point runs on all ranks.
"""

from __future__ import annotations

import itertools
import logging
import math
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import yaml
from mpi4py import MPI

from .. import compat
from ..config import Config, ConfigError, load
from ..io import files as io
from ..optim.objective import Objective
from ..optim.verification import grown_from_rest
from ..physics.model import ForwardModel
from ..timing import peak_memory_mb, reset_peak_memory
from .run import run_optimization

log = logging.getLogger(__name__)

# resolution keys and which end of a sweep is the finer model
FINEST = {"mesh.size": min, "mesh.layers": max, "model.degree": max,
          "model.quadrature_degree": max, "growth.degree": max}
COLUMNS = ("dofs_state", "dofs_design", "iterations", "wall_time_s", "rho_H_final",
           "hausdorff_final", "hausdorff_reference", "peak_memory_mb", "target_size",
           "relative_error_reference", "relative_error_verified", "status")


@dataclass(frozen=True)
class Sweep:
    key: str
    values: tuple[str, ...]  # YAML texts, as --set takes them

    @classmethod
    def parse(cls, text: str) -> Sweep:
        """``KEY=V1,V2,...``; commas inside brackets belong to a value (``[1,2]``)."""
        key, sep, rest = text.partition("=")
        if not sep or not key.strip() or not rest.strip():
            raise ConfigError([f"--sweep: expected KEY=V1,V2,..., got {text!r}"])
        values, depth, current = [], 0, ""
        for ch in rest:
            depth += ch in "[{"
            depth -= ch in "]}"
            if ch == "," and depth == 0:
                values.append(current.strip())
                current = ""
            else:
                current += ch
        values.append(current.strip())
        if any(not v for v in values):
            raise ConfigError([f"--sweep {key}: an empty value in {rest!r}"])
        return cls(key.strip(), tuple(values))


def grid(sweeps: list[Sweep]) -> list[dict[str, str]]:
    keys = [s.key for s in sweeps]
    return [dict(zip(keys, combo)) for combo in itertools.product(*(s.values for s in sweeps))]


def reference_overrides(sweeps: list[Sweep], extra: list[str]) -> list[str]:
    nested = any(e.split("=", 1)[0].strip() == "mesh.refine" for e in extra)
    out = []
    for s in sweeps:
        if nested and s.key.startswith("mesh."):
            continue  # each point is judged on its own mesh, refined
        if s.key in FINEST:
            numbers = [yaml.safe_load(v) for v in s.values]
            out.append(f"{s.key}={FINEST[s.key](numbers)}")
    return out + list(extra)


def evaluate_on_reference(model: ForwardModel, reference: Config) -> dict[str, Any]:
    """The exact Hausdorff distance of ``model``'s applied growth, solved on ``reference``."""
    ref, report = grown_from_rest(model, reference)
    if not report.converged:
        return {"hausdorff_reference": math.nan, "reference_dofs": compat.global_size(ref.state.V),
                "reference_status": f"failed: {report.reason}"}
    objective = Objective(reference, ref.state)
    return {"hausdorff_reference": objective.exact_hausdorff(),
            "reference_dofs": compat.global_size(ref.state.V), "reference_status": "solved"}


def run_study(config: Path, overrides: list[str], sweeps: list[Sweep], out: Path,
              reference_extra: list[str], comm: MPI.Comm = MPI.COMM_WORLD) -> list[dict]:
    points = grid(sweeps)
    ref_sets = reference_overrides(sweeps, reference_extra)
    load(config, overrides + ref_sets)  # a bad reference is reported before any run
    rows = []
    for k, point in enumerate(points):
        folder = out / f"point-{k:03d}"
        sets = [f"{key}={value}" for key, value in point.items()]
        label = ", ".join(sets)
        done = folder / "row.json"
        if done.exists():
            row = io.read_json(done)
            if row.get("point") == point:
                log.info("study %d/%d (%s): done before", k + 1, len(points), label)
                rows.append(row)
                continue
        log.info("study %d/%d: %s", k + 1, len(points), label)
        cfg = load(config, overrides + sets)
        resume = (folder / "checkpoint.h5").exists()
        tic = time.perf_counter()
        reset_peak_memory()
        result = run_optimization(cfg, folder, resume=resume)
        peak = peak_memory_mb(comm)
        wall = time.perf_counter() - tic
        reference = load(config, overrides + sets + ref_sets)
        judged = evaluate_on_reference(result.model, reference)
        s = result.summary
        row = {"point": point, **point,
               "dofs_state": s.dofs.state, "dofs_design": s.dofs.design,
               "iterations": s.iterations, "wall_time_s": wall,
               "rho_H_final": s.rho_H_final, "hausdorff_final": s.hausdorff_final,
               **judged, "peak_memory_mb": peak, "target_size": s.target_size,
               "status": str(s.status), "resumed": resume,
               # the run's own verification (its mesh refined verify.refine times, from rest)
               "relative_error_verified": s.verified.relative if s.verified else None}
        row["relative_error_reference"] = row["hausdorff_reference"] / row["target_size"]
        io.write_json(done, row, comm)
        log.info("  %s: %d iterations, %.1f s, Hausdorff %.4g here, %.4g on the reference "
                 "(%.3g %% of the target size)", s.status, s.iterations, wall,
                 s.hausdorff_final, row["hausdorff_reference"],
                 100 * row["relative_error_reference"])
        rows.append(row)
    write_study(out, [s.key for s in sweeps], rows, comm)
    return rows


def pareto_front(cost: np.ndarray, error: np.ndarray) -> np.ndarray:
    """Indices of the points no other point beats in both cost and error, by cost."""
    order = np.lexsort((error, cost))
    front, best = [], np.inf
    for i in order:
        if error[i] < best:
            front.append(i)
            best = error[i]
    return np.array(front, dtype=int)


def write_study(out: Path, keys: list[str], rows: list[dict], comm: MPI.Comm) -> None:
    """study.csv (one row per grid point) and study.png (shape error against wall time,
    the Pareto front drawn)."""
    if comm.rank == 0 and rows:
        import csv

        out.mkdir(parents=True, exist_ok=True)
        with open(out / "study.csv", "w", newline="") as handle:
            writer = csv.writer(handle)
            writer.writerow([*keys, *COLUMNS])
            for row in rows:
                writer.writerow([row[k] for k in keys] + [row.get(c) for c in COLUMNS])
        _plot(out / "study.png", keys, rows)
    comm.barrier()


def _plot(path: Path, keys: list[str], rows: list[dict]) -> None:
    # a Figure of its own: no pyplot, so a notebook's backend is left alone
    from matplotlib.figure import Figure

    cost = np.array([r["wall_time_s"] for r in rows], dtype=float)
    error = np.array([r["relative_error_reference"] or np.nan for r in rows], dtype=float)
    ok = np.isfinite(error)
    fig = Figure(figsize=(6.0, 4.0), dpi=120)
    ax = fig.subplots()
    ax.loglog(cost[ok], 100 * error[ok], "o", color="0.55", label="grid points")
    if ok.any():
        idx = np.flatnonzero(ok)[pareto_front(cost[ok], error[ok])]
        ax.loglog(cost[idx], 100 * error[idx], "o-", color="C3", label="Pareto front")
    for r, c, e in zip(rows, cost, error):
        if np.isfinite(e):
            ax.annotate(", ".join(f"{k.split('.')[-1]}={r[k]}" for k in keys), (c, 100 * e),
                        textcoords="offset points", xytext=(4, 3), fontsize=6)
    ax.set_xlabel("wall time of the optimisation (s)")
    ax.set_ylabel("shape error on the reference (% of target size)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path)
