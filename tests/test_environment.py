"""The environment of a process and of the processes it starts: the BLAS settings the
command line makes before numpy and PETSc load (one thread per rank under mpirun, OpenBLAS's
kernels named for the CPU's vector units where it would fall back to its SSE3 ones:
shapegrowth/blas.py; a value the user set is kept), and the launcher's child, a job of its
own whatever MPI job its parent belongs to."""

from __future__ import annotations

import subprocess
import sys

import pytest

from shapegrowth import blas

# /proc/cpuinfo's lines of the machine that measured the fallback (family 6, model 207),
# flags cut to those that decide, and of an AVX2 machine
AVX512 = ("processor\t: 0\ncpu family\t: 6\nmodel\t\t: 207\n"
          "flags\t\t: fpu sse3 avx avx2 fma avx512f avx512dq avx512cd avx512bw avx512vl\n"
          "processor\t: 1\nflags\t\t: fpu\n")
AVX2 = "processor\t: 0\nflags\t\t: fpu sse3 avx avx2 fma\n"


@pytest.mark.parametrize("cpuinfo, machine, kernels", [
    (AVX512, "x86_64", "SkylakeX"), (AVX2, "x86_64", "Haswell"),
    ("flags\t\t: fpu sse3 avx\n", "x86_64", None),  # no FMA: OpenBLAS's own choice
    ("flags\t\t: fpu avx2 fma\n", "aarch64", None), ("", "x86_64", None)])
def test_the_kernels_follow_the_first_processors_flags(cpuinfo, machine, kernels):
    assert blas.openblas_coretype(blas.cpu_flags(cpuinfo), machine) == kernels


def test_the_environment_is_set_where_unset_and_kept_where_set():
    env = {"OMPI_COMM_WORLD_SIZE": "2"}
    added = blas.prepare_environment(env, coretype="SkylakeX")
    assert added == {"OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1",
                     "OPENBLAS_CORETYPE": "SkylakeX"}
    assert env == {"OMPI_COMM_WORLD_SIZE": "2", **added}
    mine = {"OPENBLAS_NUM_THREADS": "4", "OPENBLAS_CORETYPE": "Haswell"}
    assert blas.prepare_environment(mine, coretype="SkylakeX") == {}  # one rank: no threads
    assert mine == {"OPENBLAS_NUM_THREADS": "4", "OPENBLAS_CORETYPE": "Haswell"}


def _kernels_in_a_fresh_process(env_kernels: str | None) -> tuple[str, str]:
    """(the loaded OpenBLAS's kernels, the warning) in a process that loads numpy with
    OPENBLAS_CORETYPE as given (unset where None)."""
    import os

    env = {k: v for k, v in os.environ.items() if k != "OPENBLAS_CORETYPE"}
    if env_kernels is not None:
        env["OPENBLAS_CORETYPE"] = env_kernels
    code = ("import numpy; from shapegrowth import blas; "
            "print(blas.loaded_openblas_kernels()); print(blas.kernel_warning())")
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True,
                         text=True, check=True).stdout.splitlines()
    return out[0], out[1]


def test_the_loaded_kernels_are_the_ones_asked_for_and_a_fallback_is_named():
    """Where numpy links OpenBLAS: the kernel set asked for is the one loaded (the variable
    is read at load), and the SSE3 fallback on this CPU is warned of, with the fix."""
    kernels, warning = _kernels_in_a_fresh_process("Prescott")
    if kernels == "None":
        pytest.skip("numpy does not link OpenBLAS here")
    assert kernels == "Prescott"
    better = blas.openblas_coretype()
    if better is None:
        assert warning == "None"
    else:
        assert f"set OPENBLAS_CORETYPE={better} before Python starts" in warning
        assert _kernels_in_a_fresh_process(better) == (better, "None")


def test_the_launchers_child_is_not_part_of_its_parents_mpi_job(monkeypatch):
    """An MPI singleton's (or rank's) variables are left out, the user's OpenMPI settings
    kept, OpenMPI's root and oversubscription settings added."""
    from shapegrowth.commands import launch

    for key, value in {"OMPI_MCA_ess": "singleton", "PMIX_RANK": "0", "PMI_SIZE": "2",
                       "OMPI_COMM_WORLD_SIZE": "2", "OMPI_MCA_orte_launch": "1",
                       "OMPI_APP_CTX_NUM_PROCS": "1", "OMPI_MCA_btl": "self,vader"}.items():
        monkeypatch.setenv(key, value)
    env = launch.environment()
    assert not [key for key in env if key.startswith(("PMIX_", "PMI_", "OMPI_MCA_ess",
                                                       "OMPI_COMM_WORLD", "OMPI_MCA_orte",
                                                       "OMPI_APP_CTX"))]
    assert env["OMPI_MCA_btl"] == "self,vader"
    assert launch.MPI_ENVIRONMENT.items() <= env.items()


def test_a_process_started_by_an_mpi_singleton_launches_mpirun(tmp_path):
    """A process that imported mpi4py starts one that runs mpirun: the grandchild inherits
    the singleton's variables (as a pytest-xdist worker does its controller's), and mpirun
    there exited 1 without a word until the launcher left them out.  Each rank prints 7;
    mpirun forwards the ranks' output in chunks that may interleave ('77' then the two
    newlines, seen once), so the output is read with its whitespace taken out: two sevens
    and nothing else."""
    import shutil

    if shutil.which("mpirun") is None:
        pytest.skip("no mpirun")
    grandchild = tmp_path / "grandchild.py"
    grandchild.write_text(
        "import sys\n"
        "from shapegrowth.commands.launch import launch\n"
        "done = launch([], 2, program=[sys.executable, '-c', 'print(7)'],\n"
        "              capture_output=True, text=True)\n"
        "print(done.returncode, ''.join(done.stdout.split()))\n")
    child = tmp_path / "child.py"
    child.write_text(
        "import subprocess, sys\n"
        "from mpi4py import MPI  # this process is now an MPI singleton\n"
        f"sys.exit(subprocess.run([sys.executable, {str(grandchild)!r}]).returncode)\n")
    done = subprocess.run([sys.executable, str(child)], capture_output=True, text=True,
                          timeout=120)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "0 77"
