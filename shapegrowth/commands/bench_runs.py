"""``shapegrowth bench --runs``: time to a verified shape error, measured on whole runs.

A user waits for a whole run, not for one iteration: the optimiser's own work, the levels,
the verification.  Each run of :data:`RUNS` is ``shapegrowth run`` of a shipped config
(under ``mpirun -n RANKS``) with ``verify.every`` set, so that verified.csv records the
verified shape error along the way (the design grown from rest on the run's mesh refined
``verify.refine`` times).  From it: the run's clock (without the checks) at the first
verified 1 % and 0.3 % (or the best verified error reached, and when), the time split
(forward, adjoint, rho_H, filter, optimiser, io, verification), the Newton iterations per
step and the peak memory.  A section model's headline is its lifted 3D number (at the
end); its time to 1 % is that of the section's own verified number, so labelled.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..errors import InputError
from ..io.along import Check, first_below, read_checks
from ..io.summary import RunSummary, percent
from . import launch

log = logging.getLogger(__name__)

LEVELS = (0.01, 0.003)  # verified shape errors whose time is measured


@dataclass(frozen=True)
class RunCase:
    name: str
    config: str  # relative to configs/
    overrides: tuple[str, ...]
    what: str


RUNS = (
    RunCase("reachable_bend", "reachable/bend.yaml", ("verify.every=10",),
            "a reachable target: the beam rolled into a quarter circle (3D)"),
    RunCase("beam_wave_2d", "beam_wave_2d.yaml", ("verify.every=20",),
            "scene 1, X1-X3 section in plane stress, lifted to 3D at the end"),
    RunCase("beam_wave", "beam_wave.yaml", ("verify.every=60",), "scene 1 in 3D"),
    RunCase("square_circle_free", "square_circle_free.yaml", ("verify.every=20",),
            "scene 6, the free frame (2D)"),
)


@dataclass(frozen=True)
class RunTiming:
    """What bench.json's ``runs`` holds for one run."""

    name: str
    what: str
    ranks: int
    state_dofs: int
    design_dofs: int
    iterations: int
    wall_s: float  # the whole run, checks included
    run_s: float  # the run without verify.every's checks (what a user's run takes)
    to_1pc_s: float | None  # the run's clock at the first verified 1 % (None: not reached)
    to_03pc_s: float | None
    best_verified: float | None  # the best verified error of the checks and the end
    best_at_s: float | None
    final_verified: float | None  # the run's headline: lifted for a section, else refined
    final_self: float | None  # self-reported
    split: dict[str, float]  # seconds per part, the checks and the final verification apart
    newton_per_step: float
    peak_memory_mb: float | None


def timing(case: RunCase, summary: RunSummary, checks: list[Check]) -> RunTiming:
    """The run's timing from its summary and its verified.csv."""
    spent = checks[-1].verification_seconds if checks else 0.0
    v = summary.verified
    final_check = v.check_wall_s if v else 0.0
    run_s = summary.wall_time_s - spent
    split = dict(summary.time_split)
    split["verification"] = spent + final_check
    # the end of the run: its own verification, on the clock without the checks
    points = [(c.verified_relative, c.seconds) for c in checks if c.verified_relative is not None]
    if v is not None and v.relative is not None:
        points.append((v.relative, run_s - final_check))
    best = min(points, default=None)

    def reached(level: float) -> float | None:
        hit = first_below(checks, level)
        if hit is not None:
            return hit.seconds
        if v is not None and v.relative is not None and v.relative <= level:
            return run_s - final_check
        return None

    steps = max(summary.iterations - 1, 1)
    return RunTiming(
        case.name, case.what, summary.mpi_size, summary.dofs.state, summary.dofs.design,
        summary.iterations, summary.wall_time_s, run_s, reached(LEVELS[0]), reached(LEVELS[1]),
        best[0] if best else None, best[1] if best else None,
        v.headline if v is not None else None, summary.relative_error, split,
        summary.newton_iterations_total / steps, summary.peak_memory_mb)


def run_runs(out: Path, ranks: int, only: list[str], overrides: list[str]) -> list[RunTiming]:
    """Every run of RUNS (or those named in ``only``), each in a process of its own; a
    finished run folder is read back, not run again."""
    names = {c.name for c in RUNS}
    unknown = [n for n in only if n not in names]
    if unknown:
        raise InputError(f"bench --runs: no run named {', '.join(unknown)} (the runs: "
                         f"{', '.join(sorted(names))})")
    configs = launch.shipped_configs()
    timings = []
    for case in RUNS:
        if only and case.name not in only:
            continue
        folder = out / "runs" / case.name
        summary = launch.read_summary(folder)
        if summary is None:
            log.info("bench --runs: %s (%s) on %d rank(s) ...", case.name, case.what, ranks)
            args = launch.with_sets(["run", configs / case.config, "--out", folder, "-q"],
                                    [*case.overrides, *overrides])
            done = launch.launch(args, ranks, env={"OPENBLAS_NUM_THREADS": "1"},
                                 capture_output=True, text=True)
            summary = launch.read_summary(folder)
            if summary is None:
                raise RuntimeError(f"bench --runs: {case.name} ended without a summary "
                                   f"(exit {done.returncode}):\n{done.stderr[-3000:]}")
        timings.append(timing(case, summary, read_checks(folder / "verified.csv")))
        log.info("  %s", describe(timings[-1]))
    return timings


def _s(value: float | None) -> str:
    return "not reached" if value is None else f"{value:.0f} s"


def describe(t: RunTiming) -> str:
    return (f"{t.name}: verified 1 % at {_s(t.to_1pc_s)}, 0.3 % at {_s(t.to_03pc_s)}; best "
            f"verified {percent(t.best_verified)} at {_s(t.best_at_s)}; headline "
            f"{percent(t.final_verified)} "
            f"(self-reported {percent(t.final_self)}); run {t.run_s:.0f} s, "
            f"{t.newton_per_step:.1f} Newton iterations per step")


def as_json(timings: list[RunTiming]) -> list[dict[str, Any]]:
    import dataclasses

    return [dataclasses.asdict(t) for t in timings]
