"""Designs made of real materials (growth.levels): the projection's closed forms, the Taylor
test at every sharpness, and a run that ends with the crisp design, verified from rest
(serially and on two ranks)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import CONFIGS, read_json, run_cli
from mpi4py import MPI

from shapegrowth.config import ConfigError, load
from shapegrowth.physics.projection import LevelProjection

LEVELS = (0.8, 1.1, 1.6)


def test_the_projection_keeps_its_levels_and_is_continuously_differentiable():
    """P(g_k) = g_k at every sharpness; the crisp P sends each value to its nearest level,
    exactly; dP/dx is the finite difference's, and equal on both sides of a level."""
    p = LevelProjection(LEVELS)
    g = np.array(LEVELS)
    for beta in (1.0, 4.0, 32.0):
        assert p.value(g, beta) == pytest.approx(g, abs=1e-15)
        x = np.linspace(0.8, 1.6, 2001)[1:-1]
        h = 1e-7
        fd = (p.value(x + h, beta) - p.value(x - h, beta)) / (2 * h)
        assert np.abs(fd - p.slope(x, beta)).max() < 1e-5 * max(1.0, beta)
        assert np.all(np.diff(p.value(x, beta)) >= 0)
        assert p.slope(np.array([1.1 - 1e-13]), beta) == pytest.approx(
            p.slope(np.array([1.1 + 1e-13]), beta), rel=1e-9)
    x = np.array([0.7, 0.8, 0.94, 0.96, 1.1, 1.34, 1.36, 1.7])
    crisp = p.value(x, math.inf)
    assert set(crisp.tolist()) <= set(LEVELS)
    assert crisp.tolist() == [0.8, 0.8, 0.8, 1.1, 1.1, 1.1, 1.6, 1.6]
    assert p.index(x).tolist() == [0, 0, 0, 1, 1, 1, 2, 2]
    assert np.all(p.slope(x, math.inf) == 0)
    assert p.slope(np.array([0.7, 1.7]), 4.0).tolist() == [0.0, 0.0]  # clipped


LEVEL_SETS = ["growth.levels=[0.8,1.3]", "growth.filter_length=0.05", "solver.rtol=1e-13"]


@pytest.mark.mpi
def test_the_gradient_is_exact_at_every_sharpness(shared_tmp):
    """The tiny beam with two levels: Taylor rates above 1.9 at every sharpness of the
    schedule (the Newton tolerance tightened: at beta 16 the default's floor of ~1e-9 was
    above the remainder's last halving)."""
    sets = [*LEVEL_SETS, "growth.sharpness=[1,8,16,32]"]
    status = run_cli("gradcheck", CONFIGS / "tiny" / "beam_wave.yaml", "--out", shared_tmp, "-q",
                     *[a for s in sets for a in ("--set", s)])
    report = read_json(shared_tmp / "gradcheck.json")
    assert status == 0
    assert [s["sharpness"] for s in report["sharpness"]] == [1.0, 8.0, 16.0, 32.0]
    for stage in report["sharpness"]:
        assert min(stage["rates"][:3]) > 1.9, stage


@pytest.mark.mpi
def test_a_run_ends_with_the_crisp_design_verified_from_rest(shared_tmp):
    """Twelve iterations over two sharpness stages: the settled growth takes only the levels,
    exactly, its numbers are the crisp design's (the final rho_H is not the last stage's),
    and the verification grows that design from rest."""
    out = shared_tmp / "run"
    sets = [*LEVEL_SETS, "growth.sharpness=[1,8]", "optimizer.max_iterations=12"]
    status = run_cli("run", CONFIGS / "tiny" / "beam_wave.yaml", "--out", out, "-q",
                     *[a for s in sets for a in ("--set", s)])
    assert status == 0
    summary = read_json(out / "summary.json")
    growth = np.load(out / "growth.npz")
    for name in ("lambda_hat_1", "lambda_hat_2", "lambda_hat_3"):
        assert set(np.unique(growth[name]).tolist()) <= {0.8, 1.3}
    assert summary["verified"]["relative"] is not None
    assert summary["iterations"] == 12
    if MPI.COMM_WORLD.rank == 0:
        history = (out / "history.csv").read_text().splitlines()
        last = float(history[-1].split(",")[2])
        assert summary["rho_H_final"] != pytest.approx(last, rel=1e-6)


@pytest.mark.parametrize("sets, message", [
    (["growth.levels=[1.3,0.8]"], "growth.levels: two values or more, increasing"),
    (["growth.levels=[1.0]"], "growth.levels: two values or more, increasing"),
    (["growth.levels=[0.001,1.3]"], "leave the eigenvalues' bounds"),
    (["growth.levels=[1.2,1.5]"], "growth.eigenvalues.initial[1]: 1.0 is outside growth.levels'"),
    (["growth.levels=[0.8,1.3]", "growth.sharpness=[4,2]"], "growth.sharpness: positive and "
                                                            "increasing"),
    (["growth.levels=[0.8,1.3]", "verify.best=verified", "verify.every=5"],
     "growth.levels: the crisp design is what is verified"),
])
def test_bad_levels_are_one_line_each(sets, message):
    with pytest.raises(ConfigError) as err:
        load(CONFIGS / "tiny" / "beam_wave.yaml", sets)
    assert any(message in p for p in err.value.problems), err.value.problems
