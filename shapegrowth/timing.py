"""Wall-clock time per part of a run, for summary.json's ``time_split``."""

from __future__ import annotations

import resource
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path

from mpi4py import MPI

CATEGORIES = ("forward", "adjoint", "hausdorff", "filter", "optimizer", "io")


@dataclass
class Timer:
    """Totals per category of ``time_split``; a ``detail`` name also collects its own
    total (e.g. the filter's backward pass within "filter", for the benchmark)."""

    totals: dict[str, float] = field(default_factory=lambda: dict.fromkeys(CATEGORIES, 0.0))
    details: dict[str, float] = field(default_factory=dict)
    start: float = field(default_factory=time.perf_counter)

    @contextmanager
    def __call__(self, category: str, detail: str | None = None) -> Iterator[None]:
        tic = time.perf_counter()
        try:
            yield
        finally:
            elapsed = time.perf_counter() - tic
            self.totals[category] += elapsed
            if detail is not None:
                self.details[detail] = self.details.get(detail, 0.0) + elapsed

    @property
    def wall(self) -> float:
        return time.perf_counter() - self.start

    def split(self) -> dict[str, float]:
        return {k: round(v, 4) for k, v in self.totals.items()}


def reset_peak_memory() -> None:
    """Restart this process's resident-memory high-water mark where Linux allows it (else
    the peak is that of the process so far)."""
    try:
        Path("/proc/self/clear_refs").write_text("5")
    except OSError:
        pass


def peak_memory_mb(comm: MPI.Comm) -> float:
    """Peak resident memory since the last reset (or process start), summed over ranks."""
    kb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    try:
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith("VmHWM:"):
                kb = int(line.split()[1])
    except OSError:
        pass
    return comm.allreduce(kb, MPI.SUM) / 1024.0
