"""Coarse-to-fine optimisation (``optimizer.levels``): the budgets, the level configs, the
exact carry-over of the design onto the nested mesh, and a run through two levels (history,
checkpoints per level, resume)."""

from __future__ import annotations

import csv

import numpy as np
import pytest
from conftest import CONFIGS, read_json, run_cli
from mpi4py import MPI

import shapegrowth as sg
from shapegrowth import compat
from shapegrowth.optim.levels import level_budgets, level_config
from shapegrowth.optim.problem import StateSolveError

ARC = CONFIGS / "tiny" / "beam_arc.yaml"
SQUARE = CONFIGS / "tiny" / "square_disk.yaml"


def test_budgets_and_level_configs():
    cfg = sg.load_config(ARC, ["optimizer.levels=[0, 1, 2]", "optimizer.max_iterations=10",
                               "objective.hausdorff.alpha=[50, 200]"])
    assert level_budgets(cfg) == (4, 3, 3)
    first, last = level_config(cfg, 0), level_config(cfg, 2)
    assert first.mesh.refine == 0 and first.objective.hausdorff.alphas == (50.0, 200.0)
    assert last.mesh.refine == 2 and last.objective.hausdorff.alphas == (200.0,)
    assert last.optimizer.max_iterations == 3
    given = sg.load_config(ARC, ["optimizer.levels=[0, 1]", "optimizer.level_iterations=[7, 2]"])
    assert level_budgets(given) == (7, 2)
    # max_iterations is the whole budget: a larger split is scaled down in proportion
    capped = sg.load_config(ARC, ["optimizer.levels=[0, 1]", "optimizer.max_iterations=10",
                                  "optimizer.level_iterations=[240, 60]"])
    assert level_budgets(capped) == (8, 2)
    smoke = sg.load_config(ARC, ["optimizer.levels=[0, 1]", "optimizer.max_iterations=2",
                                 "optimizer.level_iterations=[240, 60]"])
    assert level_budgets(smoke) == (1, 1)
    single = sg.load_config(ARC)
    assert level_config(single, 0) is single  # one level is the config itself
    # growth.levels: the sharpness continues on the coarse level only, as the alphas
    grown = sg.load_config(ARC, ["optimizer.levels=[0, 1]", "growth.levels=[0.9, 1.2]",
                                 "growth.sharpness=[1, 4, 16]"])
    assert level_config(grown, 0).growth.sharpness == (1.0, 4.0, 16.0)
    assert level_config(grown, 1).growth.sharpness == (16.0,)
    with pytest.raises(sg.ConfigError, match="optimizer.levels"):
        sg.load_config(ARC, ["optimizer.levels=[0, 0]"])


@pytest.mark.mpi
@pytest.mark.parametrize("degree", [1, 2])
def test_the_design_carries_over_exactly(degree):
    """A design of the growth's degree on the mesh refined once: the same function (its
    values at every coarse node and its integral, to round-off)."""
    cfg = sg.load_config(SQUARE, [f"growth.degree={degree}", "growth.filter_length=0.5"])
    coarse = sg.ReducedFunctional(sg.build_model(cfg))
    fine = sg.ReducedFunctional(sg.build_model(level_config(
        sg.load_config(SQUARE, [f"growth.degree={degree}", "growth.filter_length=0.5",
                                "optimizer.levels=[0, 1]"]), 1)))
    rng = np.random.default_rng(7 + coarse.comm.rank)
    lo, hi = coarse.bounds()
    m = np.clip(coarse.current() * (1 + 0.2 * rng.standard_normal(coarse.size)), lo, hi)
    fine.carry_design(coarse, m)
    comm = coarse.comm
    space = coarse.space
    owned = coarse.n_owned
    nodes = np.concatenate(comm.allgather(space.tabulate_dof_coordinates()[:owned]))
    for k, field in enumerate(fine.design):
        expected = np.concatenate(comm.allgather(m[k * owned:(k + 1) * owned]))
        back = sg.evaluate_at(field, nodes)[:, 0]
        assert np.abs(back - expected).max() < 1e-12
        integrals = [model.integrate(f) for model, f in
                     ((coarse.model, coarse.design[k]), (fine.model, field))]
        assert integrals[1] == pytest.approx(integrals[0], rel=1e-12)


@pytest.mark.slow  # 12 s serially, 8 s on 2 ranks
@pytest.mark.mpi
def test_the_next_level_starts_from_the_last_levels_equilibrium():
    """A level's first state: Newton at the full growth from the coarser level's
    equilibrium carried onto the refined mesh (one step, fewer Newton iterations than the
    load steps from rest), the same equilibrium as from rest; a carried state too far from
    one is reported at once, without load steps."""
    cfg = sg.load_config(ARC, ["optimizer.levels=[0, 1]", "growth.start=target"])
    coarse = sg.ReducedFunctional(sg.build_model(level_config(cfg, 0)))
    m = coarse.current()
    coarse.evaluate(m, gradient=False)
    fine = sg.ReducedFunctional(sg.build_model(level_config(cfg, 1)))
    fine.carry_design(coarse, m)
    carried = fine.evaluate(fine.current(), gradient=False).report
    u_carried = fine.model.state.snapshot()
    fine.restart_from_rest()
    rest = fine.evaluate(fine.current(), gradient=False).report
    assert carried.converged and rest.converged
    assert carried.steps == 1 and rest.steps > 1
    assert carried.newton_iterations < rest.newton_iterations
    scale = fine.comm.allreduce(np.abs(u_carried).max(), op=MPI.MAX)
    gap = fine.comm.allreduce(np.abs(u_carried - fine.model.state.snapshot()).max(), op=MPI.MAX)
    assert gap < 1e-6 * scale
    far = sg.ReducedFunctional(sg.build_model(level_config(cfg, 1)))
    far.carry_design(coarse, m)
    far.model.state.u.x.array[:] *= -3.0  # the arc bent the other way, three times over
    with pytest.raises(StateSolveError, match="carried state"):
        far.evaluate(far.current(), gradient=False)


@pytest.mark.slow
@pytest.mark.mpi
def test_a_run_through_two_levels_and_its_resume(shared_tmp):
    sets = ["--set", "optimizer.levels=[0, 1]", "--set", "optimizer.level_iterations=[4, 2]",
            "--set", "verify.enabled=false"]  # verified on the finest level: tests/test_verify
    assert run_cli("run", ARC, "--out", shared_tmp, "-q", *sets) == 0
    with open(shared_tmp / "history.csv") as fh:
        rows = list(csv.DictReader(fh))
    assert [int(r["level"]) for r in rows] == [0, 0, 0, 0, 1, 1]
    assert [int(r["iteration"]) for r in rows] == list(range(6))
    s = read_json(shared_tmp / "summary.json")
    assert s["iterations"] == 6 and s["status"] == "max_iterations"
    coarse_dofs = compat.global_size(sg.build_model(sg.load_config(ARC)).state.V)
    assert s["dofs"]["state"] > 4 * coarse_dofs
    assert (shared_tmp / "checkpoint.h5").is_file()
    assert (shared_tmp / "checkpoint-level1.h5").is_file()
    # a resume replays both levels from their checkpoints and ends where the run ended
    assert run_cli("run", ARC, "--out", shared_tmp, "-q", "--resume", *sets) == 0
    again = read_json(shared_tmp / "summary.json")
    assert again["objective_final"] == pytest.approx(s["objective_final"], rel=1e-10)
    assert again["resumed"]


@pytest.mark.slow
def test_a_level_without_one_state_leaves_the_last_levels_result(tmp_path, monkeypatch):
    """The fine level cannot grow the carried design (forced here): the run is reported
    failed with the reason, and ends with the coarse level's best design, its fields and
    its verified number - nothing computed is lost."""
    from shapegrowth.optim.problem import ReducedFunctional, StateSolveError
    from shapegrowth.physics.state import SolveReport

    real = ReducedFunctional.evaluate

    def no_state_on_level_1(self, m, gradient=True):
        if self.model.cfg.mesh.refine == 1:
            raise StateSolveError(SolveReport(converged=False, reason="no equilibrium (forced)"))
        return real(self, m, gradient)

    monkeypatch.setattr(ReducedFunctional, "evaluate", no_state_on_level_1)
    cfg = sg.load_config(ARC, ["optimizer.levels=[0, 1]", "optimizer.level_iterations=[3, 2]"])
    result = sg.optimize(cfg, tmp_path)
    s = result.summary
    assert s.status.is_failure
    assert str(s.status).startswith("failed: level 2 of 2: state solve failed at iteration 0")
    assert s.iterations == 3 and s.dofs.state == compat.global_size(
        sg.build_model(sg.load_config(ARC)).state.V)
    assert s.objective_final is not None and s.verified is not None
    assert s.verified.status == "solved"
    assert (tmp_path / "fields.xdmf").is_file()
