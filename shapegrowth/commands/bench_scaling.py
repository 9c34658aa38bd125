"""``shapegrowth bench --scaling 1,2,4``: strong scaling of one iteration over MPI ranks.

The largest case of the per-iteration bench is run on each number of ranks, one BLAS and
one numba thread per rank (so that a rank is a core and the ranks alone are measured).
Each part of an iteration (the state solve, rho_H, the adjoint with the sensitivities and
filters) is fitted to Amdahl's law, T(p) = T(1) (f + (1 - f) / p), on the rank counts
that fit on the machine's cores; rank counts beyond them run oversubscribed and measure
the parallel overhead (communication, the replicated work), not a speedup.  The fitted
serial fractions give the expected speedup at 16 and 64 ranks: an upper bound, since a
direct solver's communication grows with the ranks and Amdahl's law does not see it.
"""

from __future__ import annotations

import logging
import os
from pathlib import Path
from typing import Any

import numpy as np

log = logging.getLogger(__name__)

PARTS = ("iteration_s", "forward_s", "hausdorff_s", "gradient_s")
PROJECTED = (16, 64)


def cores() -> int:
    """The cores this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def serial_fraction(ranks: list[int], seconds: list[float]) -> float:
    """Amdahl's serial fraction f of T(p) = T(1) (f + (1 - f) / p), least squares over the
    measured rank counts (the first must be 1), clipped to [0, 1]."""
    if len(ranks) < 2 or ranks[0] != 1:
        raise ValueError("serial_fraction: needs 1 rank and at least one more")
    p = np.asarray(ranks[1:], dtype=float)
    y = np.asarray(seconds[1:], dtype=float) / seconds[0] - 1.0 / p  # = f (1 - 1/p)
    a = 1.0 - 1.0 / p
    return float(np.clip(np.dot(a, y) / np.dot(a, a), 0.0, 1.0))


def amdahl(f: float, p: int) -> float:
    return 1.0 / (f + (1.0 - f) / p)


def _parts(case: dict[str, Any]) -> dict[str, float]:
    grad = case["adjoint_s"] + case["sensitivities_s"] + case["filter_backward_s"]
    return {"iteration_s": case["iteration_s"], "forward_s": case["forward_s"],
            "hausdorff_s": case["hausdorff_s"], "gradient_s": grad}


def scaling_table(cases: dict[int, dict[str, Any]], ncores: int) -> dict[str, Any]:
    """bench.json's ``scaling``: per rank count the parts' seconds and speedups, and per part
    the fitted serial fraction and the speedup it projects."""
    ranks = sorted(cases)
    parts = {p: _parts(cases[p]) for p in ranks}
    base = parts[ranks[0]]
    rows = [{"ranks": p, "oversubscribed": p > ncores, "dofs": cases[p]["dofs"],
             "newton_iterations": cases[p]["newton_iterations"],
             "peak_memory_mb": cases[p].get("peak_memory_mb"), **parts[p],
             **{f"speedup_{k[:-2]}": base[k] / parts[p][k] for k in PARTS}} for p in ranks]
    fitted = [p for p in ranks if p <= ncores]
    fits: dict[str, Any] = {}
    if len(fitted) >= 2 and fitted[0] == 1:
        for k in PARTS:
            f = serial_fraction(fitted, [parts[p][k] for p in fitted])
            fits[k[:-2]] = {"serial_fraction": f,
                            **{f"speedup_{n}": amdahl(f, n) for n in PROJECTED}}
    return {"cores": ncores, "fitted_on": fitted, "rows": rows, "amdahl": fits}


def log_table(table: dict[str, Any]) -> None:
    for row in table["rows"]:
        log.info("%d rank(s)%s: iteration %.3g s (state %.3g, rho_H %.3g, gradient %.3g), "
                 "speedup %.2f", row["ranks"], " (oversubscribed)" if row["oversubscribed"]
                 else "", row["iteration_s"], row["forward_s"], row["hausdorff_s"],
                 row["gradient_s"], row["speedup_iteration"])
    for part, fit in table["amdahl"].items():
        log.info("%s: serial fraction %.2f -> speedup %.1f at %d ranks, %.1f at %d", part,
                 fit["serial_fraction"], fit[f"speedup_{PROJECTED[0]}"], PROJECTED[0],
                 fit[f"speedup_{PROJECTED[1]}"], PROJECTED[1])


def run_scaling(run_case, config: Path, overrides: list[str], out: Path, size: float,
                ranks: list[int]) -> dict[str, Any]:
    """``run_case(config, overrides, size, out, ranks, one_thread)`` runs one case in a
    process of its own (bench.py's harness)."""
    if 1 not in ranks:
        ranks = [1, *ranks]
    cases = {}
    for p in sorted(set(ranks)):
        log.info("bench: mesh size %g on %d rank(s), one thread each ...", size, p)
        cases[p] = run_case(config, overrides, size, out / f"scaling-{size:g}-np{p}", p,
                            one_thread=True)
    table = scaling_table(cases, cores())
    table["mesh_size"] = size
    table["cases"] = {str(p): c for p, c in cases.items()}
    log_table(table)
    return table
