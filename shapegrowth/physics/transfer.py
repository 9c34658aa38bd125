"""Fields moved between two discretisations of the same body (for ``study``'s reference).

A scalar field on one mesh is interpolated at the DOF coordinates of a space on
another mesh of the same body.  Points that fall outside the source mesh (the
fine mesh of a curved boundary sticks out of the coarse polygon by O(h^2)) take
the polynomial of the first source cell met on the way to the nearest point
inside, continued to them (the value of that point where none is met).
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
        lost = np.flatnonzero(missing)
        nearest = found[cKDTree(points[found]).query(points[lost])[1]]
        # A node of the finer mesh of a curved boundary lies outside the coarse polygon by
        # O(h^2), and the nearest node inside can be a wall's thickness away (the tube at
        # h 0.5: its outer nodes took the inner wall's growth, and its exact growth
        # verified at 3.01 % where its own mesh read 0.15 %).  The field is continued from
        # the cell found on the way to that node, the first of these steps inside, all
        # steps asked at once (one search of the source mesh).
        steps = np.arange(1, 10)[:, None, None] / 10
        tries = points[lost] + steps * (points[nearest] - points[lost])  # (step, point, 3)
        got = compat.evaluate_near(source, np.tile(points[lost], (len(steps), 1)),
                                   tries.reshape(-1, 3)).reshape(len(steps), len(lost), -1)
        inside = ~np.isnan(got[:, :, 0])
        met = inside.any(axis=0)
        first = inside.argmax(axis=0)
        values[lost[met]] = got[first[met], np.flatnonzero(met)]
        values[lost[~met]] = values[nearest[~met]]
    target.x.array[:] = values[offset:offset + len(coords)].reshape(-1)
