"""Fields moved between two discretisations of the same body (for ``study``'s reference).

A scalar field on one mesh is interpolated at the DOF coordinates of a space on
another mesh of the same body.  Points that fall outside the source mesh (the
fine mesh of a curved boundary sticks out of the coarse polygon by O(h^2)) take
the value of the nearest point that fell inside.
"""

from __future__ import annotations

import dolfinx.fem
import numpy as np
from mpi4py import MPI
from scipy.spatial import cKDTree

from .. import compat


def interpolate_between_meshes(source: dolfinx.fem.Function,
                               target: dolfinx.fem.Function) -> None:
    """target := source at target's DOF coordinates (collective on the mesh's comm)."""
    comm: MPI.Comm = target.function_space.mesh.comm
    coords = target.function_space.tabulate_dof_coordinates()
    everyone = comm.allgather(coords)
    offset = sum(len(c) for c in everyone[:comm.rank])
    points = np.concatenate(everyone)
    values = compat.evaluate_at_points(source, points)[:, 0]
    missing = np.isnan(values)
    if missing.all():
        raise ValueError("the two meshes do not overlap")
    if missing.any():
        found = np.flatnonzero(~missing)
        nearest = cKDTree(points[found]).query(points[missing])[1]
        values[missing] = values[found[nearest]]
    target.x.array[:] = values[offset:offset + len(coords)]
