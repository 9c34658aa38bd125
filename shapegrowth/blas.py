"""The BLAS a run's factorisations spend their time in: one thread per MPI rank, and
OpenBLAS's kernels for this CPU's vector units.

OpenBLAS picks its kernels by the CPU's model number, and a release older than the CPU does
not know it: Debian 12's OpenBLAS 0.3.21 on a Xeon of family 6, model 207 (AVX-512) falls
back to its Prescott kernels (SSE3).  Measured there, one thread: dgemm of 2000 x 2000 at
11.2 GFLOP/s with Prescott's kernels, 50.4 with SkylakeX's (31.4 with Haswell's); a whole run
(configs/beam_ring_2d.yaml, 2 ranks, its lift at 149k DOFs included) 1 342 s against 652 s
(docs/PERFORMANCE.md, 'The BLAS kernels').  ``OPENBLAS_CORETYPE`` names the kernels to use
instead; it is read once, when the library loads, so :func:`prepare_environment` must run
before numpy or PETSc load (the console entry point calls it first; ``import shapegrowth``
loads neither).  A value the user set is kept.

Nothing here runs at import.
"""

from __future__ import annotations

import ctypes
import os
import platform
from collections.abc import MutableMapping
from pathlib import Path

# The kernel sets named by the vector units they need (OpenBLAS's names for
# OPENBLAS_CORETYPE); a CPU with neither keeps OpenBLAS's own choice.
_AVX512 = frozenset({"avx512f", "avx512cd", "avx512bw", "avx512dq", "avx512vl"})
_AVX2 = frozenset({"avx2", "fma"})
# OpenBLAS's fallbacks for a model it does not know, and its kernels without AVX
_FALLBACKS = frozenset({"prescott", "core2", "penryn", "dunnington", "nehalem", "katmai",
                        "coppermine", "northwood", "banias", "atom", "unknown"})


def cpu_flags(cpuinfo: str | None = None) -> frozenset[str]:
    """The flags of the first processor in ``cpuinfo`` (/proc/cpuinfo's text; read where
    None, empty where there is none)."""
    if cpuinfo is None:
        try:
            cpuinfo = Path("/proc/cpuinfo").read_text()
        except OSError:
            return frozenset()
    for line in cpuinfo.splitlines():
        key, _, value = line.partition(":")
        if key.strip() == "flags":
            return frozenset(value.split())
    return frozenset()


def openblas_coretype(flags: frozenset[str] | None = None,
                      machine: str | None = None) -> str | None:
    """OpenBLAS's kernel set for an x86-64 CPU with these ``flags``: SkylakeX for AVX-512,
    Haswell for AVX2 with FMA, None for anything else (OpenBLAS's own choice stands)."""
    machine = platform.machine() if machine is None else machine
    if machine.lower() not in ("x86_64", "amd64"):
        return None
    flags = cpu_flags() if flags is None else flags
    if _AVX512 <= flags:
        return "SkylakeX"
    if _AVX2 <= flags:
        return "Haswell"
    return None


def prepare_environment(environ: MutableMapping[str, str] | None = None,
                        coretype: str | None = None) -> dict[str, str]:
    """Set, where unset, one BLAS (and OpenMP) thread per rank under mpirun (the ranks use
    the cores already: on the 27.9k-DOF P2 bend 1 rank x 2 threads took 27 s, 2 ranks x 1
    thread 21 s) and ``OPENBLAS_CORETYPE`` for this CPU (``coretype``, or
    :func:`openblas_coretype`'s); returns what it set.  ``environ``: os.environ where None."""
    env = os.environ if environ is None else environ
    wanted: dict[str, str] = {}
    ranks = env.get("OMPI_COMM_WORLD_SIZE") or env.get("PMI_SIZE") or "1"
    if int(ranks) > 1:
        wanted.update(OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1")  # the wheel's MUMPS: OpenMP
    kernels = coretype or openblas_coretype()
    if kernels is not None:
        wanted["OPENBLAS_CORETYPE"] = kernels
    added = {key: value for key, value in wanted.items() if key not in env}
    env.update(added)
    return added


def loaded_openblas_kernels() -> str | None:
    """The kernel set of the OpenBLAS this process has loaded (openblas_get_corename), or
    None where it has loaded none (or another BLAS)."""
    try:
        maps = Path("/proc/self/maps").read_text()
    except OSError:
        return None
    mapped = {line.split()[-1] for line in maps.splitlines() if line.strip()}
    for path in sorted(p for p in mapped if p.startswith("/") and "openblas" in Path(p).name):
        try:
            lib = ctypes.CDLL(path)
            corename = lib.openblas_get_corename
        except (OSError, AttributeError):
            continue
        corename.restype = ctypes.c_char_p
        name = corename()
        return name.decode() if name else None
    return None


def kernel_warning() -> str | None:
    """A one-line warning where the loaded OpenBLAS runs a fallback kernel set on a CPU
    with better vector units (the environment came too late: a notebook, a script that
    loaded numpy first), naming the fix; None otherwise."""
    kernels = loaded_openblas_kernels()
    better = openblas_coretype()
    if kernels is None or better is None or kernels.lower() not in _FALLBACKS:
        return None
    return (f"OpenBLAS runs its {kernels} kernels on a CPU with the vector units of "
            f"{better}'s (several times slower factorisations): set "
            f"OPENBLAS_CORETYPE={better} before Python starts")
