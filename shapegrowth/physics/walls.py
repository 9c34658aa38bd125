"""A design uniform across a thin wall (``growth.across_wall: uniform``).

A thin body's wall is meshed as columns of nodes across it (``mesh.layers`` elements, the
same in-plane points on every layer; a refined mesh keeps that).  The projection P sets each
column's nodal values to their mean: applied to a designed field after the filter, the
growth it makes is constant across the wall, so the design stretches the wall's mid-surface
and cannot bend it; only the fields it does not design (their start, such as the target's
metric with ``growth.start: target``) bend it.  P is a mean over disjoint sets of nodes:
symmetric and idempotent, so the derivative of J(P f) is P applied to J's (``apply`` is
both directions).

The columns: the box and the annulus are thin across X3 (a column: one (X1, X2)); the tube
across its radius about the X1 axis (one X1 and one direction (X2, X3) / r), the cylindrical
shell across its radius about the X3 axis (one X3 and one direction (X1, X2) / r).  Nodes
are matched to 1e-8 of the body's size; the columns may span ranks (collective).
"""

from __future__ import annotations

import numpy as np
from mpi4py import MPI

from .. import compat
from ..errors import InputError

# the layered bodies (config LAYERED) and their thin direction
ACROSS = {"box": "x3", "annulus": "x3", "tube": "radial_x1", "cylinder_shell": "radial_x3"}
MATCH = 1e-8  # of the body's size: two nodes of one column


class WallMeanError(InputError):
    """The mesh's nodes do not lie in columns across the wall (the command line reports it
    in one line, as other bad input)."""


def column_keys(kind: str, x: np.ndarray) -> np.ndarray:
    """The in-wall coordinates that name each point's column (one row per point)."""
    across = ACROSS[kind]
    if across == "x3":
        return x[:, :2]
    axis = 0 if across == "radial_x1" else 2
    plane = [i for i in range(3) if i != axis]
    r = np.hypot(x[:, plane[0]], x[:, plane[1]])
    r = np.where(r > 0.0, r, 1.0)
    return np.column_stack([x[:, axis], x[:, plane[0]] / r, x[:, plane[1]] / r])


class WallMean:
    """The projection P of the module doc on a growth space of a ``kind`` body."""

    def __init__(self, space, kind: str):
        self.comm: MPI.Comm = space.mesh.comm
        n = space.dofmap.index_map.size_local
        x = space.tabulate_dof_coordinates()[:n]
        keys = column_keys(kind, x)
        everywhere = np.vstack(self.comm.allgather(keys))
        size = max(float(np.abs(everywhere).max(initial=0.0)), 1.0)
        quantised = np.round(everywhere / (MATCH * size)).astype(np.int64)
        _, index, counts = np.unique(quantised, axis=0, return_inverse=True,
                                     return_counts=True)
        start = self.comm.scan(n) - n
        self.index = index.reshape(-1)[start:start + n]
        self.counts = counts.astype(float)
        self.columns = len(counts)
        self.n_owned = n
        lonely = int(np.count_nonzero(counts < 2))
        if compat.global_size(space) > 0 and lonely:
            raise WallMeanError(
                f"{lonely} of {len(counts)} columns across the wall hold one node: the "
                "mesh is not layered across its thin direction; growth.across_wall: uniform "
                "needs mesh.layers, or use 'free'")

    def apply(self, values: np.ndarray) -> np.ndarray:
        """Each owned value replaced by its column's mean (collective)."""
        sums = np.bincount(self.index, weights=values[:self.n_owned], minlength=self.columns)
        self.comm.Allreduce(MPI.IN_PLACE, sums, op=MPI.SUM)
        return sums[self.index] / self.counts[self.index]
