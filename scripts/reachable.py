"""Reachable targets: shapes that a known growth produces, found again from no growth.

    .venv/bin/python scripts/reachable.py [--algorithms lbfgs,mma,slsqp] [--only NAME,...]
                                          [--ranks 1] [--set KEY=VALUE ...]
                                          [--out results/reachable] [--report docs/REACHABLE.md]

Each case is a config in configs/reachable/ whose target is the image of a known growth
(a bend of curvature kappa, a twist, a uniform swelling, a plane shear).  For each case:

1. the known growth is solved on the same mesh (``shapegrowth solve``): its shape error
   e_known is what the discretisation allows;
2. ``shapegrowth run`` starts from no growth with the config's defaults (and each
   algorithm of ``--algorithms``) and must end within TOLERANCE x e_known, or within
   FLOOR of the target size where the discretisation represents the known growth exactly
   (the swelling and the shear are affine: e_known is round-off there).

The table gives, per case and algorithm, the final shape error, its ratio to the bound,
the iterations and seconds to 1 % and to 0.3 % shape error, and the optimiser's own share
of the run.  Every number in REPORT comes from the run folders in OUT; exit 1 if a default
run misses its bound.
"""

from __future__ import annotations

import argparse
import csv
import json
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

from shapegrowth.commands import launch
from shapegrowth.io.summary import RunSummary

ROOT = Path(__file__).resolve().parent.parent

TOLERANCE = 3.0  # the optimiser's shape error may be this multiple of the known growth's
FLOOR = 1e-3  # ... or this fraction of the target size, where the known growth is exact


@dataclass(frozen=True)
class Case:
    name: str
    config: str
    sets: tuple[str, ...]  # the case's own settings (curvature, ...)
    known: tuple[str, ...]  # the settings that apply the known growth
    what: str


BEND = "configs/reachable/bend.yaml"
BEND_GROWTH = ("growth.eigenvalues.initial=['(1 + kappa*x3)**2', 1, 1]",)
TARGET_START = ("growth.start=target", "growth.eigenvalues.initial=null",
                "growth.angles.initial=null")  # the known growth is the target's own metric
CASES = [
    Case("bend_1", BEND, ("parameters.kappa=1.0",), BEND_GROWTH, "beam bent to curvature 1"),
    Case("bend_quarter", BEND, ("parameters.kappa=1.5707963267948966",), BEND_GROWTH,
         "beam rolled into a quarter circle"),
    Case("bend_half", BEND, ("parameters.kappa=3.141592653589793",), BEND_GROWTH,
         "beam rolled into a half circle"),
    Case("swell", "configs/reachable/swell.yaml", (),
         ("growth.eigenvalues.initial=['s**2', 's**2', 's**2']",), "cube swollen by 1.1"),
    Case("twist", "configs/reachable/twist.yaml", (), TARGET_START,
         "strip twisted a quarter turn about a parallel axis (free 3D frame)"),
    Case("shear", "configs/reachable/shear.yaml", (),
         TARGET_START, "square sheared by 0.3 (plane strain, free frame)"),
]


def bound(known_error: float) -> float:
    """The largest final shape error (relative to the target size) a run may end with."""
    return max(TOLERANCE * known_error, FLOOR)


def _sets(items) -> list[str]:
    return [a for s in items for a in ("--set", s)]


def _run(args: list[str], ranks: int, log: Path) -> None:
    with open(log, "w") as fh:
        done = launch.launch(args, ranks, one_thread=False, stdout=fh,
                             stderr=subprocess.STDOUT, cwd=ROOT)
    if done.returncode not in (0, 1):
        raise SystemExit(f"reachable: '{' '.join(args)}' exited {done.returncode} (see {log})")


def finished(folder: Path) -> RunSummary | None:
    """The run's (or the solve's) summary, or None before it ends."""
    return launch.read_summary(folder)


def relative(summary: RunSummary) -> float:
    """The self-reported shape error (the run's own mesh and path)."""
    error = summary.relative_error
    if error is None:
        raise SystemExit(f"reachable: {summary.name} has no shape error ({summary.status})")
    return error


def first_below(rows: list[dict], size: float, level: float) -> tuple[int, float] | None:
    """(iteration, seconds) of the first iteration whose shape error is at most ``level``."""
    for row in rows:
        if float(row["hausdorff"]) / size <= level:
            return int(row["iteration"]), float(row["seconds"])
    return None


def measure(case: Case, algorithm: str | None, out: Path, ranks: int, extra: list[str]) -> dict:
    """Solve the known growth and run the optimiser; a finished folder is read back."""
    base = ROOT / case.config
    known_dir = out / case.name / "known"
    known = finished(known_dir)
    if known is None:
        known_dir.mkdir(parents=True, exist_ok=True)
        _run(["solve", str(base), "--out", str(known_dir), "-q",
              *_sets(case.sets + case.known + tuple(extra))], ranks, known_dir / "log.txt")
        known = finished(known_dir)
    run_dir = out / case.name / (algorithm or "default")
    run = finished(run_dir)
    if run is None:
        run_dir.mkdir(parents=True, exist_ok=True)
        sets = case.sets + tuple(extra) + ((f"optimizer.algorithm={algorithm}",) if algorithm
                                           else ())
        _run(["run", str(base), "--out", str(run_dir), "-q", *_sets(sets)], ranks,
             run_dir / "log.txt")
        run = finished(run_dir)
    with open(run_dir / "history.csv") as fh:
        rows = list(csv.DictReader(fh))
    if known is None or run is None:
        raise SystemExit(f"reachable: {case.name} ended without a summary (see its log.txt)")
    size = run.target_size or 1.0
    e_known = relative(known)
    e_run = relative(run)
    return {"case": case.name, "what": case.what, "algorithm": run.config["optimizer"][
        "algorithm"], "default": algorithm is None, "known": e_known, "final": e_run,
        "bound": bound(e_known), "passed": e_run <= bound(e_known),
        "iterations": run.iterations, "status": str(run.status),
        "to_1pc": first_below(rows, size, 0.01), "to_03pc": first_below(rows, size, 0.003),
        "wall_s": run.wall_time_s,
        "optimizer_share": run.time_split.get("optimizer", 0.0) / run.wall_time_s,
        "design_dofs": run.dofs.design, "state_dofs": run.dofs.state}


def _when(hit) -> str:
    return f"{hit[0]} ({hit[1]:.0f} s)" if hit else "-"


def report(rows: list[dict], ranks: int) -> str:
    lines = [
        "# Reachable targets",
        "",
        "Written by `scripts/reachable.py` from its run folders; do not edit by hand.",
        "",
        "Each target is the image of a known growth.  *known* is the shape error (exact",
        "Hausdorff distance / target size) of that growth solved on the same mesh: what the",
        "discretisation allows.  The optimiser starts from no growth; it passes when it ends",
        f"within {TOLERANCE:g} x *known*, or within {100 * FLOOR:g} % of the size where the",
        "known growth is exact on the mesh (affine cases).  *to 1 %* and *to 0.3 %*: the",
        "first iteration (and seconds into the run) at that shape error.  *optimiser*: NLopt's",
        f"own share of the run's wall time.  {ranks} rank(s).",
        "",
        "| case | design DOFs | algorithm | known | final | bound | passed | iterations | "
        "to 1 % | to 0.3 % | wall s | optimiser |",
        "|---|---:|---|---:|---:|---:|---|---:|---:|---:|---:|---:|",
    ]
    for r in rows:
        algo = r["algorithm"] + (" (default)" if r["default"] else "")
        lines.append(
            f"| {r['case']} | {r['design_dofs']} | {algo} | {100 * r['known']:.3f} % | "
            f"{100 * r['final']:.3f} % | {100 * r['bound']:.3f} % | "
            f"{'yes' if r['passed'] else '**no**'} | {r['iterations']} | {_when(r['to_1pc'])} | "
            f"{_when(r['to_03pc'])} | {r['wall_s']:.0f} | {100 * r['optimizer_share']:.1f} % |")
    lines += ["", "Cases: " + "; ".join(f"`{c.name}` {c.what}" for c in CASES) + "."]
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--algorithms", default="",
                        help="comma-separated algorithms to run beside the default")
    parser.add_argument("--only", default="", help="comma-separated case names")
    parser.add_argument("--ranks", type=int, default=1)
    parser.add_argument("--set", action="append", default=[], dest="sets")
    parser.add_argument("--out", type=Path, default=ROOT / "results" / "reachable")
    parser.add_argument("--report", type=Path, default=ROOT / "docs" / "REACHABLE.md")
    args = parser.parse_args(argv)
    only = set(filter(None, args.only.split(",")))
    unknown = only - {c.name for c in CASES}
    if unknown:
        print(f"reachable: unknown case(s) {', '.join(sorted(unknown))} "
              f"(known: {', '.join(c.name for c in CASES)})", file=sys.stderr)
        return 2
    algorithms = [None, *filter(None, args.algorithms.split(","))]
    rows = []
    for case in CASES:
        if only and case.name not in only:
            continue
        for algorithm in algorithms:
            row = measure(case, algorithm, args.out, args.ranks, args.sets)
            print(f"reachable: {case.name} {row['algorithm']}: {100 * row['final']:.3f} % "
                  f"(known growth {100 * row['known']:.3f} %, bound {100 * row['bound']:.3f} %)",
                  flush=True)
            rows.append(row)
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "reachable.json").write_text(json.dumps(rows, indent=1))
    args.report.parent.mkdir(parents=True, exist_ok=True)
    args.report.write_text(report(rows, args.ranks))
    return 0 if all(r["passed"] for r in rows if r["default"]) else 1


if __name__ == "__main__":
    sys.exit(main())
