"""rho_H of a growth shell's wall (optim/shell_objective.py): its cloud and its gradient."""

from __future__ import annotations

import dolfinx
import numpy as np
import pytest
import ufl
from conftest import design_taylor, shell_taylor_rates
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


def _rolled(shell, m):
    """The strip grown by lam_1 = 1.05 + 1.0 zeta (a stretch and a roll of about one radian):
    its wall's cloud (ShellCloud), that cloud's points and weights, and its mid-surface's
    nodes."""
    m.interpolate(lambda x: np.vstack([1.05 + 0 * x[0], 1.0 + 0 * x[0], 1.0 + 0 * x[0],
                                       0 * x[0]]))
    assert shell.solve().converged
    cloud = ShellCloud(shell)
    return cloud, cloud.deformed(), shell.mid_surface()[1]


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
    # the same stretch given as a target map: its cloud is the grown wall's, point for point
    mapped = cloud.mapped(lambda X: X * np.array([1.1, 1.0, 1.0]))
    assert mapped.points == pytest.approx(grown.points, abs=1e-8)
    assert mapped.weights == pytest.approx(grown.weights, rel=1e-8)
    with pytest.raises(ValueError, match=r"\(n, 3\) finite"):
        cloud.mapped(lambda X: X[:, :2])


@pytest.mark.mpi
def test_the_wall_s_rho_h_passes_its_taylor_test():
    """rho_H of the wall against a rolled strip's wall (the same shell at another growth),
    its gradient through the shell's adjoint: the Taylor remainder falls like h^2."""
    shell, m = _strip()
    cloud, target, _ = _rolled(shell, m)
    m.interpolate(lambda x: np.vstack([1.1 + 0.05 * x[0], 1.0 + 0 * x[0], 1.2 + 0.3 * x[0],
                                       0.1 + 0 * x[0]]))
    assert shell.solve().converged
    rho = SmoothHausdorff(alpha=50.0)

    def evaluate(gradient: bool):
        result, dJ = cloud.hausdorff(target, rho, gradient)
        return result.value, dJ

    dm = dolfinx.fem.Function(m.function_space)
    dm.interpolate(lambda x: np.vstack([0.05 * np.sin(3 * x[0]), 0.02 * np.cos(2 * x[0]),
                                        0.3 * np.cos(4 * x[0]), 0.1 * x[0]]))
    remainders, rates = shell_taylor_rates(shell, evaluate, m, dm)
    assert min(rates) > 1.9, (remainders, rates)


@pytest.mark.mpi
def test_the_optimiser_finds_a_rolled_strip_again_from_the_uniform_growth():
    """A reachable target: the wall of the strip grown by lam_1 = 1.05 + 1.0 zeta (a stretch
    and a roll of about one radian), found from the uniform growth by L-BFGS on rho_H (alpha
    50, 200, 1000; 100 evaluations), the four fields filtered at l = 0.2 and bounded.
    Measured: the exact Hausdorff distance 0.475 -> 1.24e-3 of the strip's length serially,
    1.5e-3 to 4.7e-3 on two ranks (where the stage ends after its 100 evaluations moves with
    the rounding of the sums), the mid-surface's nodes within 2.0e-3 of the target's, the
    fields' means (1.050, 1.001, 0.970, 0.033) against (1.05, 1, 1, 0).  Asserted: found
    to within 1 % of the length."""
    from shapegrowth.optim.driver import Driver, DriverSettings
    from shapegrowth.optim.shell_problem import ShellDesign

    shell, m = _strip()
    cloud, target, goal = _rolled(shell, m)
    m.interpolate(lambda x: np.vstack([1.0 + 0 * x[0], 1.0 + 0 * x[0], 0 * x[0], 0 * x[0]]))
    assert shell.solve().converged
    problem = ShellDesign(shell, target, SmoothHausdorff(alpha=50.0), [0.8, 0.8, -5.0, -5.0],
                          [1.3, 1.3, 5.0, 5.0], cloud, filter_length=0.2)
    driver = Driver(problem, DriverSettings("strip", "lbfgs", 100, (50.0, 200.0, 1000.0)))
    result = driver.run()
    first = result.history[0].hausdorff
    found = problem.evaluate(driver.local(result.best))
    assert first == pytest.approx(0.4746, rel=1e-3)
    assert found.value.hausdorff < 1e-2
    _, phi = shell.mid_surface()
    comm = MPI.COMM_WORLD
    assert comm.allreduce(float(np.max(np.linalg.norm(phi - goal, axis=1))), MPI.MAX) < 1e-2
    fields = m.x.array.reshape(-1, 4)[:m.function_space.dofmap.index_map.size_local]
    means = comm.allreduce(fields.sum(axis=0)) / comm.allreduce(len(fields))
    assert means[0] == pytest.approx(1.05, abs=1e-2)


@pytest.mark.mpi
def test_the_filtered_shell_design_passes_its_taylor_test():
    """J(m) of ShellDesign, its four raw fields through the Helmholtz filter (l = 0.2) into
    the shell: J(m + h dm) - J(m) - h dJ.dm falls like h^2 (measured: 1.9965, 1.9982)."""
    from shapegrowth.optim.shell_problem import ShellDesign

    shell, m = _strip()
    _, target, _ = _rolled(shell, m)
    m.interpolate(lambda x: np.vstack([1.1 + 0.05 * x[0], 1.0 + 0 * x[0], 1.2 + 0.3 * x[0],
                                       0.1 + 0 * x[0]]))
    problem = ShellDesign(shell, target, SmoothHausdorff(alpha=50.0), [0.5] * 2 + [-5.0] * 2,
                          [1.5] * 2 + [5.0] * 2, filter_length=0.2)
    result = design_taylor(problem, seed=3, scale=0.05, eps0=0.1, steps=2)
    assert result.min_rate > 1.9, result
