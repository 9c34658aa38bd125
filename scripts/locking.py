"""Locking and its cure: a thin cantilever under a small tip load, neo-Hookean (mu = 1) at
Poisson's ratio nu = 0.3, 0.49, 0.499, 0.4999 (kappa = 2 mu (1 + nu) / (3 (1 - 2 nu))), its tip
deflection with P2 displacements (material.formulation: displacement) and with the mixed
Taylor-Hood element (mixed), each on the beam's mesh and on it refined once, against the mixed
element on the mesh refined twice (the converged reference).

The beam is configs/tiny/beam_bend.yaml's box (1 x 0.1 x 0.02, size 0.05, one layer of
cells through the thickness), clamped at X1 = 0; the load is a traction on its end face X1 = 1
sized for an Euler-Bernoulli deflection of 1e-3 (linear range).  Incompressible (nu = 0.5)
rows are the mixed element's limit (material.incompressible).  Writes
results/locking/table.md (and a folder per solve); serially or under mpirun.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from shapegrowth.commands.cli import main as cli

ROOT = Path(__file__).resolve().parents[1]
BEAM = ROOT / "configs" / "tiny" / "beam_bend.yaml"
LENGTH, THICKNESS = 1.0, 0.02
NUS = (0.3, 0.49, 0.499, 0.4999)
TARGET = 1e-3  # the Euler-Bernoulli tip deflection the load is sized for


def solve(out: Path, nu: float | None, formulation: str, refine: int) -> float:
    """The tip's deflection (-u_3 at (1, 0, 0)) of one solve; nu None: incompressible."""
    E = 2 * (1 + (0.5 if nu is None else nu))
    load = TARGET * E * THICKNESS ** 2 / (4 * LENGTH ** 3)  # delta = 4 s L^3 / (E t^2)
    sets = ["material.kind=neo_hookean", "material.mu=1", f"mesh.refine={refine}",
            "growth.eigenvalues.initial=[1, 1, 1]", "parameters={kappa: 0}",
            f"loads.traction={{x1_max: [0, 0, {-load}]}}"]
    if nu is None:
        sets.append("material.incompressible=true")
    else:
        sets += [f"material.kappa={2 * (1 + nu) / (3 * (1 - 2 * nu))!r}",
                 f"material.formulation={formulation}"]
    summary = out / "summary.json"
    if not summary.is_file():
        args = ["solve", str(BEAM), "--out", str(out), "-q", "--probe", "1,0,0"]
        assert cli([*args, *[x for s in sets for x in ("--set", s)]]) == 0, out
    probe = json.loads(summary.read_text())["probes"][0]
    return -(probe["deformed"][2] - probe["reference"][2])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=ROOT / "results" / "locking")
    args = parser.parse_args()
    rows = ["| nu | kappa/mu | P2 displacement | P2, refined once | mixed | mixed, refined once "
            "| reference (mixed, refined twice) |", "|---|---|---|---|---|---|---|"]
    for nu in (*NUS, None):
        tag = "0.5" if nu is None else f"{nu}"
        ref = solve(args.out / f"{tag}-mixed-2", nu, "mixed", 2)
        cells = []
        for formulation in ("displacement", "mixed"):
            for refine in (0, 1):
                if nu is None and formulation == "displacement":
                    cells.append("-")
                    continue
                d = solve(args.out / f"{tag}-{formulation}-{refine}", nu, formulation, refine)
                cells.append(f"{d / ref:.4f}")
        kappa = "inf" if nu is None else f"{2 * (1 + nu) / (3 * (1 - 2 * nu)):.4g}"
        rows.append(f"| {tag} | {kappa} | {' | '.join(cells)} | {ref:.6g} |")
    table = "\n".join(rows) + "\n"
    (args.out / "table.md").write_text(table)
    print(table)


if __name__ == "__main__":
    main()
