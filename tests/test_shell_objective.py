"""rho_H of a growth shell's wall (optim/shell_objective.py): its cloud and its gradient."""

from __future__ import annotations

import dolfinx
import numpy as np
import pytest
import ufl
from conftest import shell_taylor_rates
from mpi4py import MPI

from shapegrowth import compat
from shapegrowth.optim.shell_objective import ShellCloud
from shapegrowth.physics.material import MooneyRivlin
from shapegrowth.physics.shell import GrowthShell, RestForms, ShellMaterial
from shapegrowth.shape.hausdorff import SmoothHausdorff

LENGTH, WIDTH, WALL = 1.0, 0.1, 0.01


def _strip(cells: int = 12):
    """The strip clamped at X1 = 0, its growth the four stretch fields (P1) of the mid-surface
    and their slopes through the wall."""
    mesh = dolfinx.mesh.create_rectangle(
        MPI.COMM_WORLD, [np.array([0.0, 0.0]), np.array([LENGTH, WIDTH])], [cells, 2],
        dolfinx.mesh.CellType.triangle)
    m = dolfinx.fem.Function(compat.vector_space(mesh, 1, 4))
    rest = RestForms.of_stretches(ufl.Identity(2), ufl.as_vector([m[0], m[1]]),
                                  ufl.as_vector([m[2], m[3]]))
    shell = GrowthShell(mesh, WALL, ShellMaterial.of_energy(MooneyRivlin()), rest,
                        lambda x: np.isclose(x[0], 0.0), design=m)
    return shell, m


def _total(cloud) -> float:
    return MPI.COMM_WORLD.allreduce(float(np.sum(cloud.weights)))


@pytest.mark.mpi
def test_the_wall_s_cloud_weighs_the_wall_and_its_stretch():
    """The reference cloud weighs the wall's volume (L W t) and fills its thickness; the wall
    grown by 1.1 along X1 weighs 1.1 times it, its points 1.1 times as far along."""
    shell, m = _strip(4)
    cloud = ShellCloud(shell, layers=2)
    rest = cloud.reference()
    assert _total(rest) == pytest.approx(LENGTH * WIDTH * WALL, rel=1e-12)
    heights = np.unique(np.round(rest.points[:, 2], 12))
    assert heights == pytest.approx(WALL / 2 / np.sqrt(3) * np.array([-1.0, 1.0]), rel=1e-12)
    m.interpolate(lambda x: np.vstack([1.1 + 0 * x[0], 1.0 + 0 * x[0], 0 * x[0], 0 * x[0]]))
    assert shell.solve().converged
    grown = cloud.deformed()
    assert _total(grown) == pytest.approx(1.1 * LENGTH * WIDTH * WALL, rel=1e-8)
    assert grown.points[:, 0] == pytest.approx(1.1 * rest.points[:, 0], abs=1e-8)


@pytest.mark.mpi
def test_the_wall_s_rho_h_passes_its_taylor_test():
    """rho_H of the wall against a rolled strip's wall (the same shell at another growth),
    its gradient through the shell's adjoint: the Taylor remainder falls like h^2."""
    shell, m = _strip()
    m.interpolate(lambda x: np.vstack([1.05 + 0 * x[0], 1.0 + 0 * x[0], 1.0 + 0 * x[0],
                                       0 * x[0]]))
    assert shell.solve().converged
    cloud = ShellCloud(shell)
    target = cloud.deformed()
    m.interpolate(lambda x: np.vstack([1.1 + 0.05 * x[0], 1.0 + 0 * x[0], 1.2 + 0.3 * x[0],
                                       0.1 + 0 * x[0]]))
    assert shell.solve().converged
    rho = SmoothHausdorff(alpha=50.0)

    def evaluate():
        result, gradient = cloud.hausdorff(target, rho)
        return result.value, gradient

    dm = dolfinx.fem.Function(m.function_space)
    dm.interpolate(lambda x: np.vstack([0.05 * np.sin(3 * x[0]), 0.02 * np.cos(2 * x[0]),
                                        0.3 * np.cos(4 * x[0]), 0.1 * x[0]]))
    remainders, rates = shell_taylor_rates(shell, evaluate, m, dm)
    assert min(rates) > 1.9, (remainders, rates)
