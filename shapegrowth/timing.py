"""Wall-clock time per part of a run, for summary.json's ``time_split``."""

from __future__ import annotations

import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field

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
