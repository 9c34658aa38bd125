"""The optimisation driver: a reachable target, MPI agreement, exact resume after SIGKILL,
outputs, and bad input."""

from __future__ import annotations

import csv
import dataclasses
import os
import signal
import subprocess
import time
from pathlib import Path

import numpy as np
import pytest
from conftest import BIN, CONFIGS, ROOT, read_json, run_cli, run_subprocess

import shapegrowth as sg

ARC = CONFIGS / "tiny" / "beam_arc.yaml"
CUBE = CONFIGS / "tiny" / "cube_uniform.yaml"
# the tiny cube as a solid body of degree 2, clamped at one face, its target bent
SOLID_CUBE = ("model.degree=2", "mesh.size=0.25", "boundary.clamp=x1_min",
              "target.map=[x1, x2, 'x3 + 0.1*x1**2']", "objective.hausdorff.alpha=200.0",
              "output.checkpoint_every=1")


def history(out: Path) -> list[dict]:
    with open(out / "history.csv") as fh:
        return [{k: float(v) for k, v in row.items()} for row in csv.DictReader(fh)]


@pytest.mark.slow
def test_reachable_target_is_found(tmp_path):
    """From no growth, designing lambda_1 only: measured 1.7 % relative Hausdorff error
    after 30 MMA iterations (0.45 at the start) on Debian 12's gmsh 4.11 mesh, 2.1 % on
    Debian 13's gmsh 4.13 mesh of the same box (20 of its 240 tetrahedra split otherwise)."""
    assert run_cli("run", ARC, "--out", tmp_path, "-q") == 0
    s = read_json(tmp_path / "summary.json")
    assert s["status"] in ("max_iterations", "converged")
    assert s["hausdorff_initial"] / s["target_size"] > 0.4
    assert s["hausdorff_final"] / s["target_size"] < 0.025
    assert s["rho_H_final"] < 0.2 * s["rho_H_initial"]
    for name in ("history.csv", "history.png", "shape3d.png", "fields.xdmf", "fields.h5",
                 "checkpoint.h5"):
        assert (tmp_path / name).is_file(), name
    rows = history(tmp_path)
    assert len(rows) == s["iterations"] == 30
    assert min(r["objective"] for r in rows) == pytest.approx(s["objective_final"], rel=1e-9)


@pytest.mark.slow
# the three algorithms are NLopt's behind one driver (optim/driver.py): two stand for them
@pytest.mark.parametrize("algorithm", ["mma", "lbfgs"])
def test_serial_and_two_ranks_give_the_same_history(algorithm, tmp_path):
    runs = []
    for ranks in (1, 2):
        out = tmp_path / f"np{ranks}"
        # the history alone is compared: the verification's serial == 2 ranks is
        # tests/test_verify.py's (under mpirun)
        done = run_subprocess(["run", ARC, "--out", out, "-q", "--set",
                               "optimizer.max_iterations=6", "--set",
                               f"optimizer.algorithm={algorithm}", "--set",
                               "verify.enabled=false"], ranks=ranks, timeout=300)
        assert done.returncode == 0, done.stderr
        runs.append([r["objective"] for r in history(out)])
    assert np.allclose(runs[1], runs[0], rtol=1e-6, atol=0)


@pytest.mark.slow
def test_an_alpha_schedule_sharpens_stage_by_stage(tmp_path):
    """alpha [50, 200] on 8 iterations: the first stage takes at most its share (4), the
    second the rest; history.csv records each iteration's alpha, and the run's final J is
    the best of the last stage (values of J at different alphas are not comparable)."""
    assert run_cli("run", ARC, "--out", tmp_path, "-q", "--set", "optimizer.max_iterations=8",
                   "--set", "optimizer.algorithm=lbfgs",
                   "--set", "objective.hausdorff.alpha=[50, 200]") == 0
    rows = history(tmp_path)
    alphas = [r["alpha"] for r in rows]
    assert len(rows) == 8 and alphas[0] == 50.0 and alphas[-1] == 200.0
    assert alphas == sorted(alphas) and 1 <= alphas.count(50.0) <= 4
    s = read_json(tmp_path / "summary.json")
    last = [r["objective"] for r in rows if r["alpha"] == 200.0]
    assert s["objective_final"] == pytest.approx(min(last), rel=1e-9)


@pytest.mark.slow
@pytest.mark.parametrize("rtol_far, cells, linear, extra", [
    # the checkpoint holds the design and the optimiser's state, not the linear solver's:
    # one factorisation besides auto's LU (LDL^T, on a mixed body on hexahedra), where the
    # out-of-core presets' states are LU's (tests/test_linear.py); and the p-multigrid, on a
    # solid cube (a thin beam's multigrid falls back to LU)
    (None, "simplex", "auto", ()), (1e-6, "simplex", "auto", ()), (None, "hex", "auto", ()),
    (None, "hex", "mumps_ldlt", ("material.formulation=mixed",)),
    (None, "simplex", "pmg", SOLID_CUBE)])
def test_resume_after_sigkill_ends_identical(rtol_far, cells, linear, extra, tmp_path):
    """Killed after 3 checkpoints and resumed, a run ends with the uninterrupted one's
    history.  Where the state's tolerance follows the optimiser's progress (solver.rtol_far;
    it comes from the history, replayed steps included) the history agrees to that
    tolerance, not to round-off: the resumed process holds no factors for the tangent
    predictor, so its first warm step reaches the same tolerance by another path (measured
    3.6e-9 apart in J at rtol_far 1e-6).  The same on hexahedra, and for a mixed body (its
    pressure in the checkpointed state), Q2-Q1 on hexahedra by the LDL^T factorisation; and
    a solid cube by the p-multigrid, its MINRES solves to 1e-10."""
    config = CUBE if extra == SOLID_CUBE else ARC
    sets = ["--set", "optimizer.max_iterations=8", "--set", f"mesh.cells={cells}",
            "--set", f"solver.linear={linear}", *[x for e in extra for x in ("--set", e)]]
    if rtol_far is not None:
        sets += ["--set", f"solver.rtol_far={rtol_far}"]
    ref = tmp_path / "uninterrupted"
    assert run_cli("run", config, "--out", ref, "-q", *sets) == 0

    killed = tmp_path / "killed"
    # a killed process leaves its out-of-core factors (mumps_ooc): here, not in /tmp
    env = {**os.environ, "MUMPS_OOC_TMPDIR": str(tmp_path)}
    proc = subprocess.Popen([str(BIN / "shapegrowth"), "run", str(config), "--out", str(killed),
                             "-q", *sets], cwd=ROOT, env=env, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL)
    deadline = time.time() + 240
    while time.time() < deadline and _checkpointed(killed / "checkpoint.h5") < 3:
        time.sleep(0.05)
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    done_before = _checkpointed(killed / "checkpoint.h5")
    assert 3 <= done_before < 8, "the run was not interrupted in the middle"
    assert not (killed / "summary.json").exists()

    assert run_cli("run", config, "--out", killed, "-q", "--resume", *sets) == 0
    a, b = history(ref), history(killed)
    assert [r["iteration"] for r in b] == [r["iteration"] for r in a]
    rel = 1e-10 if rtol_far is None else 1e-7
    assert [r["objective"] for r in b] == pytest.approx([r["objective"] for r in a], rel=rel)
    sa, sb = read_json(ref / "summary.json"), read_json(killed / "summary.json")
    assert sb["objective_final"] == pytest.approx(sa["objective_final"], rel=rel)
    assert sb["resumed"] and not sa["resumed"]
    if linear == "pmg":  # the multigrid's own states, none by the exact fallback
        assert sa["linear_solver"]["preset"] == "pmg"
        assert sa["linear_solver"]["fallbacks"] == sb["linear_solver"]["fallbacks"] == 0


def _checkpointed(path: Path) -> int:
    from shapegrowth import compat

    h5py = compat.h5py()
    try:
        with h5py.File(path, "r") as h5:
            return len(h5["f"])
    except (OSError, KeyError):
        return 0


@pytest.mark.slow
def test_the_stopping_test_stops_a_reachable_arc_at_its_floor(tmp_path):
    """The reachable quarter arc at t/L = 1/25 with every optimizer default (docs/VERIFICATION.md,
    "Where the stopping test stops"): NLopt's one-step test stopped it converged after 84
    iterations at 0.444 % verified, the old default budget of 100 at 0.371 %; the window's
    test lets it reach its floor before the default budget (measured: converged after 354
    iterations at 0.0845 % verified, the known growth's own level 0.083 %)."""
    from shapegrowth.config import OptimizerConfig

    text = (CONFIGS / "reachable" / "bend.yaml").read_text()
    config = tmp_path / "bend.yaml"
    config.write_text("\n".join(line for line in text.splitlines()
                                if not line.startswith("optimizer:")))
    assert run_cli("run", config, "--out", tmp_path / "run", "-q",
                   "--set", "geometry.thickness=0.04", "--set", "objective.hausdorff.alpha=100",
                   "--set", f"mesh.cache_dir={CONFIGS.parent / 'meshes'}") == 0
    s = read_json(tmp_path / "run" / "summary.json")
    assert s["status"] == "converged"
    assert 200 < s["iterations"] < OptimizerConfig().max_iterations
    assert s["verified"]["relative"] < 0.001


def test_failed_state_solve_ends_the_run_with_the_best_design(tmp_path):
    """Newton limited to 2 iterations and load steps to >= 0.3: the first real design
    change cannot be solved, also not on the retry from rest."""
    code = run_cli("run", ARC, "--out", tmp_path, "-q", "--set", "optimizer.max_iterations=5",
                   "--set", "solver.max_newton_iterations=2",
                   "--set", "solver.continuation.min_step=0.3",
                   "--set", "solver.continuation.initial_step=0.5")
    s = read_json(tmp_path / "summary.json")
    assert code == 1
    assert s["status"].startswith("failed: state solve failed at iteration 1")
    assert s["iterations"] == 1
    assert s["objective_final"] == pytest.approx(s["objective_initial"], rel=1e-12)  # the best
    for name in ("history.csv", "fields.xdmf", "checkpoint.h5"):
        assert (tmp_path / name).is_file()


def test_run_fields_hold_phi_and_the_filtered_growth(tmp_path):
    from shapegrowth import compat

    h5py = compat.h5py()

    assert run_cli("run", ARC, "--out", tmp_path, "-q", "--set", "optimizer.max_iterations=2",
                   "--set", "growth.filter_length=0.05") == 0
    with h5py.File(tmp_path / "fields.h5") as h5:
        names = set(h5["Function"])
    assert {"Phi", "displacement", "lambda_hat_1", "lambda_hat_2", "lambda_hat_3",
            "v_1", "v_2", "v_3"} <= names
    assert (tmp_path / "shape.png").stat().st_size > 10000  # the deformed body and target


@pytest.mark.mpi
def test_a_2d_run_draws_its_plane_on_two_ranks(shared_tmp):
    """The square (free frame): shape.png, and frame.png with the eigenvector glyphs; its
    best growth solved again from rest reaches the optimiser's equilibrium (one branch)."""
    assert run_cli("run", CONFIGS / "tiny" / "square_disk.yaml", "--out", shared_tmp, "-q",
                   "--set", "optimizer.max_iterations=2") == 0
    assert (shared_tmp / "shape.png").stat().st_size > 10000
    assert (shared_tmp / "frame.png").stat().st_size > 10000
    s = read_json(shared_tmp / "summary.json")
    assert s["hausdorff_from_rest"] == pytest.approx(s["hausdorff_final"], rel=1e-5)
    assert s["rho_H_from_rest"] == pytest.approx(s["rho_H_final"], rel=1e-5)


def test_resume_without_checkpoint_is_bad_input(tmp_path, capsys):
    assert run_cli("run", ARC, "--out", tmp_path, "--resume") == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "no checkpoint" in err[0]


BAD = {
    "misspelt key": ("geometry.lenght", ["--set", "geometry.lenght=1"], "--set geometry.lenght"),
    "negative length": ("geometry.length", ["--set", "geometry.length=-1"], "geometry.length"),
    "reversed bounds": ("bounds", ["--set", "growth.eigenvalues.bounds=[12, 0.01]"],
                        "growth.eigenvalues.bounds"),
    "unknown frame": ("frame", ["--set", "growth.frame=polar"], "growth.frame"),
    "wrong type": ("size", ["--set", "mesh.size=fine"], "mesh.size"),
    "initial outside bounds": ("initial", ["--set", "growth.eigenvalues.initial=[0, 1, 1]"],
                               "growth.eigenvalues.initial[0]"),
    "expression calling Python": (
        "expr", ["--set", "growth.eigenvalues.initial=[\"__import__('os').getcwd()\", 1, 1]"],
        "growth.eigenvalues.initial[0]"),
    "bad probe": ("probe", ["--probe", "1,x,0"], "--probe"),
    "rtol_far tighter than rtol": ("rtol_far", ["--set", "solver.rtol_far=1e-13"],
                                   "solver.rtol_far"),
}


@pytest.mark.parametrize("case", list(BAD))
def test_bad_input_is_one_line_naming_the_key(case, tmp_path, capsys):
    _, extra, key = BAD[case]
    command = "solve" if "--probe" in extra else "run"
    code = run_cli(command, ARC, "--out", tmp_path, *extra)
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2
    assert len(err) == 1 and err[0].startswith(f"error: {key}"), err
    assert not (tmp_path / "summary.json").exists()


def test_broken_yaml_and_missing_file_through_the_cli(tmp_path, capsys):
    broken = tmp_path / "broken.yaml"
    broken.write_text("name: [oops\n")
    assert run_cli("run", broken) == 2
    assert run_cli("run", tmp_path / "missing.yaml") == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err[0].startswith("error: config: broken YAML") and "line" in err[0]
    assert err[1] == f"error: config: file '{tmp_path / 'missing.yaml'}' not found"


@pytest.mark.slow
def test_a_non_finite_objective_never_reaches_the_optimiser(tmp_path, monkeypatch):
    """The guard: NaN at iteration 2 ends the run loudly, with the best design kept."""
    from shapegrowth.optim.problem import ReducedFunctional

    real = ReducedFunctional.evaluate
    calls = {"n": 0}

    def poisoned(self, m, gradient=True):
        ev = real(self, m, gradient)
        calls["n"] += 1
        if calls["n"] == 3:
            ev.value.total = float("nan")
        return ev

    monkeypatch.setattr(ReducedFunctional, "evaluate", poisoned)
    code = run_cli("run", ARC, "--out", tmp_path, "-q", "--set", "optimizer.max_iterations=6")
    s = read_json(tmp_path / "summary.json")
    assert code == 1
    assert s["status"].startswith("failed: non-finite objective at iteration 2")
    assert s["iterations"] == 2 and np.isfinite(s["objective_final"])


@pytest.mark.slow
def test_nlopts_own_failure_ends_the_stage_with_its_best_design(tmp_path, monkeypatch):
    """NLopt's L-BFGS reports a line search that finds no decrease as a generic
    RuntimeError ("nlopt failure", disk_cone at iteration 80): the run keeps its best design,
    ends converged and loses nothing.  Here the failure is raised at the 4th evaluation."""
    from shapegrowth.optim.driver import Driver

    real = Driver._objective
    calls = {"n": 0}

    def fails(self, x, grad):
        calls["n"] += 1
        if calls["n"] == 4:
            raise RuntimeError("nlopt failure")
        return real(self, x, grad)

    monkeypatch.setattr(Driver, "_objective", fails)
    code = run_cli("run", ARC, "--out", tmp_path, "-q", "--set", "optimizer.max_iterations=8")
    s = read_json(tmp_path / "summary.json")
    assert code == 0 and s["status"] == "converged" and s["iterations"] == 3
    rows = history(tmp_path)
    assert s["objective_final"] == pytest.approx(min(r["objective"] for r in rows), rel=1e-8)
    assert (tmp_path / "fields.xdmf").is_file()


def _adjoint_breaks_down_at(monkeypatch, call: int) -> None:
    """The adjoint solve fails, as an iterative solver that breaks down would, at its
    ``call``-th call (1-based) and works otherwise."""
    from shapegrowth.optim.adjoint import AdjointProblem, AdjointSolveError

    real = AdjointProblem.solve
    calls = {"n": 0}

    def breaks_down(self, *args):
        calls["n"] += 1
        if calls["n"] == call:
            raise AdjointSolveError("adjoint solve failed (KSP reason -5)")
        return real(self, *args)

    monkeypatch.setattr(AdjointProblem, "solve", breaks_down)


# slow (8.5 s): the fast tier's failed solve ending a run is the state's, above, and the
# failed adjoint's fall-back is test_linear's
@pytest.mark.slow
def test_a_failed_adjoint_solve_ends_the_run_reported(tmp_path, monkeypatch):
    """An iterative adjoint solver that breaks down (seen with GAMG on a thin beam) ends the
    run with its reason and the best design, not with a traceback."""
    _adjoint_breaks_down_at(monkeypatch, 2)
    code = run_cli("run", ARC, "--out", tmp_path, "-q", "--set", "optimizer.max_iterations=6")
    s = read_json(tmp_path / "summary.json")
    assert code == 1
    assert s["status"] == "failed: at iteration 1: adjoint solve failed (KSP reason -5)"
    assert s["iterations"] == 1 and (tmp_path / "fields.xdmf").is_file()


@pytest.mark.slow
def test_a_failed_run_solves_its_best_design_again_from_rest(tmp_path, monkeypatch):
    """The adjoint breaks down at iteration 2, after iteration 1 (the best design) was the
    last one evaluated: the final state is that design solved from rest, not the cached
    evaluation over a state reset to zero, so the summary's shape and the shape from rest
    agree (the arc has one equilibrium) and the fields hold a deformed body."""
    from shapegrowth import compat

    h5py = compat.h5py()

    _adjoint_breaks_down_at(monkeypatch, 3)
    assert run_cli("run", ARC, "--out", tmp_path, "-q",
                   "--set", "optimizer.max_iterations=6") == 1
    s = read_json(tmp_path / "summary.json")
    assert s["status"].startswith("failed: at iteration 2")
    assert s["objective_final"] < s["objective_initial"]  # the best design is not the start
    assert s["hausdorff_from_rest"] == pytest.approx(s["hausdorff_final"], rel=1e-6)
    with h5py.File(tmp_path / "fields.h5") as h5:
        u = np.asarray(next(iter(h5["Function"]["displacement"].values())))
    assert np.abs(u).max() > 0.1


@pytest.mark.slow
def test_reproduce_writes_results_from_the_run_folders(tmp_path):
    """scripts/reproduce.py: the two square runs, the table with the fixed/free ratio, the
    figures, the refined-twice check (--twice); a second call reads the finished runs and
    checks back instead of running them."""
    import json
    import sys

    cmd = [sys.executable, str(ROOT / "scripts" / "reproduce.py"), "--ranks", "1", "--twice",
           "--only", "square_circle_fixed,square_circle_free", "--out", str(tmp_path / "runs"),
           "--results", str(tmp_path / "RESULTS.md"), "--set", "optimizer.max_iterations=2",
           "--set", "mesh.size=1.0"]
    first = subprocess.run(cmd, capture_output=True, text=True, cwd=ROOT)
    assert first.returncode == 0, first.stderr
    text = (tmp_path / "RESULTS.md").read_text()
    # each row leads with the verified number, the self-reported one beside it
    import re

    row = re.search(r"\| 6 \| square_circle_free \| 2D plane strain, free frame \| "
                    r"\*\*(\d+\.\d\d) %\*\* \| (\d+\.\d\d) % \| refined x1, from rest, "
                    r"(\d+) DOFs \| (\d+\.\d\d) % \(x2, (\d+) DOFs\): moved (\d+\.\d\d) of "
                    r"(\d+\.\d\d) points, (settled|\*\*not settled\*\*) \| (\d+\.\d\d) % \|", text)
    assert row, text
    verified, surface, dofs, second, second_dofs, moved, _, verdict, _ = row.groups()
    free = json.loads((tmp_path / "runs" / "square_circle_free" / "summary.json").read_text())
    assert float(verified) == pytest.approx(100 * free["verified"]["relative"], abs=0.006)
    # the same state, boundary to boundary
    assert float(surface) == pytest.approx(100 * free["verified"]["surface"], abs=0.006)
    assert int(dofs) == free["verified"]["dofs"] > free["dofs"]["state"]
    twice = json.loads((tmp_path / "runs" / "square_circle_free" / "verify-r2" /
                        "verify.json").read_text())
    assert float(second) == pytest.approx(100 * twice["verified"]["relative"], abs=0.006)
    assert int(second_dofs) == twice["verified"]["dofs"] > 3 * int(dofs)
    assert float(moved) == pytest.approx(100 * twice["check"]["moved"], abs=0.006)
    assert (verdict == "settled") == twice["check"]["settled"]
    assert "not run" in text  # the others
    # the extra measurements not made are named, not tabled
    assert "Not in this reproduction: beam_wave_from_2d" in text
    assert "| beam_wave_from_2d |" not in text
    took = re.search(r"The 2 runs of this reproduction took \*\*(\d+) min\*\*", text)
    fixed = json.loads((tmp_path / "runs" / "square_circle_fixed" / "summary.json").read_text())
    assert took and int(took[1]) == round((free["wall_time_s"] + fixed["wall_time_s"]) / 60)
    assert "The 2 refined-twice checks (`--twice`) took " in text
    assert "rho_H(square_circle_fixed) / rho_H(square_circle_free) = **" in text
    assert "Second, above the floor rho_H(T, T) = " in text  # two iterations: far above it
    assert "a floor 10 % lower or higher moves it across" in text
    # the readings: each of scenes 1-5 with its printed target's floor beside the reading
    assert "## On the printed targets and on the readings" in text
    assert "| 2 | (5.15): the mid-line ring about the origin |" in text
    assert (tmp_path / "img" / "results" / "square_circle_free_shape.png").is_file()
    again = subprocess.run(cmd, capture_output=True, text=True, cwd=ROOT)
    assert again.returncode == 0 and "reproduce: square" not in again.stdout
    assert (tmp_path / "RESULTS.md").read_text() == text


def _reproduce_module():
    import importlib.util
    import sys

    spec = importlib.util.spec_from_file_location("reproduce", ROOT / "scripts" / "reproduce.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules["reproduce"] = module  # its dataclasses look their module up
    spec.loader.exec_module(module)
    return module


def test_reproduce_runs_the_restarts_only_when_asked():
    """Each scene's other model, the 3D restarts from a section's optimum and the 3D cube are
    measurements: not in the default set (one run per scene 1-5, on the model that wins, and
    the two squares), the other models with --models, the cube's with --cube, all of them
    with --all, and each can be named."""
    reproduce = _reproduce_module()
    models = {"beam_wave", "beam_ring", "disk_cone_axi", "cylinder_flare"}
    restarts = {"beam_wave_from_2d", "disk_cone_from_axi", "cylinder_flare_from_axi"}
    cube = {"cube_cylinder_fixed", "cube_cylinder_free", "cube_cylinder_fixed_uniform",
            "cube_cylinder_free_staged"}
    every = {scene.name for scene in reproduce.SCENES}
    assert {scene.name for scene in reproduce.SCENES if scene.extra} == models | restarts | cube
    # every group of extra measurements is named in RESULTS.md when not made
    assert {scene.group for scene in reproduce.SCENES if scene.extra} == set(reproduce.NOT_RUN)
    default = reproduce.selected(set(), False)
    assert {scene.name for scene in default} == every - models - restarts - cube
    assert [scene.number for scene in default] == [1, 2, 3, 4, 5, 6, 6]
    assert {scene.name for scene in reproduce.selected(set(), False, cube=True)} == \
        every - models - restarts
    assert {scene.name for scene in reproduce.selected(set(), False, models=True)} == \
        every - restarts - cube
    assert {scene.name for scene in reproduce.selected(set(), True)} == every
    assert [s.name for s in reproduce.selected({"disk_cone_from_axi"}, False)] == [
        "disk_cone_from_axi"]
    # each cube run is a shipped config with the paper's frames, the pairs share the rest
    configs = {scene.name: sg.load_config(CONFIGS / f"{scene.config}.yaml")
               for scene in reproduce.SCENES if scene.group == "cube"}
    for fixed, free, _ in reproduce.CUBE_PAIRS:
        a, b = configs[fixed], configs[free]
        assert (a.growth.frame, b.growth.frame) == ("cartesian", "free")
        assert a.model.dim == b.model.dim == 3 and a.mesh == b.mesh
        assert a.objective == b.objective and a.optimizer == b.optimizer


def _fake_run(folder: Path, rho_h: float, verified: float, *, config: Path | None = None,
              state_dofs: int = 100, target_size: float = 1.0) -> None:
    """A finished run's summary.json with the numbers given (its distances in proportion to
    ``verified``, so two runs scaled alike compare alike), and ``config``'s own config."""
    import json

    summary = {
        "dofs": {"state": state_dofs, "design": 10}, "iterations": 300,
        "status": "max_iterations", "rho_H_final": rho_h, "rho_H_from_rest": rho_h,
        "hausdorff_final": 0.6 * verified * target_size,
        "hausdorff_from_rest": 0.8 * verified * target_size, "residual_strain": 10 * verified,
        "target_size": target_size, "evaluations": 300, "resumed": False,
        "wall_time_s": 60.0, "mpi_size": 2,
        "verified": {"hausdorff": target_size * verified, "relative": verified, "refine": 1,
                     "dofs": 8 * state_dofs, "wall_s": 1.0, "branch_changed": False,
                     "status": "solved"}}
    if config is not None:
        summary["config"] = sg.load_config(config).to_dict()
    folder.mkdir(parents=True)
    folder.joinpath("summary.json").write_text(json.dumps(summary))


def test_reproduce_says_where_self_reported_and_refined_part(tmp_path):
    """RESULTS.md's per-scene line: the self-reported number against the run's own mesh
    refined once, within 1.3x either way or apart by more (where the optimum leans on its
    mesh, or its clouds over-read it)."""
    reproduce = _reproduce_module()
    # _fake_run: self-reported 0.6 x verified, so the refined number reads 1 / 0.6 = 1.67x it
    _fake_run(tmp_path / "apart", 0.01, 0.02)
    apart = reproduce.finished(tmp_path / "apart")
    assert apart.relative_error == pytest.approx(0.012)
    assert reproduce._mesh_ratio(apart) == pytest.approx(1 / 0.6)
    assert reproduce._outside(apart)
    assert "1.67x, apart by more than 1.3x" in reproduce._agreement(apart)
    close = dataclasses.replace(
        apart, verified=dataclasses.replace(apart.verified, relative=0.96 * 0.012))
    assert not reproduce._outside(close) and "0.96x, within 1.3x" in reproduce._agreement(close)
    below = dataclasses.replace(
        apart, verified=dataclasses.replace(apart.verified, relative=0.012 / 1.4))
    assert reproduce._outside(below)
    # no self-reported number: nothing said
    assert reproduce._agreement(dataclasses.replace(apart, hausdorff_final=0.0)) == ""


def test_results_md_says_which_numbers_are_on_a_reading():
    """docs/RESULTS.md's readings section is the generator's, made from its own table: for
    scenes 2-5 the printed target's floor and best verified number beside the reading's,
    and the headline sentence says "on the project's readings"."""
    reproduce = _reproduce_module()
    text = (ROOT / "docs" / "RESULTS.md").read_text()
    assert reproduce.with_readings(text) == text
    verified = reproduce.tabled_verified(text)
    assert sorted(verified) == [1, 2, 3, 4, 5]
    assert "on the project's readings** of scenes 2, 3, 4, 5" in text
    for number in (2, 5):  # a printed target without thickness: its floor above 1 %
        assert "**" in reproduce.READINGS[number].floor


def test_reproduce_tables_the_cube_beside_the_square(tmp_path):
    """RESULTS.md: the 3D cube's fixed/free ratio from each start, raw and above the cube's
    own floor rho_H(T, T), beside the paper's and the square's; a free frame that ends worse
    verified is said so; runs not made are named, not tabled."""
    import re

    reproduce = _reproduce_module()
    out = tmp_path / "runs"
    with_coarse = tmp_path / "configs"
    with_coarse.mkdir()
    for name in ("cube_cylinder_fixed", "cube_cylinder_free"):  # the cube's floor, cheaply
        text = (CONFIGS / f"{name}.yaml").read_text().replace("size: 0.67", "size: 2.0")
        with_coarse.joinpath(f"{name}.yaml").write_text(text)
    for name, rho_h, verified in (("cube_cylinder_fixed", 0.2, 0.098),
                                  ("cube_cylinder_free", 0.1, 0.028)):
        _fake_run(out / name, rho_h, verified, config=with_coarse / f"{name}.yaml",
                  target_size=12.0)
    rows = [(scene, reproduce.finished(out / scene.name)) for scene in reproduce.SCENES]
    text = reproduce.results_markdown(rows, out, tmp_path / "img")
    floor = reproduce.target_floor(reproduce.finished(out / "cube_cylinder_fixed"))
    assert 0 < floor < 0.1
    line = re.search(r"- from the target's metric: rho_H 0.2 fixed, 0.1 free, ratio \*\*2\*\*; "
                     r"above the floor rho_H\(T, T\) = ([0-9.e-]+): ([0-9.]+) \(a floor 10 % "
                     r"lower or higher moves it across ([0-9.]+)-([0-9.]+)\) "
                     r"\(verified 9.80 % fixed, 2.80 % free; the free frame ends no worse, "
                     r"verified\)", text)
    assert line, text
    assert float(line[2]) == pytest.approx((0.2 - floor) / (0.1 - floor), rel=1e-3)
    assert float(line[3]) == pytest.approx((0.2 - 0.9 * floor) / (0.1 - 0.9 * floor), rel=1e-2)
    assert float(line[4]) == pytest.approx((0.2 - 1.1 * floor) / (0.1 - 1.1 * floor), rel=1e-2)
    assert "beside the paper's 13.8889" in text
    assert "| 6 | cube_cylinder_free | 3D cube, free frame (three angles) | **2.80 %** |" in text
    assert "Not in this reproduction: cube_cylinder_fixed_uniform, cube_cylinder_free_staged" \
        in text and "from the uniform growth" not in text
    # the free frame contains the fixed one: ending worse verified is flagged
    (out / "cube_cylinder_free" / "summary.json").unlink()
    (out / "cube_cylinder_free").rmdir()
    _fake_run(out / "cube_cylinder_free", 0.1, 0.12,
              config=with_coarse / "cube_cylinder_free.yaml", target_size=12.0)
    rows = [(scene, reproduce.finished(out / scene.name)) for scene in reproduce.SCENES]
    assert "the free frame ends **worse**, verified" in reproduce.results_markdown(
        rows, out, tmp_path / "img")


def test_reproduce_says_beside_a_verified_number_which_branch_it_is_on():
    """RESULTS.md: an unstable state is flagged; a stable one reached by switching branch
    says where it left the path from rest; one on the path from rest says nothing."""
    from shapegrowth.physics.stability import Stability

    reproduce = _reproduce_module()
    assert reproduce._unstable(Stability((0.1,), 0)) == ""
    assert reproduce._unstable(None) == ""
    unstable = Stability((-0.3,), 4, lost_at=1.0, kind="bifurcation")
    assert reproduce._unstable(unstable) == ", **unstable** since 1 of the growth"
    switched = Stability((4.6e-6,), 0, lost_at=1.0, kind="bifurcation", branch="switched",
                         switched_at=1.0)
    assert reproduce._unstable(switched) == (
        ", on the stable branch it switched to at 1 of the growth")


def test_reproduce_compare_flags_a_difference_beyond_the_tolerance(tmp_path):
    """--compare: two reproductions that differ by 1 % agree at rtol 5 % and not at 0.5 %; a
    different problem size never agrees; a missing run is reported, not skipped."""
    reproduce = _reproduce_module()

    def write(out: Path, scale: float, state_dofs: int = 100) -> None:
        for scene in reproduce.SCENES:
            _fake_run(out / scene.name, 2.0 * scale, 0.05 * scale, state_dofs=state_dofs)

    write(tmp_path / "a", 1.0)
    write(tmp_path / "b", 1.01)
    write(tmp_path / "c", 1.0, state_dofs=101)
    text, agree = reproduce.compare(tmp_path / "a", tmp_path / "b", rtol=0.05)
    assert agree and "**no**" not in text and "| square | fixed / free ratio | 1 | 1 | 0.0e+00 | yes |" in text
    assert not reproduce.compare(tmp_path / "a", tmp_path / "b", rtol=0.005)[1]
    text, agree = reproduce.compare(tmp_path / "a", tmp_path / "c", rtol=0.05)
    assert not agree and text.count("| **no** |") == len(reproduce.SCENES)  # the state DOFs
    (tmp_path / "b" / "beam_ring" / "summary.json").unlink()
    text, agree = reproduce.compare(tmp_path / "a", tmp_path / "b", rtol=0.05)
    assert not agree and "| beam_ring | finished | True | False |" in text
    assert "| beam_wave | verified | 0.05 | 0.0505 | 9.9e-03 | yes |" in text
    # the headline in points: 5.00 % against 5.05 % is 0.05 points, within 0.3
    assert "| beam_wave | 5.00 % | 5.05 % | 0.05 | yes |" in text
    runs = {name: (reproduce.finished(tmp_path / "a" / name),
                   reproduce.finished(tmp_path / "c" / name)) for name in ("beam_wave",)}
    assert reproduce.headline_spread(runs)[1]
    write(tmp_path / "d", 1.1)  # 5.0 % against 5.5 %: 0.5 points
    runs = {"beam_wave": (reproduce.finished(tmp_path / "a" / "beam_wave"),
                          reproduce.finished(tmp_path / "d" / "beam_wave"))}
    lines, within = reproduce.headline_spread(runs)
    assert not within and "| beam_wave | 5.00 % | 5.50 % | 0.50 | **no** |" in lines


def test_the_state_tolerance_follows_the_optimisers_progress():
    """solver.rtol_far: rtol x progress / ftol_rel, clipped: tight at and below the stopping
    test's change, loose (up to rtol_far) where J still changes by much per step; the
    problem receives it after each evaluation from the second on.  Measured on
    disk_cone_axi, progress relative to |J| alone left the debiased J (1e-5 near the
    optimum) at rtol_far to the end: its second level stopped after 9 evaluations."""
    from shapegrowth.optim.callbacks import ProgressTolerance

    class Problem:
        def __init__(self) -> None:
            self.rtols: list[float | None] = []

        def stopping_scale(self) -> float:
            return 0.0

        def set_warm_rtol(self, rtol: float | None) -> None:
            self.rtols.append(rtol)

    problem = Problem()
    cb = ProgressTolerance(problem, rtol=1e-11, rtol_far=1e-6, ftol_rel=1e-8)  # type: ignore
    assert cb.tolerance(1.0, 1.0 - 1e-9) == 1e-11  # below ftol_rel: the configured rtol
    assert cb.tolerance(1.0, 1.0 - 1e-5) == pytest.approx(1e-8, rel=1e-5)
    assert cb.tolerance(0.5, 1.0) == 1e-6  # far: rtol_far
    assert cb.tolerance(-2e-3, -1e-3) == 1e-6  # the relative change of either sign
    # the debiased J tends to 0: progress relative to the stopping test's scale rho_H(T, T)
    assert cb.tolerance(2e-5, 1e-5) == 1e-6
    assert cb.tolerance(2e-5 + 1e-9, 2e-5, scale=1e-2) == pytest.approx(1e-10, rel=1e-5)
    from shapegrowth.optim.interface import Record, Step

    def step(k: int, objective: float) -> Step:
        r = Record(k, objective, objective, 0.0, 0.0, 1.0, 4, 0.0, 100.0, 0.0)
        return Step(k, np.zeros(1), objective, np.zeros(1), r, np.zeros(1), False)

    for k, j in enumerate([1.0, 0.9, 0.9 * (1 - 1e-7)]):
        cb.evaluated(step(k, j))
    assert problem.rtols == [1e-6, pytest.approx(1e-10, rel=1e-5)]


@pytest.mark.mpi
def test_a_free_frame_starts_from_a_fixed_frame_run(shared_tmp):
    """growth.start: run: a fixed frame's best eigenvalues start the free frame at angle 0,
    where its frame is the fixed one: the free run's first objective is the fixed run's
    best to round-off, and it only goes down from there (what breaks the symmetry
    dJ/dtheta = 0 of an isotropic start)."""
    square = CONFIGS / "tiny" / "square_disk.yaml"
    fixed, free = shared_tmp / "fixed", shared_tmp / "free"
    common = ["--set", "verify.enabled=false", "--set", "optimizer.max_iterations=6", "-q"]
    assert run_cli("run", square, "--out", fixed, "--set", "growth.frame=cartesian",
                   "--set", "growth.angles.initial=null", *common) == 0
    assert run_cli("run", square, "--out", free, "--set", "growth.start=run",
                   "--set", f"growth.from_run={fixed}", "--set", "growth.angles.initial=[0.0]",
                   *common) == 0
    best_fixed = min(r["objective"] for r in history(fixed))
    rows = history(free)
    assert rows[0]["objective"] == pytest.approx(best_fixed, rel=1e-9)
    assert min(r["objective"] for r in rows) < best_fixed


def test_reproduce_compare_keeps_the_sections_measured_by_hand():
    """--compare rewrites the report above docs/REPRODUCIBILITY.md's KEPT line and keeps the
    measured comparisons below it (before, it wrote the report over the whole file)."""
    reproduce = _reproduce_module()
    previous = ("# Reproducibility\n\nold table\n\n" + reproduce.KEPT +
                "\n\n## The eleventh reproduction against the tenth\n\nmeasured\n")
    text = reproduce.with_kept("# Reproducibility\n\nnew table\n", previous)
    assert "new table" in text and "old table" not in text
    assert text.endswith(reproduce.KEPT + "\n\n## The eleventh reproduction against the "
                         "tenth\n\nmeasured\n")
    assert reproduce.with_kept("new\n", "no such line") == "new\n"
    shipped = (ROOT / "docs" / "REPRODUCIBILITY.md").read_text()
    assert shipped.count(reproduce.KEPT) == 1


def test_reproduce_says_what_a_cube_row_s_missing_check_takes(tmp_path):
    """A cube row whose refined-twice check is not made says what it takes (x2's DOFs, the
    time the checks made took, or from rest where the carried start is no start) and the
    command that makes it, where a row without a measured limit says only `--twice`."""
    from types import SimpleNamespace

    reproduce = _reproduce_module()
    verified_once = SimpleNamespace(verified=SimpleNamespace(refine=1))
    for scene in reproduce.SCENES:
        cell = reproduce._twice(scene, tmp_path / scene.name, verified_once)
        if scene.group == "cube":
            assert "352 947 DOFs" in cell
            if scene.twice_limit:  # run only when named
                assert "1-2 h" in cell and "`--only NAME --twice`" in cell
            else:
                assert "`--cube --twice`" in cell
        else:
            assert "--cube" not in cell
