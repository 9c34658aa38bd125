"""How a solve or a run ended: ``converged``, ``max_iterations`` or ``failed: <reason>``
(summary.json's ``status``), owned here and nowhere else."""

from __future__ import annotations

from dataclasses import dataclass
from enum import StrEnum


class Status(StrEnum):
    CONVERGED = "converged"
    MAX_ITERATIONS = "max_iterations"
    FAILED = "failed"


@dataclass(frozen=True)
class Outcome:
    """A :class:`Status` and, for a failure, its reason; ``str()`` is summary.json's text."""

    status: Status
    reason: str = ""

    @classmethod
    def converged(cls) -> Outcome:
        return cls(Status.CONVERGED)

    @classmethod
    def max_iterations(cls) -> Outcome:
        return cls(Status.MAX_ITERATIONS)

    @classmethod
    def failed(cls, reason: str) -> Outcome:
        return cls(Status.FAILED, reason)

    @classmethod
    def parse(cls, text: str) -> Outcome:
        """The inverse of ``str()``: ``"failed: no equilibrium"`` -> FAILED, that reason."""
        head, _, reason = text.partition(":")
        return cls(Status(head.strip()), reason.strip())

    @property
    def is_failure(self) -> bool:
        return self.status is Status.FAILED

    def __str__(self) -> str:
        if self.status is Status.FAILED:
            return f"failed: {self.reason}" if self.reason else "failed"
        return self.status.value
