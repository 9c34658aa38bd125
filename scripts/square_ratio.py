"""Scene 6 compared fairly: the fixed and the free frame from the same starts, the rho_H
ratio against alpha and the cloud density, beside the floor rho_H(T, T).

For each alpha and cloud degree, five runs of the square of side 4 into the disk of
diameter 12 (plane strain, the shipped configs' mesh and optimiser):

* fixed / free from the target map's metric (``growth.start: target``, the shipped start);
* fixed / free from the same uniform growth: lambda_1 = lambda_2 = 9 pi / 4, the isotropic
  growth whose stress-free square has the disk's area (area ratio sqrt(lambda_1 lambda_2)
  = 36 pi / 16);
* free staged: ``growth.start: run`` from the fixed uniform run's optimum at angle 0, where
  dJ/dtheta no longer vanishes (an isotropic growth has no direction to turn: dJ/dtheta = 0
  there, so a free frame started isotropic only turns once its eigenvalues have parted).

Optionally (``--cube``, or ``--cube-only`` without the plane rows) the 3D cube of side 4 as
the paper ran it: three eigenvalues and three Rodrigues angles, X3 kept (``x3`` mapped to
itself), per mesh size of ``--cube-sizes``: fixed / free from the target's metric (the
free frame's third angle signed, [-pi, pi], so that its in-plane turn keeps its axis at +X3
where it changes sign: eigenframes.one_hemisphere), fixed from the uniform growth
lambda = (9 pi / 4, 9 pi / 4, 1), and the free frame staged from each fixed optimum at
angle 0 (it contains the fixed frame: it cannot end worse than the run it starts from).

Each run is verified as every run is (from rest on its mesh refined once).  The floor is
rho_H(T, T), the value rho_H takes when the body is the target: a ratio of rho_H is only
meaningful well above it, so the table gives the ratio of rho_H and of rho_H - floor.
Writes results/square_ratio/table.md (and a folder per run; resumable).
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

from shapegrowth.commands import launch
from shapegrowth.io.summary import RunSummary

ROOT = Path(__file__).resolve().parents[1]
UNIFORM = 9 * math.pi / 4  # lambda of the isotropic growth with the disk's area


def run(config: str, out: Path, sets: list[str], ranks: int) -> RunSummary | None:
    """The run's summary, run first (under mpirun beyond one rank) where there is none."""
    if launch.read_summary(out) is None:
        print(f"square_ratio: {out.name}", flush=True)
        launch.launch(launch.with_sets(["run", ROOT / "configs" / config, "--out", out, "-q"],
                                       sets), ranks, env={"OPENBLAS_NUM_THREADS": "1"}, cwd=ROOT)
    return launch.read_summary(out)


def floor(config: str, sets: list[str]) -> float:
    """rho_H(T, T) of the target cloud at these settings."""
    from shapegrowth import Objective, build_model, load_config

    cfg = load_config(ROOT / "configs" / config, sets)
    return Objective(cfg, build_model(cfg).state).stopping_scale()  # rho_H(T, T)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--alphas", default="100,1000")
    parser.add_argument("--degrees", default="2,4")
    parser.add_argument("--ranks", type=int, default=1)
    parser.add_argument("--cube", action="store_true", help="also the 3D cube (minutes)")
    parser.add_argument("--cube-only", action="store_true", help="the 3D cube alone")
    parser.add_argument("--cube-sizes", default="1.0", help="the cube's mesh sizes")
    parser.add_argument("--out", type=Path, default=ROOT / "results" / "square_ratio")
    args = parser.parse_args()
    rows = []
    for alpha in ([] if args.cube_only else [float(a) for a in args.alphas.split(",")]):
        for degree in [int(d) for d in args.degrees.split(",")]:
            tag = f"a{alpha:g}-q{degree}"
            base = [f"objective.hausdorff.alpha={alpha}",
                    f"objective.hausdorff.quadrature_degree={degree}"]
            uniform = ["growth.start=given", f"growth.eigenvalues.initial=[{UNIFORM}, {UNIFORM}]"]
            folder = args.out / tag
            results = {
                "fixed, target": run("square_circle_fixed.yaml", folder / "fixed-target", base,
                                     args.ranks),
                "free, target": run("square_circle_free.yaml", folder / "free-target", base,
                                    args.ranks),
                "fixed, uniform": run("square_circle_fixed.yaml", folder / "fixed-uniform",
                                      base + uniform, args.ranks),
                "free, uniform": run("square_circle_free.yaml", folder / "free-uniform",
                                     base + uniform + ["growth.angles.initial=[0.0]"],
                                     args.ranks),
            }
            results["free, staged"] = run(
                "square_circle_free.yaml", folder / "free-staged",
                base + ["growth.start=run", f"growth.from_run={folder / 'fixed-uniform'}",
                        "growth.angles.initial=[0.0]"], args.ranks)
            rows.append((alpha, degree, floor("square_circle_fixed.yaml", base), results))
    lines = table(rows) if rows else []
    if args.cube or args.cube_only:
        lines += cube(args.out, args.ranks, [float(h) for h in args.cube_sizes.split(",")])
    text = "\n".join(lines) + "\n"
    (args.out / "table.md").write_text(text)
    print(text)
    return 0


def _rho(s: RunSummary | None) -> float | None:
    return None if s is None else s.rho_H_final


def _verified(s: RunSummary | None) -> str:
    v = None if s is None or s.verified is None else s.verified.relative
    return "-" if v is None else f"{100 * v:.2f} %"


def table(rows) -> list[str]:
    lines = ["| alpha | clouds | floor rho_H(T,T) | start | fixed rho_H | fixed verified | "
             "free rho_H | free verified | ratio | ratio above the floor |",
             "|---:|---:|---:|---|---:|---:|---:|---:|---:|---:|"]
    for alpha, degree, rho_tt, results in rows:
        for start, fixed_key, free_key in (("target metric", "fixed, target", "free, target"),
                                           ("uniform", "fixed, uniform", "free, uniform"),
                                           ("uniform, free staged from fixed",
                                            "fixed, uniform", "free, staged")):
            f, g = results[fixed_key], results[free_key]
            a, b = _rho(f), _rho(g)
            ratio = "-" if not (a and b) else f"{a / b:.3g}"
            above = "-" if not (a and b) or b <= rho_tt else f"{(a - rho_tt) / (b - rho_tt):.3g}"
            lines.append(f"| {alpha:g} | {degree} | {rho_tt:.4g} | {start} | "
                         f"{'-' if a is None else f'{a:.4g}'} | {_verified(f)} | "
                         f"{'-' if b is None else f'{b:.4g}'} | {_verified(g)} | {ratio} | "
                         f"{above} |")
    return lines


CUBE_MAP = "target.map=[3*x1*sqrt(1 - x2**2/8), 3*x2*sqrt(1 - x1**2/8), x3]"
SIGNED = ("growth.angles.bounds=[[0.0, 6.283185307179586], [0.0, 3.141592653589793], "
          "[-3.141592653589793, 3.141592653589793]]")


def cube(out: Path, ranks: int, sizes: list[float]) -> list[str]:
    """The 3D cube of side 4, three eigenvalues and three angles, per mesh size."""
    lines = ["", "3D cube of side 4 (P2, alpha 1000, clouds of degree 2; the free frame's "
             "t3 in [-pi, pi]; staged: from the fixed run's optimum at angle 0):", "",
             "| h | state DOFs | floor rho_H(T,T) | start | fixed rho_H | fixed verified | "
             "free rho_H | free verified | ratio | ratio above the floor | wall s (fixed, "
             "free) |", "|---:|---:|---:|---|---:|---:|---:|---:|---:|---:|---|"]
    for h in sizes:
        sets = ["geometry.kind=cube", "geometry.side=4.0", "model.dim=3", f"mesh.size={h}",
                CUBE_MAP, "growth.eigenvalues.design=[1, 2, 3]",
                "objective.hausdorff.quadrature_degree=2"]
        uniform = ["growth.start=given",
                   f"growth.eigenvalues.initial=[{UNIFORM}, {UNIFORM}, 1.0]"]
        folder = out / f"cube-h{h:g}"
        fixed_target = run("square_circle_fixed.yaml", folder / "fixed-target", sets, ranks)
        free_target = run("square_circle_free.yaml", folder / "free-target", sets + [SIGNED],
                          ranks)
        fixed_uniform = run("square_circle_fixed.yaml", folder / "fixed-uniform",
                            sets + uniform, ranks)
        staged = {name: run("square_circle_free.yaml", folder / f"free-staged-{name}",
                            sets + [SIGNED, "growth.start=run",
                                    f"growth.from_run={folder / f'fixed-{name}'}",
                                    "growth.angles.initial=[0.0, 0.0, 0.0]"], ranks)
                  for name in ("target", "uniform")}
        rho_tt = floor("square_circle_fixed.yaml", sets)
        for start, f, g in (("target metric", fixed_target, free_target),
                            ("target metric, free staged", fixed_target, staged["target"]),
                            ("uniform, free staged", fixed_uniform, staged["uniform"])):
            a, b = _rho(f), _rho(g)
            ratio = "-" if not (a and b) else f"{a / b:.3g}"
            above = "-" if not (a and b) or b <= rho_tt else f"{(a - rho_tt) / (b - rho_tt):.3g}"
            dofs = "-" if f is None else str(f.dofs.state)
            wall = ", ".join("-" if s is None else f"{s.wall_time_s:.0f}" for s in (f, g))
            lines.append(f"| {h:g} | {dofs} | {rho_tt:.4g} | {start} | "
                         f"{'-' if a is None else f'{a:.4g}'} | {_verified(f)} | "
                         f"{'-' if b is None else f'{b:.4g}'} | {_verified(g)} | {ratio} | "
                         f"{above} | {wall} |")
    return lines


if __name__ == "__main__":
    sys.exit(main())
