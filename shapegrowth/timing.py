"""Wall-clock time per part of a run, for summary.json's ``time_split``."""

from __future__ import annotations

import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field

CATEGORIES = ("forward", "adjoint", "hausdorff", "filter", "optimizer", "io")


@dataclass
class Timer:
    totals: dict[str, float] = field(default_factory=lambda: dict.fromkeys(CATEGORIES, 0.0))
    start: float = field(default_factory=time.perf_counter)

    @contextmanager
    def __call__(self, category: str) -> Iterator[None]:
        tic = time.perf_counter()
        try:
            yield
        finally:
            self.totals[category] += time.perf_counter() - tic

    @property
    def wall(self) -> float:
        return time.perf_counter() - self.start

    def split(self) -> dict[str, float]:
        return {k: round(v, 4) for k, v in self.totals.items()}
