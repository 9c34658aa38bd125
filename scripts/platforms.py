"""Do the platforms give the same numbers?  A short run of each scene, and a comparison.

    .venv/bin/python scripts/platforms.py run OUT.json [--iterations 5] [--scenes a,b]
    .venv/bin/python scripts/platforms.py compare A.json B.json [C.json ...]

``run`` runs every shipped scene (the 3D ones and the reduced ones) for a few L-BFGS
iterations on the coarse mesh the fast tier uses (tests/test_scenes.py), without its
verification, and writes per scene: the platform (dolfinx, PETSc, gmsh), the objective at
every iteration, the exact Hausdorff distance at the first and the last, and the seconds.
Run it on each platform from checkouts that share their mesh files (``make test-debian13``
and ``make test-dolfinx011`` copy this machine's into their root; gmsh releases split some
cells otherwise, which alone moves the numbers at the discretisation's level).

``compare`` prints a Markdown table: per scene, the largest relative difference between the
platforms of the first objective (one state solve and the shape term: round-off expected)
and of the last (a path of Newton solves, each converged to its tolerance, and L-BFGS steps
that follow them), and the difference of the last exact Hausdorff distances in points of
the target size.
"""

from __future__ import annotations

import argparse
import csv
import json
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
# the fast tier's coarse settings (tests/test_scenes.py): scene -> its sets
SCENES = {
    "beam_wave": ["mesh.size=0.1", "mesh.layers=1"],
    "beam_ring": ["mesh.size=0.1", "mesh.layers=1"],
    "tube_helix": ["mesh.size=2.0", "mesh.layers=1"],
    "disk_cone": ["mesh.size=0.25", "mesh.layers=1"],
    "cylinder_flare": ["mesh.size=0.25", "mesh.layers=1"],
    "square_circle_fixed": ["mesh.size=1.0"],
    "square_circle_free": ["mesh.size=1.0"],
    **{name: ["mesh.size=0.05", "mesh.layers=2", "verify.lift=null", "verify.lift_refine=null",
                 "verify.lift_degree=null"]
       for name in ("beam_wave_2d", "beam_ring_2d", "disk_cone_axi", "cylinder_flare_axi")},
}


def platform() -> dict[str, str]:
    import dolfinx
    import gmsh
    from petsc4py import PETSc

    return {"dolfinx": dolfinx.__version__, "gmsh": gmsh.__version__,
            "petsc": ".".join(str(v) for v in PETSc.Sys.getVersion()),
            "python": ".".join(str(v) for v in sys.version_info[:3])}


def run(out: Path, iterations: int, scenes: list[str]) -> None:
    from shapegrowth.commands.launch import launch, read_summary, with_sets

    rows: dict[str, dict[str, object]] = {}
    for scene in scenes:
        with tempfile.TemporaryDirectory() as folder:
            sets = [*SCENES[scene], f"optimizer.max_iterations={iterations}",
                    "optimizer.levels=[0]", "optimizer.level_iterations=null",
                    "verify.enabled=false"]
            tic = time.perf_counter()
            done = launch(with_sets(["run", ROOT / "configs" / f"{scene}.yaml", "--out",
                                     folder, "-q"], sets), cwd=ROOT)
            seconds = time.perf_counter() - tic
            summary = read_summary(Path(folder))
            if done.returncode != 0 or summary is None:
                rows[scene] = {"failed": True}
                print(f"{scene}: failed ({done.returncode})", flush=True)
                continue
            with open(Path(folder) / "history.csv") as f:
                history = list(csv.DictReader(f))
            objective = [float(r["objective"]) for r in history]
            rows[scene] = {"objective": objective,
                           "hausdorff": [float(history[0]["hausdorff"]),
                                         float(history[-1]["hausdorff"])],
                           "target_size": summary.target_size, "seconds": seconds}
            print(f"{scene}: J {objective[0]:.12g} -> {objective[-1]:.12g} in "
                  f"{seconds:.0f} s", flush=True)
    out.write_text(json.dumps({"platform": platform(), "scenes": rows}, indent=1))


def compare(paths: list[Path]) -> str:
    """The comparison as a Markdown table (docs/PLATFORMS.md holds the last one)."""
    runs = [json.loads(p.read_text()) for p in paths]
    lines = [f"- `{p.name}`: " + ", ".join(f"{k} {v}" for k, v in r["platform"].items())
             for p, r in zip(paths, runs)]
    lines += ["", "| scene | first objective | last objective | last Hausdorff distance "
              "(points of the target size) |", "|---|---:|---:|---:|"]
    for scene in runs[0]["scenes"]:
        rows = [r["scenes"].get(scene, {"failed": True}) for r in runs]
        if any(row.get("failed") for row in rows):
            failed = sum(bool(row.get("failed")) for row in rows)
            lines.append(f"| {scene} | failed on {failed} | | |")
            continue

        def spread(values: list[float]) -> float:
            return (max(values) - min(values)) / max(abs(v) for v in values)

        first = spread([row["objective"][0] for row in rows])
        last = spread([row["objective"][-1] for row in rows])
        points = [100 * row["hausdorff"][1] / row["target_size"] for row in rows]
        lines.append(f"| {scene} | {first:.1e} | {last:.1e} | {max(points) - min(points):.4f} |")
    return "\n".join(lines)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)
    r = sub.add_parser("run")
    r.add_argument("out", type=Path)
    r.add_argument("--iterations", type=int, default=5)
    r.add_argument("--scenes", default=",".join(SCENES))
    c = sub.add_parser("compare")
    c.add_argument("runs", type=Path, nargs="+")
    args = parser.parse_args()
    if args.command == "run":
        run(args.out, args.iterations, args.scenes.split(","))
    else:
        print(compare(args.runs))
    return 0


if __name__ == "__main__":
    sys.exit(main())
