"""PETSc options per solver instance.

Each solver (the state's SNES, the adjoint's and the filter's KSP) has a *role* - ``state_``,
``adjoint_`` or ``filter_``, the prefixes of ``solver.petsc_options``' keys - and an options
prefix of its own, ``<role><n>_``, n counting the solvers of that role in this process.  Its
options live in PETSc's global table only while PETSc reads them: ``setFromOptions`` at
construction, and every solve (MUMPS reads its ``mat_mumps_*`` options at the first
factorisation, a SNES its ``snes_view`` at the end of a solve); they are deleted afterwards.
So two models in one process (a study, a notebook) never share or inherit options, and the
table is as empty after a run as before it.
"""

from __future__ import annotations

import itertools
from collections.abc import Iterator, Mapping
from contextlib import contextmanager

from petsc4py import PETSc

from ..compat import set_option

_COUNT = {role: itertools.count() for role in ("state_", "adjoint_", "filter_", "stability_")}


class SolverOptions:
    """The defaults of one solver and the user's ``<role>...`` entries of
    ``solver.petsc_options`` (true is a bare flag, false removes the option)."""

    def __init__(self, role: str, defaults: Mapping[str, object],
                 user: Mapping[str, object] | None = None, prefix: str | None = None):
        self.role = role
        self.prefix = f"{role}{next(_COUNT[role])}_" if prefix is None else prefix
        self.defaults = dict(defaults)
        self.user = {key[len(role):]: value for key, value in (user or {}).items()
                     if key.startswith(role)}

    @property
    def user_keys(self) -> list[str]:
        """The user's keys as written in the config."""
        return sorted(self.role + key for key in self.user)

    @contextmanager
    def pushed(self) -> Iterator[None]:
        """The options in PETSc's table under this solver's prefix, for the block's time."""
        opts = PETSc.Options()
        for key, value in self.defaults.items():
            opts.setValue(self.prefix + key, value)
        for key, value in self.user.items():
            set_option(opts, self.prefix + key, value)
        try:
            yield
        finally:
            for key in {**self.defaults, **self.user}:
                opts.delValue(self.prefix + key)
