"""growth.across_wall: uniform: the mean across a thin wall (physics/walls.py) is a symmetric
projection onto fields constant along each column of nodes, on the flat wall (across X3)
and the tube's (across its radius), serial and on 2 ranks; a run's designed growth is
uniform across the wall while the fields it does not design keep their variation; bodies
without a thin wall are refused by name."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import CONFIGS
from mpi4py import MPI

from shapegrowth import compat
from shapegrowth.config import ConfigError, load
from shapegrowth.physics.geometry import load_domain
from shapegrowth.physics.walls import WallMean, column_keys

BEAM = CONFIGS / "tiny" / "beam_wave.yaml"
TUBE = CONFIGS / "tiny" / "tube_axial.yaml"


def _gathered(comm, *arrays):
    return [np.concatenate(comm.allgather(a)) for a in arrays]


@pytest.mark.mpi
@pytest.mark.parametrize("config, kind", [(BEAM, "box"), (TUBE, "tube")], ids=["box", "tube"])
def test_the_wall_mean_is_a_symmetric_projection_onto_columns(config, kind, shared_tmp):
    cfg = load(config, [f"mesh.cache_dir={shared_tmp}"])
    space = compat.scalar_space(load_domain(cfg).mesh, 1)
    wall = WallMean(space, kind)
    comm = MPI.COMM_WORLD
    n = space.dofmap.index_map.size_local
    x = space.tabulate_dof_coordinates()[:n]
    a = np.sin(3.0 * x[:, 0]) + 7.0 * x[:, 2] + x[:, 1] ** 2
    b = np.cos(2.0 * x[:, 0]) - 5.0 * x[:, 1] * x[:, 2]
    pa = wall.apply(a)
    dot = lambda u, v: comm.allreduce(float(np.dot(u, v)), MPI.SUM)  # noqa: E731
    assert dot(pa, b) == pytest.approx(dot(a, wall.apply(b)), rel=1e-12)  # symmetric
    assert np.allclose(wall.apply(pa), pa, rtol=0, atol=1e-14)  # idempotent
    assert dot(pa, np.ones(n)) == pytest.approx(dot(a, np.ones(n)), rel=1e-12)  # sums kept
    # one layer of degree-1 nodes: two nodes a column, one value in each
    total = comm.allreduce(n, MPI.SUM)
    assert wall.columns * 2 == total
    keys, values, raw = _gathered(comm, np.round(column_keys(kind, x), 9), pa, a)
    _, column = np.unique(keys, axis=0, return_inverse=True)
    column = column.reshape(-1)
    for c in range(wall.columns):
        assert np.ptp(values[column == c]) < 1e-13
    assert np.ptp(raw[column == 0]) > 1e-3  # the field varied across the wall before


@pytest.mark.mpi
def test_a_runs_designed_growth_is_uniform_across_the_wall(shared_tmp):
    from shapegrowth.optim.problem import ReducedFunctional
    from shapegrowth.physics.model import ForwardModel

    cfg = load(BEAM, [f"mesh.cache_dir={shared_tmp}", "growth.across_wall=uniform",
                      "growth.eigenvalues.design=[2,3]",
                      'growth.eigenvalues.initial=["(1 + 0.5*x3)**2", "1 + 5*x3", 1.1]'])
    rf = ReducedFunctional(ForwardModel.build(cfg))
    m = rf.current()
    n = rf.n_owned
    x = rf.space.tabulate_dof_coordinates()[:n]
    # the design starts at the start's mean across the wall: 1 + 5 x3 -> 1
    assert np.allclose(m[:n], 1.0, atol=1e-12)
    m = m + 0.05 * np.sin(np.arange(len(m)) * 1.3)  # a design that varies across the wall
    rf(m)
    comm = MPI.COMM_WORLD
    keys = np.round(column_keys("box", x), 9)
    lam1, lam2, lam3 = (f.x.array[:n] for f in rf.model.growth.eigenvalues)
    keys, lam1, lam2, lam3 = _gathered(comm, keys, lam1, lam2, lam3)
    _, column = np.unique(keys, axis=0, return_inverse=True)
    column = column.reshape(-1)
    spread = [max(np.ptp(f[column == c]) for c in range(column.max() + 1))
              for f in (lam1, lam2, lam3)]
    assert spread[1] < 1e-13 and spread[2] < 1e-13  # designed: one value across the wall
    assert spread[0] > 0.01  # not designed: (1 + 0.5 x3)^2 across the wall of 0.02


def test_a_body_without_a_thin_wall_is_refused_by_name():
    with pytest.raises(ConfigError) as err:
        load(CONFIGS / "tiny" / "cube_uniform.yaml", ["growth.across_wall=uniform"])
    assert any(p.startswith("growth.across_wall: 'uniform' needs a thin-walled 3D body")
               for p in err.value.problems), err.value.problems
    with pytest.raises(ConfigError) as err:
        load(CONFIGS / "tiny" / "disk_axi.yaml", ["growth.across_wall=uniform"])
    assert any(p.startswith("growth.across_wall:") for p in err.value.problems)
