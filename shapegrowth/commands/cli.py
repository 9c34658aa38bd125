"""Command line: ``shapegrowth COMMAND CONFIG [options]`` (also ``python -m shapegrowth``).

Exit status: 0 success, 2 bad input (config, file, option), 1 a run that failed.
Bad input prints one ``error:`` line per problem and no traceback; under
``mpirun`` only rank 0 prints.
"""

from __future__ import annotations

import argparse
import logging
import re
import sys
from pathlib import Path

from mpi4py import MPI

from .. import blas
from ..version import __version__

EXIT_OK, EXIT_FAILED, EXIT_BAD_INPUT = 0, 1, 2
log = logging.getLogger("shapegrowth")


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="shapegrowth",
        description="Shape programming by differential growth (growth-modulated Mooney-Rivlin).")
    parser.add_argument("--version", action="version", version=f"shapegrowth {__version__}")
    options = argparse.ArgumentParser(add_help=False)
    options.add_argument("--set", dest="overrides", action="append", default=[],
                        metavar="KEY=VALUE",
                        help="override a config entry (dotted key, YAML value); repeatable")
    options.add_argument("--out", type=Path, default=None,
                        help="output folder (default: the config's output.dir)")
    noise = options.add_mutually_exclusive_group()
    noise.add_argument("--quiet", "-q", action="store_true", help="only warnings and errors")
    noise.add_argument("--verbose", "-v", action="store_true", help="debug output")
    common = argparse.ArgumentParser(add_help=False, parents=[options])
    common.add_argument("config", help="YAML config file")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    sub.add_parser("validate", parents=[common], help="check a config, print every problem")
    sub.add_parser("mesh", parents=[common], help="build (or reuse) the gmsh mesh")
    solve = sub.add_parser("solve", parents=[common],
                           help="forward solve with the config's initial growth")
    solve.add_argument("--probe", action="append", default=[], metavar="X1,X2,X3",
                       help="report the deformed position of this reference point; repeatable")
    run = sub.add_parser("run", parents=[common], help="the optimisation, end to end")
    run.add_argument("--resume", action="store_true",
                     help="continue an interrupted run from its checkpoint.h5 (same ranks)")
    check = sub.add_parser("gradcheck", parents=[common],
                           help="Taylor test of the reduced gradient in a random direction")
    check.add_argument("--seed", type=int, default=0, help="seed of the direction (default 0)")
    check.add_argument("--eps", type=float, default=1e-2, help="first step (default 1e-2)")
    check.add_argument("--steps", type=int, default=4, help="halvings of the step (default 4)")
    lift = sub.add_parser("lift", parents=[options],
                          help="a 2D section run's best growth on its 3D body, grown from rest")
    lift.add_argument("run_dir", type=Path, help="folder of a finished run of a 2D model")
    lift.add_argument("--config", required=True,
                      help="YAML config of the 3D body (--set applies to it)")
    check = sub.add_parser("verify", parents=[options],
                           help="a finished run's best growth verified on a finer mesh, "
                                "against the run's own verified number (verify.json)")
    check.add_argument("run_dir", type=Path, help="folder of a finished run")
    check.add_argument("--refine", type=_refinements, default=None, metavar="N",
                       help="refinements of the run's last mesh (default: one more than the "
                            "run's verify.refine)")
    check.add_argument("--lift", default=None, metavar="CONFIG_3D",
                       help="a section run: the 3D config to lift onto (default: the run's "
                            "verify.lift; none: the section alone)")
    check.add_argument("--continued", action="store_true",
                       help="grow from rest on the mesh refined N - 1 times (a section's 3D "
                            "body), and solve the finer mesh from that equilibrium: a check "
                            "at a few Newton iterations where one from rest takes hours")
    fig = sub.add_parser("figure", parents=[options],
                         help="a finished run's deformed body over its target, in 3D "
                              "(shape3d.png)")
    fig.add_argument("run_dir", type=Path, help="folder of a finished run")
    fig.add_argument("--view", type=_view, default=[24.0, -62.0], metavar="ELEV,AZIM",
                     help="camera elevation and azimuth in degrees (default 24,-62)")
    study = sub.add_parser("study", parents=[common],
                           help="a grid of settings: accuracy against cost (study.csv, study.png)")
    study.add_argument("--sweep", action="append", default=[], metavar="KEY=V1,V2,...",
                       help="a config key and its values; repeatable (the grid is the product)")
    study.add_argument("--reference", action="append", default=[], metavar="KEY=VALUE",
                       help="override of the reference discretisation the optima are judged "
                            "on (default: the finest swept resolution); repeatable")
    bench = sub.add_parser("bench", parents=[options],
                           help="the performance benchmark (bench.json)")
    bench.add_argument("config", nargs="?", default=None,
                       help="YAML config (default: configs/beam_wave.yaml with a growth near "
                            "the optimum)")
    bench.add_argument("--sizes", type=_sizes, default=None, metavar="H1,H2,...",
                       help="mesh sizes, one case each (default 0.05,0.025,0.0125)")
    bench.add_argument("--ranks", type=int, default=2,
                       help="ranks of the MPI run of the largest case (1: none; default 2)")
    bench.add_argument("--steps", type=int, default=3,
                       help="optimisation-like iterations measured per case (default 3)")
    bench.add_argument("--runs", nargs="?", const="all", default=None, metavar="NAME,...",
                       help="time to a verified shape error on whole runs (bench.json "
                            "`runs`; all of them, or those named); --set applies to each run")
    bench.add_argument("--scaling", type=_ranks, default=None, metavar="P1,P2,...",
                       help="strong scaling of the largest case over these rank counts, "
                            "one thread per rank, with Amdahl's law fitted (bench.json "
                            "`scaling`), e.g. 1,2,4")
    return parser


def _numbers(kind: type, what: str, valid):
    """An argparse type: a comma-separated list of ``kind`` values, each ``valid``."""

    def parse(text: str) -> list:
        try:
            values = [kind(v) for v in text.split(",") if v.strip()]
        except ValueError:
            raise argparse.ArgumentTypeError(
                f"{what} separated by commas, got {text!r}") from None
        if not values or not all(valid(v) for v in values):
            raise argparse.ArgumentTypeError(f"{what}, got {text!r}")
        return values

    return parse


_sizes = _numbers(float, "positive mesh sizes", lambda v: v > 0)
_ranks = _numbers(int, "rank counts >= 1", lambda v: v >= 1)


def _refinements(text: str) -> int:
    """--refine N: 1 to 4 uniform refinements."""
    if not text.isdigit() or not 1 <= int(text) <= 4:
        raise argparse.ArgumentTypeError(f"a number of refinements from 1 to 4, got {text!r}")
    return int(text)


def _view(text: str) -> list[float]:
    """--view ELEV,AZIM: two angles in degrees."""
    values = _numbers(float, "two angles in degrees (elevation, azimuth)",
                      lambda v: abs(v) <= 360)(text)
    if len(values) != 2:
        raise argparse.ArgumentTypeError(
            f"two angles in degrees (elevation, azimuth), got {text!r}")
    return values


def _validate(cfg, args) -> int:
    log.info("%s: valid", args.config)
    return EXIT_OK


def _mesh(cfg, args) -> int:
    from ..physics.geometry import load_domain, mesh_quality, patches

    domain = load_domain(cfg)
    log.info("mesh: %s", domain.path)
    log.info("mesh: %s", mesh_quality(domain, cfg).describe())
    for patch in patches(domain):  # what a boundary name or a selector can name
        log.info("  %s", patch.describe())
    return EXIT_OK


def _exit_status(summary) -> int:
    """A summary's exit status: 1 for a failed solve or run, else 0 (the CLI's exit codes)."""
    return EXIT_FAILED if summary.status.is_failure else EXIT_OK


def _solve(cfg, args) -> int:
    from .solve import solve_forward

    return _exit_status(solve_forward(cfg, args.out or cfg.output_dir, args.probe))


def _gradcheck(cfg, args) -> int:
    from .gradcheck import gradcheck

    out = args.out or cfg.output_dir
    report = gradcheck(cfg, out, args.seed, args.eps, args.steps)
    rates = ", ".join(f"{r:.3f}" for r in report["rates"])
    log.info("Taylor remainders fall at rates %s (2 for an exact gradient)", rates)
    log.info("wrote %s", out / "gradcheck.json")
    return EXIT_OK if report["min_rate"] > 1.9 else EXIT_FAILED


def _run(cfg, args) -> int:
    from .run import lift_config, run_optimization

    if cfg.shell:  # the thin body's mid-surface shell, verified on the 3D body
        from ..errors import InputError
        from .shell_run import run_shell

        if args.resume:
            raise InputError("run --resume: a shell run keeps no checkpoint and starts anew; "
                             "run it without --resume")

        return _exit_status(run_shell(cfg, args.out or cfg.output_dir).summary)

    onto = lift_config(cfg, args.overrides)  # its problems before the run starts
    return _exit_status(run_optimization(cfg, args.out or cfg.output_dir, args.resume,
                                         onto).summary)


def _lift(cfg, args) -> int:
    from .lift import lift_run

    lifted = lift_run(args.run_dir, cfg, args.out or args.run_dir / "lift")
    return EXIT_OK if lifted.relative is not None else EXIT_FAILED


def _verify(args) -> int:
    from .verify import reverify

    check = reverify(args.run_dir, args.refine, args.out, args.overrides, args.lift,
                     args.continued)
    return EXIT_OK if check.second_headline is not None else EXIT_FAILED


def _figure(args) -> int:
    from ..io.figures3d import View
    from .figure import figure

    elevation, azimuth = args.view
    figure(args.run_dir, args.out or args.run_dir, View(elevation, azimuth))
    return EXIT_OK


def _study(cfg, args) -> int:
    from ..config import ConfigError, load
    from ..status import Outcome
    from .study import Sweep, run_study

    if not args.sweep:
        raise ConfigError(["study: give at least one --sweep KEY=V1,V2,..."])
    sweeps = [Sweep.parse(text) for text in args.sweep]
    errors = []  # every value must make a valid config: all problems at once
    for sweep in sweeps:
        for value in sweep.values:
            try:
                load(args.config, args.overrides + [f"{sweep.key}={value}"])
            except ConfigError as err:
                errors += [f"--sweep {sweep.key}={value}: {e}" for e in err.problems]
    if errors:
        raise ConfigError(errors)
    out = args.out or cfg.output_dir
    rows = run_study(Path(args.config), args.overrides, sweeps, out, args.reference)
    failed = [r for r in rows if Outcome.parse(str(r["status"])).is_failure]
    log.info("wrote %s and %s (%d points, %d failed)", out / "study.csv", out / "study.png",
             len(rows), len(failed))
    return EXIT_FAILED if failed else EXIT_OK


def _bench(args) -> int:
    """``bench``: the per-iteration benchmark of a config (default: the shipped scene 1 at
    the benchmark's growth), its strong scaling, or whole runs of the shipped configs."""
    from ..config import load
    from . import bench

    out = args.out or Path("results/bench")
    if args.runs is not None:  # whole runs of shipped configs: no config of its own
        return _bench_runs(args.runs, args.ranks, args.overrides, out)
    config, overrides = args.config, list(args.overrides)
    if config is None:
        from .launch import shipped_configs

        config = str(shipped_configs() / bench.DEFAULT_CONFIG)
        overrides = bench.DEFAULT_OVERRIDES + overrides
    load(config, overrides)  # every problem of the config before any case starts
    if args.scaling is not None:
        return _bench_scaling(config, overrides, args.sizes, args.scaling, out)
    result = bench.run_bench(Path(config), overrides, out,
                             args.sizes or list(bench.DEFAULT_SIZES), args.ranks)
    r = result["ratios"]
    log.info("gradient/forward %.3f, rho_H/iteration %.3f, Newton/reference %.2f, "
             "%.1f Newton iterations per step, scaling exponent %.2f",
             r["gradient_over_forward"], r["hausdorff_over_iteration"],
             r["newton_over_reference"], result["newton_iterations_per_step"],
             result["scaling_exponent"])
    if "speedup" in result["mpi"]:
        mpi = result["mpi"]
        log.info("mpirun -n %d speedup %.2f at %d DOFs (%.2f over one thread on one rank)",
                 mpi["ranks"], mpi["speedup"], mpi["dofs"], mpi["speedup_over_one_thread"])
    log.info("wrote %s", out / "bench.json")
    return EXIT_OK


def _bench_scaling(config: str, overrides: list[str], sizes: list[float] | None,
                   ranks: list[int], out: Path) -> int:
    from . import bench, bench_scaling

    size = min(sizes or bench.DEFAULT_SIZES)
    table = bench_scaling.run_scaling(bench.run_case_process, Path(config), overrides, out,
                                      size, ranks)
    log.info("wrote %s", bench.update_bench_json(out, {"scaling": table}))
    return EXIT_OK


def _bench_runs(runs: str, ranks: int, overrides: list[str], out: Path) -> int:
    from . import bench, bench_runs

    only = [] if runs == "all" else [n for n in runs.split(",") if n]
    timings = bench_runs.run_runs(out, ranks, only, overrides)
    log.info("wrote %s", bench.update_bench_json(out, {"runs": bench_runs.as_json(timings)}))
    return EXIT_OK


COMMANDS = {"validate": _validate, "mesh": _mesh, "solve": _solve, "gradcheck": _gradcheck,
            "run": _run, "lift": _lift, "study": _study}


def _join_negative_values(argv: list[str]) -> list[str]:
    """``--probe -0.5,0,0`` -> ``--probe=-0.5,0,0`` (argparse takes -0.5,... for an option)."""
    out: list[str] = []
    i = 0
    while i < len(argv):
        if argv[i] == "--probe" and i + 1 < len(argv) and re.match(r"-[\d.]", argv[i + 1]):
            out.append(f"--probe={argv[i + 1]}")
            i += 2
            continue
        out.append(argv[i])
        i += 1
    return out


# the commands a shell model (model.reduction: shell) runs under
SHELL_COMMANDS = ("validate", "run")


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    args = build_parser().parse_args(_join_negative_values(argv))
    from .. import logs
    from ..config import load
    from ..errors import ConfigError, InputError

    level = logging.WARNING if args.quiet else logging.DEBUG if args.verbose else logging.INFO
    logs.configure(level)
    try:
        if args.command == "bench":  # its config is optional: the shipped scene's default
            return _bench(args)
        if args.command == "figure":  # the run's own config
            return _figure(args)
        if args.command == "verify":
            return _verify(args)
        cfg = load(args.config, args.overrides)
        if cfg.shell and args.command not in SHELL_COMMANDS:
            raise ConfigError([f"model.reduction: a shell model runs under "
                               f"{' and '.join(SHELL_COMMANDS)}, not {args.command}; use "
                               "model.dim: 3 for the 3D body"])
        return COMMANDS[args.command](cfg, args)
    except (ConfigError, InputError) as err:
        return bad_input(err)


def bad_input(err: Exception) -> int:
    """One ``error:`` line per problem of ``err``, on rank 0; the bad-input exit status."""
    if MPI.COMM_WORLD.rank == 0:
        for line in str(err).splitlines():
            print(f"error: {line}", file=sys.stderr)
    return EXIT_BAD_INPUT


def entry() -> None:
    blas.prepare_environment()  # before numpy and PETSc load the BLAS
    sys.exit(main())


if __name__ == "__main__":
    entry()
