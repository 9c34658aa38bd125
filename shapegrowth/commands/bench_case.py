"""One case of ``shapegrowth bench`` in a process of its own: the worker the benchmark's
harness launches (serially, or under ``mpirun``) for each mesh size, not a command of the
command line.

    python -m shapegrowth.commands.bench_case CONFIG --out DIR [--steps N] [--set KEY=VALUE]

It writes DIR/case.json (:func:`bench.measure_case`); a bad config is one ``error:`` line
per problem and exit status 2, as the command line's.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from .. import blas


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m shapegrowth.commands.bench_case",
                                     description=__doc__.splitlines()[0] if __doc__ else None)
    parser.add_argument("config")
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument("--steps", type=int, default=3)
    parser.add_argument("--set", dest="overrides", action="append", default=[])
    args = parser.parse_args(argv)
    import logging

    from .. import logs
    from ..config import load
    from ..errors import ConfigError, InputError
    from ..io import files
    from .bench import measure_case
    from .cli import EXIT_OK, bad_input

    logs.configure(logging.WARNING)
    try:
        cfg = load(args.config, args.overrides)
        files.write_json(args.out / "case.json", measure_case(cfg, args.steps))
    except (ConfigError, InputError) as err:
        return bad_input(err)
    return EXIT_OK


if __name__ == "__main__":
    blas.prepare_environment()  # before numpy and PETSc load the BLAS
    sys.exit(main())
