"""Fields moved between two discretisations of the same body (for ``study``'s reference).

A scalar field on one mesh is interpolated at the DOF coordinates of a space on
another mesh of the same body.  Points that fall outside the source mesh (the
fine mesh of a curved boundary sticks out of the coarse polygon by O(h^2)) take
the value of the nearest point that fell inside.
"""

from __future__ import annotations

from collections.abc import Callable

import dolfinx.fem
import numpy as np
from mpi4py import MPI
from scipy.spatial import cKDTree

from .. import compat
from .boundary import body_box


def interpolate_between_meshes(source: dolfinx.fem.Function, target: dolfinx.fem.Function,
                               to_source: Callable[[np.ndarray], np.ndarray] | None = None
                               ) -> None:
    """target := source at target's DOF coordinates (collective on the mesh's comm; a
    vector field node by node);
    ``to_source`` maps those points (n, 3) to the source mesh's coordinates (n, k), e.g. a
    3D body's points to the section its 2D model meshes (the lift)."""
    comm: MPI.Comm = target.function_space.mesh.comm
    coords = target.function_space.tabulate_dof_coordinates()
    everyone = comm.allgather(coords)
    offset = sum(len(c) for c in everyone[:comm.rank])
    points = np.concatenate(everyone)
    if to_source is not None:
        mapped = to_source(points)
        points = np.zeros((len(mapped), 3))
        points[:, :mapped.shape[1]] = mapped
    # a node of a nested mesh can lie outside the other mesh by round-off (a regenerated hex
    # mesh's far end at 1 - 1e-16): points are held inside the source's bounding box
    lo, hi = body_box(source.function_space.mesh)
    points = np.clip(points, lo, hi)
    values = compat.evaluate_at_points(source, points)  # (n, block size)
    missing = np.isnan(values[:, 0])
    if missing.all():
        raise ValueError("the two meshes do not overlap")
    if missing.any():
        found = np.flatnonzero(~missing)
        nearest = cKDTree(points[found]).query(points[missing])[1]
        values[missing] = values[found[nearest]]
    target.x.array[:] = values[offset:offset + len(coords)].reshape(-1)
