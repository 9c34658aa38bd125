"""Every error the library raises to its caller, in one place.

Bad input (the caller can fix it): :class:`ConfigError` (a config, every problem at once),
:class:`InputError` (an option, a file, a probe; :class:`ResumeError` for ``--resume``),
:class:`ExpressionError` (an expression's text, reported as a ConfigError by the config).
A solve that fails: :class:`StateSolveError`, :class:`AdjointSolveError` (an optimisation
recovers from them or ends on them, reported in its summary's status).

The library raises these and returns typed results (``RunSummary``, ``RunResult``); the
command line alone turns them into exit statuses (``commands/cli.py``: 2 for bad input, 1 for
a run whose status is ``failed``).
"""

from __future__ import annotations

from typing import Any


class ConfigError(ValueError):
    """One or more problems in a config; ``problems`` holds one line each."""

    def __init__(self, problems: list[str]):
        self.problems = list(problems)
        super().__init__("\n".join(self.problems))


class InputError(ValueError):
    """Bad input outside the config (an option, a file, a probe): one line that names it."""


class ResumeError(InputError):
    """``--resume`` cannot continue from the checkpoint there."""


class ExpressionError(ValueError):
    """The text is not an allowed expression; the message says why."""


class StateSolveError(RuntimeError):
    """The state could not be brought into equilibrium for this design; ``report`` is the
    solve's report (physics.state.SolveReport)."""

    def __init__(self, report: Any):
        super().__init__(report.reason)
        self.report = report


class AdjointSolveError(RuntimeError):
    """The adjoint's linear solver did not converge (an optimisation ends on it, reported)."""
