"""The one launcher: a shapegrowth command (or any program) in a process of its own, on N MPI
ranks, and its run folder's summary read back as a :class:`RunSummary`.

Used by ``bench`` (its cases and whole runs), the scripts (reproduce, reachable, square_ratio)
and the tests.  OpenMPI refuses root without its two variables and more ranks than cores
without oversubscription: both are set here, in the environment, and nowhere else (not as
``--oversubscribe``, a flag MPICH's mpiexec, the dolfinx wheel's, refuses).
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from ..errors import InputError
from ..io import files as io
from ..io.summary import RunSummary

MPI_ENVIRONMENT = {"OMPI_ALLOW_RUN_AS_ROOT": "1", "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM": "1",
                   "OMPI_MCA_rmaps_base_oversubscribe": "1"}


def mpirun(ranks: int) -> list[str]:
    """``mpirun -n ranks`` (or mpiexec), or an InputError naming the fix; the environment of
    :func:`environment` lets OpenMPI oversubscribe (MPICH always may)."""
    launcher = shutil.which("mpirun") or shutil.which("mpiexec")
    if launcher is None:
        raise InputError(f"no mpirun or mpiexec on PATH for {ranks} ranks (use one rank)")
    return [launcher, "-n", str(ranks)]


# What an MPI job leaves in its processes' environment (a rank's, or a singleton's: a
# process that imported mpi4py, and the processes it starts): a child that inherits it takes
# itself for a part of that job, and OpenMPI's mpirun exits 1 without a word (measured from a
# pytest-xdist worker, whose controller had imported mpi4py).  The user's own OMPI_MCA_
# settings stay.
_JOB_VARIABLES = ("PMIX_", "PMI_", "OMPI_COMM_WORLD_", "OMPI_APP_CTX", "OMPI_NUM_APP_CTX",
                  "OMPI_FIRST_RANKS", "OMPI_UNIVERSE_SIZE", "OMPI_FILE_LOCATION",
                  "OMPI_MCA_ess", "OMPI_MCA_orte_", "OMPI_MCA_pmix", "OMPI_MCA_initial_wdir")


def environment(one_thread: bool = False, extra: dict[str, str] | None = None) -> dict[str, str]:
    """This process's environment with OpenMPI's settings, less an MPI job's own variables
    (the child is a job of its own); ``one_thread``: one BLAS and one numba thread (what each
    rank of a run on several gets)."""
    env = {key: value for key, value in os.environ.items()
           if not key.startswith(_JOB_VARIABLES)}
    env.update(MPI_ENVIRONMENT)
    if one_thread:
        env.update(OPENBLAS_NUM_THREADS="1", NUMBA_NUM_THREADS="1", OMP_NUM_THREADS="1")
    env.update(extra or {})
    return env


def command(args: Sequence[Any], ranks: int = 1,
            program: Sequence[Any] | None = None) -> list[str]:
    """``python -m shapegrowth ARGS`` (or ``program ARGS``), under mpirun beyond one rank."""
    head = [sys.executable, "-m", "shapegrowth"] if program is None else list(program)
    cmd = [str(a) for a in (*head, *args)]
    return mpirun(ranks) + cmd if ranks > 1 else cmd


def launch(args: Sequence[Any], ranks: int = 1, *, program: Sequence[Any] | None = None,
           one_thread: bool | None = None, env: dict[str, str] | None = None,
           **run: Any) -> subprocess.CompletedProcess:
    """Run :func:`command` and wait for it (``run``: subprocess.run's keywords: cwd,
    capture_output, text, stdout, timeout, ...).  ``one_thread`` defaults to ranks > 1.
    Its standard input is empty unless ``run`` gives one: mpirun forwards its input to rank
    0, and a caller whose input is a channel of its own (a pytest-xdist worker's) lost it to
    mpirun, which then exited 1 without a word."""
    single = ranks > 1 if one_thread is None else one_thread
    run.setdefault("stdin", subprocess.DEVNULL)
    return subprocess.run(command(args, ranks, program), env=environment(single, env), **run)


def read_summary(folder: Path) -> RunSummary | None:
    """The run's (or the solve's) summary.json as a RunSummary, or None before it ends."""
    path = Path(folder) / "summary.json"
    return RunSummary.from_json(io.read_json(path)) if path.is_file() else None


def shipped_configs() -> Path:
    """The folder of the shipped configs that ``bench`` runs: ``SHAPEGROWTH_CONFIGS`` where set,
    else the checkout's ``configs/`` beside the package (an editable install, as the README's
    set-up makes); an InputError naming the variable where neither is there."""
    given = os.environ.get("SHAPEGROWTH_CONFIGS")
    folder = Path(given) if given else Path(__file__).resolve().parents[2] / "configs"
    if not (folder / "beam_wave.yaml").is_file():
        where = f"SHAPEGROWTH_CONFIGS={given}" if given else f"{folder} (beside the package)"
        raise InputError(f"bench: no shipped configs in {where}; give a CONFIG, or set "
                         "SHAPEGROWTH_CONFIGS to a checkout's configs/ folder")
    return folder


def with_sets(args: Sequence[Any], sets: Sequence[str]) -> list[str]:
    """``args`` followed by ``--set ITEM`` for each item."""
    return [str(a) for a in args] + [x for item in sets for x in ("--set", item)]
