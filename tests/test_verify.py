"""The verified shape error of a run: the growth carried exactly onto the refined mesh,
solved from rest there; its fields in summary.json; the warning that names the likely cause
when it is more than twice the run's own."""

from __future__ import annotations

import logging

import numpy as np
import pytest
from conftest import CONFIGS, read_json, run_cli
from mpi4py import MPI

import shapegrowth as sg
from shapegrowth.io.records import Verified
from shapegrowth.optim.lift import verification_model
from shapegrowth.optim.objective import VERIFY_CLOUD_DEGREE, Objective, verification_clouds
from shapegrowth.optim.verification import branch_changed, likely_cause, refined_config
from shapegrowth.physics.transfer import interpolate_between_meshes

ARC = CONFIGS / "tiny" / "beam_arc.yaml"
SQUARE = CONFIGS / "tiny" / "square_disk.yaml"


@pytest.mark.mpi
@pytest.mark.parametrize("degree", [1, 2])
def test_a_growth_carries_over_exactly_onto_the_nested_mesh(degree):
    """A growth field of the growth space's degree, on the mesh refined once: the same
    function (its integral and its values at the coarse nodes to round-off)."""
    cfg = sg.load_config(SQUARE, [f"growth.degree={degree}",
                                  "growth.eigenvalues.initial=['2 + 0.1*x1*x2 + 0.05*x1', 1.5]"])
    coarse = sg.build_model(cfg)
    fine = sg.build_model(refined_config(cfg, 1))
    assert fine.state.V.dofmap.index_map.size_global > 3 * coarse.state.V.dofmap.index_map.size_global
    field = coarse.growth.eigenvalues[0]
    # a field that is not the expression: the coarse nodal values perturbed
    rng = np.random.default_rng(1)
    field.x.array[:] += 0.1 * rng.standard_normal(field.x.array.size)
    field.x.scatter_forward()
    target = fine.growth.eigenvalues[0]
    interpolate_between_meshes(field, target)
    integral = [m.integrate(f) for m, f in ((coarse, field), (fine, target))]
    assert integral[1] == pytest.approx(integral[0], rel=1e-12)
    comm = coarse.comm  # every rank asks for the same points: all coarse nodes
    owned = coarse.growth.space.dofmap.index_map.size_local
    nodes = np.concatenate(comm.allgather(
        coarse.growth.space.tabulate_dof_coordinates()[:owned]))
    values = np.concatenate(comm.allgather(field.x.array[:owned]))
    back = sg.evaluate_at(target, nodes)[:, 0]
    assert np.abs(back - values).max() < 1e-12


# simplices: gmsh refines them nested, the new nodes on the circle; a hexahedral mesh is
# regenerated with curved (second-order) cells, on which a linear growth is not in the space
@pytest.mark.simplex
@pytest.mark.mpi
def test_a_growth_carries_onto_a_curved_wall_refined_past_its_polygon():
    """A tube's mesh refined once puts its new outer nodes on the circle, outside the coarse
    polygon (by 1 - cos(pi/16) = 0.019 at 16 segments round).  A growth linear across the
    section carries onto them exactly: each is continued from the coarse cell it lies
    beside, not given the value of the nearest node inside (before: the inner wall's, a
    wall's thickness away, which made scene 3's exact growth verify at 3.01 % where its
    own mesh read 0.15 %)."""
    cfg = sg.load_config(CONFIGS / "tube_helix.yaml", [
        "geometry.length=2.0", "mesh.size=0.5",
        "growth.eigenvalues.initial=['1.5 + 0.3*x2 - 0.2*x3 + 0.1*x1', 1.0, 1.0]",
        "growth.start=given"])
    coarse = sg.build_model(cfg)
    fine = sg.build_model(refined_config(cfg, 1))
    target = fine.growth.eigenvalues[0]
    interpolate_between_meshes(coarse.growth.eigenvalues[0], target)
    X = fine.growth.space.tabulate_dof_coordinates()
    exact = 1.5 + 0.3 * X[:, 1] - 0.2 * X[:, 2] + 0.1 * X[:, 0]
    outside = np.abs(np.hypot(X[:, 1], X[:, 2]) - 1.0) < 1e-9  # on the circle: all beyond a chord
    outside &= ~np.isclose(np.mod(np.arctan2(X[:, 2], X[:, 1]), np.pi / 8), 0.0, atol=1e-6)
    assert fine.comm.allreduce(int(outside.sum()), MPI.SUM) > 0
    assert np.abs(target.x.array - exact).max() < 1e-10


def test_likely_cause_names_the_branch_or_the_mesh():
    def v(relative, changed):
        return Verified(0.1, relative, 1, 10, 0.0, changed, "solved")

    assert likely_cause(0.02, v(0.039, False)) is None  # within a factor 2
    assert likely_cause(0.02, v(0.05, False)) == "mesh"
    assert likely_cause(0.02, v(0.05, True)) == "branch"
    assert likely_cause(0.02, Verified(None, None, 1, 10, 0.0, False, "failed: x")) == "mesh"
    assert not branch_changed(1.02, 1.0, 10.0) and branch_changed(1.2, 1.0, 10.0)
    assert branch_changed(None, 1.0, 10.0)


def test_a_verified_number_on_an_unstable_state_says_so_beside_it():
    """Scene 4's section lifted onto hexahedra: the symmetric mesh holds the disk on its
    axisymmetric path past the bifurcation (0.68 %, 4 negative eigenvalues): the headline
    carries UNSTABLE where it lost stability; a stable state's headline carries nothing."""
    from shapegrowth.commands.report import verified_text
    from shapegrowth.io.records import Lifted
    from shapegrowth.physics.stability import Stability

    stable = Stability((0.6, 1.2), 0)
    unstable = Stability((-0.0227, -0.0227, -0.0152), 4, lost_at=0.35, kind="bifurcation")
    lifted = Lifted(0.0131, 0.00681, 24480, 35.0, "solved", "disk_cone", 0.006, unstable)
    text = verified_text(Verified(0.0038, 0.00476, 1, 42306, 13.7, False, "solved", lifted,
                                   stable))
    head, section = text.split("; the reduced model's ")
    assert "0.681 %" in head and "UNSTABLE since 0.35 of the growth" in head
    assert "0.476 %" in section and "UNSTABLE" not in section
    alone = verified_text(Verified(0.0038, 0.00476, 1, 42306, 13.7, False, "solved", None,
                                    unstable))
    assert "0.476 %" in alone and "UNSTABLE since 0.35" in alone
    chosen = verified_text(Verified(0.0038, 0.00476, 1, 42306, 13.7, False, "solved",
                                     iteration=120))
    assert "iteration 120's growth, the lowest verified along the run" in chosen



def test_the_headline_names_the_lifted_model_where_there_is_one():
    """A lifted section leads with its 3D body's number, DOFs, status and stability; the
    check's wall time is the section's and the lift's together."""
    from shapegrowth.io.records import Lifted
    from shapegrowth.physics.stability import Stability

    stable = Stability((0.6, 1.2), 0)
    unstable = Stability((-0.02,), 1, lost_at=0.5, kind="bifurcation")
    lifted = Lifted(None, None, 24480, 35.0, "failed: no load step", "disk_cone", None, unstable)
    v = Verified(0.0038, 0.00476, 1, 42306, 13.7, False, "solved", lifted, stable)
    assert v.headline is None and v.headline_dofs == 24480
    assert v.headline_status == "failed: no load step" and v.headline_stability is unstable
    assert v.check_wall_s == pytest.approx(48.7)
    alone = Verified(0.0038, 0.00476, 1, 42306, 13.7, False, "solved", None, stable)
    assert alone.headline == 0.00476 and alone.headline_dofs == 42306
    assert alone.headline_status == "solved" and alone.headline_stability is stable
    assert alone.check_wall_s == 13.7

@pytest.mark.slow
@pytest.mark.mpi
def test_every_run_reports_its_verified_error(shared_tmp):
    assert run_cli("run", ARC, "--out", shared_tmp, "-q", "--set",
                   "optimizer.max_iterations=4") == 0
    s = read_json(shared_tmp / "summary.json")
    v = s["verified"]
    assert set(v) == {"hausdorff", "relative", "refine", "dofs", "wall_s", "branch_changed",
                      "status", "stability", "surface", "iteration", "continued_from"}
    assert v["iteration"] is None  # verify.best: self, the optimiser's best
    assert v["continued_from"] is None  # a run's verification grows from rest
    assert v["stability"]["stable"] and v["stability"]["negative"] == 0
    # the boundaries surface to surface beside the volume clouds' points: the same shape
    # error to within the clouds' sampling (a tenth of the cells here)
    assert 0 < v["surface"] < 1
    assert v["surface"] == pytest.approx(v["relative"], rel=0.5)
    assert v["status"] == "solved" and v["refine"] == 1 and not v["branch_changed"]
    assert v["dofs"] > 4 * s["dofs"]["state"]  # the state on the mesh refined once
    assert v["relative"] == pytest.approx(v["hausdorff"] / s["target_size"], rel=0.05)
    summary = sg.RunSummary.from_json(s)
    assert summary.verified is not None and summary.verified.hausdorff == v["hausdorff"]


@pytest.mark.slow
def test_the_verified_number_is_the_refined_model_solved_from_rest(tmp_path):
    """The same growth, judged by the study's reference (refined once, from rest, measured
    with the verification's clouds), gives the verified number to round-off."""
    from shapegrowth.commands.study import evaluate_on_reference

    cfg = sg.load_config(ARC, ["optimizer.max_iterations=3"])
    result = sg.optimize(cfg, tmp_path)
    judged = evaluate_on_reference(result.model, verification_clouds(refined_config(cfg, 1)))
    assert result.summary.verified is not None
    assert result.summary.verified.hausdorff == pytest.approx(judged["hausdorff_reference"],
                                                              rel=1e-9)


def test_verification_can_be_switched_off(tmp_path):
    assert run_cli("run", ARC, "--out", tmp_path, "-q", "--set", "optimizer.max_iterations=2",
                   "--set", "verify.enabled=false") == 0
    assert "verified" not in read_json(tmp_path / "summary.json")


def test_a_run_far_from_its_verified_error_says_why(tmp_path, monkeypatch, caplog):
    """The warning names the likely cause; here the verification is replaced by one that
    reports another branch at more than twice the run's error."""
    import shapegrowth.commands.run as run

    def far(model, refine, changed):
        return Verified(1.0, 0.9, refine, 1, 0.0, True, "solved")

    monkeypatch.setattr(run, "verify", far)
    logger = logging.getLogger("shapegrowth")  # it may not propagate (logs.configure)
    logger.addHandler(caplog.handler)
    try:
        result = sg.optimize(sg.load_config(ARC, ["optimizer.max_iterations=2"]), tmp_path)
    finally:
        logger.removeHandler(caplog.handler)
    own = result.summary.relative_error
    assert own is not None and 0.9 > 2 * own
    warnings = [r.getMessage() for r in caplog.records if r.levelno == logging.WARNING]
    assert any("likely the branch" in w and "is not the run's" in w for w in warnings), warnings


@pytest.mark.slow
def test_the_physical_branch_mode_solves_from_rest_every_k_iterations(tmp_path, monkeypatch):
    """``optimizer.from_rest_every: 2``: the state is dropped after every second iteration,
    so the next one is grown from rest; where the body has one equilibrium (the arc) the
    objective is the one the warm starts find (measured: 21 Newton iterations from rest
    against 48 warm after MMA's large steps)."""
    from shapegrowth.physics.state import StateProblem

    resets = []
    real = StateProblem.reset

    def counted(self, step_scale=1.0):
        resets.append(step_scale)
        return real(self, step_scale)

    monkeypatch.setattr(StateProblem, "reset", counted)
    sets = ["optimizer.max_iterations=6", "verify.enabled=false"]
    warm = sg.optimize(sg.load_config(ARC, sets), tmp_path / "warm")
    n_warm = len(resets)  # the final solve from rest of the best growth
    rest = sg.optimize(sg.load_config(ARC, [*sets, "optimizer.from_rest_every=2"]),
                       tmp_path / "rest")
    assert len(resets) - n_warm == n_warm + 3  # after iterations 1, 3 and 5
    hw, hr = (np.genfromtxt(tmp_path / n / "history.csv", delimiter=",", names=True)
              for n in ("warm", "rest"))
    assert hr["objective"] == pytest.approx(hw["objective"], rel=1e-7)
    assert rest.summary.objective_final == pytest.approx(warm.summary.objective_final, rel=1e-7)


@pytest.mark.slow
@pytest.mark.mpi
def test_verify_every_writes_the_verified_error_along_the_run(shared_tmp):
    """verify.every: 2: verified.csv holds iterations 1 and 3, each the design just
    evaluated grown from rest on the refined mesh; iteration 3 is the run's last and best
    here, so its row is the run's own final verification to round-off.  The clock of a
    row leaves the checks out, and a resumed run does not check a replayed iteration
    again."""
    from shapegrowth.io.along import first_below, read_checks

    out = shared_tmp / "along"
    sets = ["--set", "optimizer.max_iterations=4", "--set", "verify.every=2"]
    assert run_cli("run", ARC, "--out", out, "-q", *sets) == 0
    checks = read_checks(out / "verified.csv")
    assert [c.iteration for c in checks] == [1, 3] and [c.level for c in checks] == [0, 0]
    s = read_json(out / "summary.json")
    rows = (out / "history.csv").read_text().splitlines()[1:]
    objective = [float(r.split(",")[1]) for r in rows]
    assert int(np.argmin(objective)) == 3  # the last design is the best: the final one
    assert checks[1].verified_relative == pytest.approx(s["verified"]["relative"], rel=1e-9)
    assert checks[1].self_relative == pytest.approx(s["hausdorff_final"] / s["target_size"],
                                                    rel=1e-9)
    assert 0 < checks[0].seconds < checks[1].seconds < s["wall_time_s"]
    assert 0 < checks[0].verification_seconds < checks[1].verification_seconds
    assert checks[1].seconds + checks[1].verification_seconds < s["wall_time_s"]
    assert first_below(checks, 1.0) is checks[0] and first_below(checks, 0.0) is None
    # resumed after the end: every iteration is replayed, nothing is checked again
    assert run_cli("run", ARC, "--out", out, "-q", "--resume", *sets) == 0
    assert len(read_checks(out / "verified.csv")) == 2


def _scripted_verify(monkeypatch, relatives):
    """``verify`` replaced (in the checks and in the run) by one that returns the given
    relative errors in turn and records the growth's integral it was asked about."""
    import shapegrowth.commands.run as run
    import shapegrowth.optim.verification as along

    asked = []

    def scripted(model, refine, changed=False):
        asked.append(model.integrate(model.growth.eigenvalues[0]))
        relative = relatives[len(asked) - 1]
        return Verified(relative, relative, refine, 1, 0.0, changed, "solved")

    monkeypatch.setattr(run, "verify", scripted)
    monkeypatch.setattr(along, "verify", scripted)
    return asked


@pytest.mark.mpi
# on two ranks in make test-all (11 s); the fast tier's two ranks verify a run in
# test_verify_checks_a_run_on_its_mesh_refined_once_more
@pytest.mark.mpi_slow
def test_verify_best_ends_the_run_on_the_lowest_verified_growth(shared_tmp, monkeypatch):
    """verify.best: verified, checks at iterations 1 and 3 (verified 20 % and 50 %,
    scripted): the optimiser's best (iteration 3, by its own number; not verified again)
    is no lower, so the run ends on iteration 1's growth: its state (the self-reported
    numbers of that row of history.csv), its growth written, its check the headline, named
    by iteration."""
    script = [0.2, 0.5]
    asked = _scripted_verify(monkeypatch, script)
    out = shared_tmp / "best"
    cfg = sg.load_config(ARC, ["optimizer.max_iterations=4", "verify.every=2",
                               "verify.best=verified"])
    result = sg.optimize(cfg, out)
    history = np.genfromtxt(out / "history.csv", delimiter=",", names=True)
    assert int(np.argmin(history["objective"])) == 3  # the optimiser's best: the last
    # the two checks only: the optimiser's best is the latest check's design (iteration
    # 3's), whose verification is its own
    assert len(asked) == 2
    v, s = result.summary.verified, result.summary
    assert v is not None and v.relative == 0.2 and v.iteration == 1
    assert s.objective_final == pytest.approx(history["objective"][1], rel=1e-6)
    assert s.hausdorff_final == pytest.approx(history["hausdorff"][1], rel=1e-6)
    assert s.hausdorff_final != pytest.approx(history["hausdorff"][3], rel=1e-3)
    growth = result.model.growth.eigenvalues[0]
    assert result.model.integrate(growth) == pytest.approx(asked[0], rel=1e-12)
    assert read_json(out / "summary.json")["verified"]["iteration"] == 1
    # resumed after the end: the checks' numbers read back from verified.csv, their designs
    # from the replay; the optimiser's best verified, and the winner verified again
    asked.clear()
    script[:] = [0.5, 0.2]
    resumed = sg.optimize(cfg, out, resume=True).summary
    assert len(asked) == 2 and len((out / "verified.csv").read_text().splitlines()) == 3
    assert asked[1] == pytest.approx(result.model.integrate(growth), rel=1e-12)
    assert resumed.verified is not None and resumed.verified.iteration == 1
    assert resumed.hausdorff_final == pytest.approx(s.hausdorff_final, rel=1e-6)


@pytest.mark.slow  # verify.best's other outcome (5.7 s); the fast tier runs the first
def test_verify_best_keeps_the_optimisers_best_where_it_verifies_lower(tmp_path, monkeypatch):
    """The same run with the optimiser's best verifying lowest: the run is verify.best:
    self's, and a check whose design is the optimiser's best is not verified twice."""
    asked = _scripted_verify(monkeypatch, [0.5, 0.2])
    cfg = sg.load_config(ARC, ["optimizer.max_iterations=4", "verify.every=2",
                               "verify.best=verified"])
    result = sg.optimize(cfg, tmp_path)
    history = np.genfromtxt(tmp_path / "history.csv", delimiter=",", names=True)
    v = result.summary.verified
    assert len(asked) == 2 and v is not None and v.relative == 0.2 and v.iteration is None
    assert result.summary.hausdorff_final == pytest.approx(history["hausdorff"][3], rel=1e-6)


@pytest.mark.slow
def test_verify_best_hands_a_levels_winner_to_the_next_level(tmp_path, monkeypatch):
    """Coarse to fine (levels [0, 1], 4 iterations each): the first level's lowest check
    (iteration 1, not its optimiser's best) is the design the second level starts from;
    the second level's own checks and best decide the run."""
    asked = _scripted_verify(monkeypatch, [0.2, 0.5, 0.4, 0.3, 0.3])
    cfg = sg.load_config(ARC, ["optimizer.max_iterations=8", "optimizer.levels=[0, 1]",
                               "verify.every=2", "verify.best=verified"])
    result = sg.optimize(cfg, tmp_path)
    history = np.genfromtxt(tmp_path / "history.csv", delimiter=",", names=True)
    first = history[history["level"] == 0]
    assert int(np.argmin(first["objective"])) == 3
    # the second level's first evaluation is iteration 1's design on the finer mesh (17 %
    # above its number on the coarse one here), not iteration 3's (a quarter of that)
    assert history["hausdorff"][4] == pytest.approx(first["hausdorff"][1], rel=0.25)
    assert history["hausdorff"][4] > 3 * first["hausdorff"][3]
    second = history[history["level"] == 1]
    # 2 checks on each level; the optimiser's best verified only where it is neither
    # check's design (the first level's is its latest check's, iteration 3's)
    assert len(asked) == (4 if int(np.argmin(second["objective"])) == 3 else 5)
    v = result.summary.verified
    assert v is not None and v.relative == 0.3


@pytest.mark.parametrize("degree, measured", [(1, 6), (4, 6), (6, 6), (7, 7)])
def test_the_verification_measures_with_clouds_of_degree_six_at_least(degree, measured):
    """A run may optimise on cheaper clouds (quadrature degree 1 or 2); its verification
    measures with degree 6 (VERIFY_CLOUD_DEGREE) or the run's own where that is higher, so
    verified numbers compare.  The refined model itself is the run's (its clouds, and so
    where det F is checked, unchanged): only the measurement is denser."""
    cfg = sg.load_config(SQUARE, [f"objective.hausdorff.quadrature_degree={degree}"])
    assert VERIFY_CLOUD_DEGREE == 6
    assert verification_clouds(cfg).objective.hausdorff.quadrature_degree == measured
    fine = refined_config(cfg, 1)
    assert fine.objective.hausdorff.quadrature_degree == degree
    assert fine.mesh.refine == cfg.mesh.refine + 1


def test_the_verification_checks_det_f_where_the_run_does_and_measures_denser(monkeypatch):
    """verify() solves the run's own model on the refined mesh (det F checked at the run's
    points) and measures that state with the verification's clouds: the exact distance
    equals an Objective of degree 6 on the same state."""
    import shapegrowth.optim.verification as refined

    cfg = sg.load_config(SQUARE, ["objective.hausdorff.quadrature_degree=2"])
    model = sg.build_model(cfg)
    model.state.applied.assign(model.growth.values())
    built: list[sg.Config] = []
    carried = refined.carried_to

    def watched(source, target_cfg):
        built.append(target_cfg)
        return carried(source, target_cfg)

    monkeypatch.setattr(refined, "carried_to", watched)
    v = refined.verify(model, 1)
    assert built[0].objective.hausdorff.quadrature_degree == 2  # the run's model
    fine = carried(model, refined_config(cfg, 1))
    fine.state.solve()
    dense = Objective(verification_clouds(cfg), fine.state)
    assert v.hausdorff == pytest.approx(dense.exact_hausdorff(), rel=1e-9)
    sparse = Objective(cfg, fine.state).exact_hausdorff()
    assert v.hausdorff != pytest.approx(sparse, rel=1e-6)


@pytest.mark.parametrize("degree", [2, 7])
def test_a_lift_is_solved_on_the_3d_config_and_measured_with_the_verification_clouds(degree):
    """A section's lift is solved on the 3D config's verification model (its own clouds)
    and measured with the verification's, as a 3D run's own verification is."""
    solid = sg.load_config(CONFIGS / "beam_wave.yaml",
                           [f"objective.hausdorff.quadrature_degree={degree}"])
    model = verification_model(solid, 2, 2)
    assert model.objective.hausdorff.quadrature_degree == degree
    assert verification_clouds(model).objective.hausdorff.quadrature_degree == max(degree, 6)
    assert model.growth.degree == 2
    assert model.mesh.refine == solid.mesh.refine + solid.optimizer.levels[-1] + 2


def test_the_check_of_a_verification_is_a_third_of_the_way_to_one_percent():
    """Reverified: the finer mesh may move the number by less than a third of its distance
    to 1 % (from above or from below), and says nothing where a solve failed."""
    from shapegrowth.io.records import Reverified

    def second(relative):
        return Verified(None if relative is None else relative * 2.0, relative, 2, 100, 1.0,
                        False, "solved" if relative is not None else "failed: x")

    near = Reverified(0.03, 1, second(0.025))  # 0.5 points of the allowed 0.667
    assert near.moved == pytest.approx(0.005) and near.allowed == pytest.approx(0.02 / 3)
    assert near.settled is True
    assert Reverified(0.03, 1, second(0.0231)).settled is False  # 0.69 points
    below = Reverified(0.009, 1, second(0.0093))  # 0.03 of the allowed 0.033
    assert below.settled is True and Reverified(0.009, 1, second(0.0094)).settled is False
    failed = Reverified(0.03, 1, second(None))
    assert failed.moved is None and failed.settled is None
    assert failed.to_json()["second"] is None and near.to_json()["second_refine"] == 2


@pytest.mark.mpi
def test_verify_checks_a_run_on_its_mesh_refined_once_more(shared_tmp):
    """``shapegrowth verify RUN``: --refine 1 is the run's own verification again (the same
    number to round-off); by default the mesh refined once more, with more DOFs, the check
    computed from both numbers and written to RUN/verify-r2/verify.json."""
    run = shared_tmp / "run"
    assert run_cli("run", SQUARE, "--out", run, "-q", "--set",
                   "optimizer.max_iterations=4") == 0
    own = read_json(run / "summary.json")["verified"]
    assert run_cli("verify", run, "--refine", "1", "--out", shared_tmp / "again", "-q") == 0
    again = read_json(shared_tmp / "again" / "verify.json")
    assert again["verified"]["relative"] == pytest.approx(own["relative"], rel=1e-9)
    assert again["verified"]["dofs"] == own["dofs"]
    assert again["check"]["moved"] < 1e-9 * own["relative"] and again["check"]["settled"]
    assert run_cli("verify", run, "-q") == 0
    twice = read_json(run / "verify-r2" / "verify.json")
    # -q prints nothing; the check's progress is in its folder, a line per load step
    progress = (run / "verify-r2" / "progress.log").read_text().splitlines()
    assert any("load step" in line for line in progress)
    said = [line.split(" ", 2)[2] for line in progress]  # after the date and the time
    assert any(line.startswith("verified on the mesh refined 2 time(s)") for line in said)
    assert said[-1].startswith("wrote") and said[-1].endswith("verify.json")
    v, check = twice["verified"], twice["check"]
    assert v["refine"] == 2 and v["status"] == "solved" and v["dofs"] > 3 * own["dofs"]
    assert (check["first"], check["second"]) == (own["relative"], v["relative"])
    assert check["moved"] == pytest.approx(abs(v["relative"] - own["relative"]), rel=1e-12)
    assert check["allowed"] == pytest.approx(abs(own["relative"] - 0.01) / 3, rel=1e-12)
    assert check["settled"] == (check["moved"] < check["allowed"])
    from shapegrowth.io.summary import verified_from_json

    assert verified_from_json(v).to_json() == v  # read back whole
    assert v["continued_from"] is None
    # --continued: from rest on the mesh refined once, then Newton on the mesh refined twice
    # from that equilibrium: the same equilibrium as from rest there, in fewer iterations
    assert run_cli("verify", run, "--continued", "--out", shared_tmp / "on", "-q") == 0
    on = read_json(shared_tmp / "on" / "verify.json")["verified"]
    assert on["continued_from"] == 1 and on["status"] == "solved"
    assert on["dofs"] == v["dofs"]
    assert on["relative"] == pytest.approx(v["relative"], rel=1e-7)
    assert on["surface"] == pytest.approx(v["surface"], rel=1e-7)
    assert on["stability"]["negative"] == v["stability"]["negative"] == 0
    assert on["stability"]["lowest"][0] == pytest.approx(v["stability"]["lowest"][0], rel=1e-4)
    log = (shared_tmp / "on" / "progress.log").read_text()
    assert "continued from its equilibrium from rest on the mesh refined 1 time(s)" in log


def test_verify_refuses_a_folder_without_a_run_or_without_a_verification(tmp_path, capsys):
    assert run_cli("verify", tmp_path / "none") == 2
    assert "error: verify: " in capsys.readouterr().err
    assert run_cli("run", ARC, "--out", tmp_path, "-q", "--set", "optimizer.max_iterations=1",
                   "--set", "verify.enabled=false") == 0
    assert run_cli("verify", tmp_path) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "verify.enabled false" in err
    # a run stopped before its summary (e.g. in its own verification) is resumed, not verified
    (tmp_path / "summary.json").unlink()
    assert run_cli("verify", tmp_path) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "did not finish" in err
    assert f"shapegrowth run CONFIG --out {tmp_path} --resume" in err
