"""The linear solver presets (``solver.linear``, physics/linear.py): each reaches the state
that MUMPS LU reaches, each gives gradients with Taylor rates > 1.9, ``auto`` chooses by the
model's size, a missing package degrades with one line, and a failed preset solve falls back
to the exact factorisation, is logged and counted in summary.json."""

from __future__ import annotations

import logging
import os
import subprocess
import sys

import numpy as np
import pytest
from conftest import CONFIGS, ROOT, read_json, run_cli
from mpi4py import MPI

from shapegrowth.config import ConfigError, load
from shapegrowth.config.numerics import SolverConfig
from shapegrowth.physics import linear

BEND = CONFIGS / "tiny" / "beam_bend.yaml"
BEAM = CONFIGS / "tiny" / "beam_wave.yaml"
CUBE = CONFIGS / "tiny" / "cube_uniform.yaml"
SQUARE = CONFIGS / "tiny" / "square_disk.yaml"
# the fast tier bends the beam with LDL^T; out of core and block low-rank (4.3 and 3.8 s on a
# fresh clone, each its own MUMPS set-up) run in the slow tier
DIRECT = ("mumps_ldlt", pytest.param("mumps_ooc", marks=pytest.mark.slow),
          pytest.param("mumps_blr", marks=pytest.mark.slow))


def test_the_config_offers_every_preset_and_auto():
    import dataclasses

    field = next(f for f in dataclasses.fields(SolverConfig) if f.name == "linear")
    assert tuple(field.metadata["choices"]) == linear.CHOICES


def _probes(out) -> np.ndarray:
    return np.array([p["deformed"] for p in read_json(out / "summary.json")["probes"]])


@pytest.mark.mpi
@pytest.mark.parametrize("preset", DIRECT)
def test_a_direct_preset_bends_the_thin_beam_as_lu_does(preset, shared_tmp):
    """The compatible bend kappa L = pi/2 (a quarter arc) of the thin P2 beam: the LDL^T
    factorisation and its compressed variant under GMRES land where LU lands, to Newton's
    tolerance, without a fallback."""
    sets = ["--set", "parameters.kappa=1.5707963", "--probe", "1,0,0", "--probe", "0.5,0.05,0.01"]
    results = []
    for name in ("mumps", preset):
        out = shared_tmp / name
        assert run_cli("solve", BEND, "--out", out, "-q", "--set", f"solver.linear={name}",
                       *sets) == 0
        results.append(_probes(out))
        use = read_json(out / "summary.json")["linear_solver"]
        assert use["preset"] == name and use["fallbacks"] == 0
    assert results[1] == pytest.approx(results[0], abs=1e-9)


@pytest.mark.mpi
# on Q2 hexahedra both stall (1000 GMRES iterations) and fall back to LU: docs/PERFORMANCE.md
@pytest.mark.simplex
# slow (8.6 and 9.9 s): the fast tier's multigrid check is test_state's
# test_gamg_gives_the_mumps_solution
@pytest.mark.slow
@pytest.mark.parametrize("preset", ["gamg", "hypre"])
def test_a_multigrid_preset_solves_a_chunky_body_as_lu_does(preset, shared_tmp):
    """A stretched, sheared P2 cube (where algebraic multigrid with the rigid-body modes
    holds; on the thin beam it does not, and falls back: docs/PERFORMANCE.md)."""
    sets = ["--set", "model.degree=2", "--set", "mesh.size=0.25",
            "--set", "loads.traction={x1_max: [0.3, 0.1, 0], x1_min: [-0.3, -0.1, 0]}",
            "--set", "growth.eigenvalues.initial=[1.2, 0.9, 1.0]",
            "--probe", "0.5,0.5,0.5", "--probe", "-0.5,0.2,0.1"]
    results = []
    for name in ("mumps", preset):
        out = shared_tmp / name
        assert run_cli("solve", CUBE, "--out", out, "-q", "--set", f"solver.linear={name}",
                       *sets) == 0
        results.append(_probes(out))
        assert read_json(out / "summary.json")["linear_solver"]["fallbacks"] == 0
    assert results[1] == pytest.approx(results[0], abs=1e-8)


@pytest.mark.mpi
def test_the_p_multigrid_grows_a_clamped_cube_as_lu_does(shared_tmp):
    """A P2 (Q2 on the hex leg) cube clamped at one end, its growth varying across it and a
    traction on the other end: the p-multigrid's state is LU's, with no fallback, in few
    MINRES iterations per Newton step (measured: 32 on tetrahedra, 24 on hexahedra)."""
    sets = ["--set", "model.degree=2", "--set", "mesh.size=0.25",
            "--set", "boundary.clamp=x1_min",
            "--set", "loads.traction={x1_max: [0.0, 0.1, 0.05]}",
            "--set", "growth.eigenvalues.initial=['1.2 + 0.3*x2', 0.9, 1.0]",
            "--probe", "0.5,0.5,0.5", "--probe", "0.5,-0.2,0.1"]
    results = []
    for name in ("mumps", "pmg"):
        out = shared_tmp / name
        assert run_cli("solve", CUBE, "--out", out, "-q", "--set", f"solver.linear={name}",
                       *sets) == 0
        results.append(_probes(out))
    assert results[1] == pytest.approx(results[0], abs=1e-9)
    use = read_json(shared_tmp / "pmg" / "summary.json")["linear_solver"]
    assert use["preset"] == "pmg" and use["fallbacks"] == 0
    assert use["krylov_solves"] > 0 and use["krylov_iterations"] < 60 * use["krylov_solves"]
    assert read_json(shared_tmp / "mumps" / "summary.json")["linear_solver"]["krylov_solves"] == 0


@pytest.mark.mpi
def test_taylor_rate_with_the_p_multigrid_on_a_solid_cube(shared_tmp):
    """The state, a fresh adjoint and the filter with the p-multigrid preset on a clamped P2
    (Q2) cube against a bent target: the reduced gradient's Taylor rate stays above 1.9
    (measured: 2.00), with no solve falling back to LU."""
    with linear.counting() as tally:
        assert run_cli("gradcheck", CUBE, "--out", shared_tmp, "-q",
                       "--set", "model.degree=2", "--set", "solver.linear=pmg",
                       "--set", "solver.adjoint_reuse=false", "--set", "boundary.clamp=x1_min",
                       "--set", "target.map=[x1, x2, 'x3 + 0.1*x1**2']",
                       "--set", "growth.eigenvalues.initial=[1.1, 1.0, 0.95]") == 0
    report = read_json(shared_tmp / "gradcheck.json")
    assert report["min_rate"] > 1.9, report["rates"]
    assert tally.state == tally.adjoint == 0 and tally.krylov_solves > 0


def test_the_p_multigrid_refuses_a_model_of_degree_one():
    with pytest.raises(ConfigError) as err:
        load(CUBE, ["solver.linear=pmg"])
    assert str(err.value).splitlines() == [
        "solver.linear: pmg coarsens P2 (Q2) displacements to P1 (Q1), and model.degree is "
        "1; set model.degree: 2 or another solver"]


@pytest.mark.mpi
@pytest.mark.parametrize("config, preset", [(BEAM, "mumps_ldlt"), (BEAM, "mumps_ooc"),
                                            (BEAM, "mumps_blr"),
                                            (SQUARE, "gamg"), (SQUARE, "hypre"),
                                            (SQUARE, "pmg")])
def test_taylor_rate_with_each_preset(config, preset, shared_tmp):
    """The state, a fresh adjoint (no reuse of the state's factors) and the filter by the
    preset: the reduced gradient's Taylor rate stays above 1.9."""
    assert run_cli("gradcheck", config, "--out", shared_tmp, "-q",
                   "--set", f"solver.linear={preset}", "--set", "solver.adjoint_reuse=false",
                   "--set", "growth.filter_length=0.05") == 0
    report = read_json(shared_tmp / "gradcheck.json")
    assert report["min_rate"] > 1.9, report["rates"]


@pytest.mark.mpi
@pytest.mark.slow  # 18 s serially: the bend grown from rest by GAMG, falling back to LU
def test_a_warm_solve_after_a_failed_preset_starts_from_its_chord_predictor():
    """A preset's failed solve resets its KSP (a failed factorisation stays failed); the
    operators stay, so the next warm solve's chord predictor, which solves with that KSP
    directly, runs (it stopped on PETSc's error before) and the solve converges."""
    from shapegrowth.physics.model import ForwardModel

    cfg = load(BEND, ["parameters.kappa=1.5707963", "solver.linear=gamg",
                      "solver.petsc_options={state_ksp_max_it: 2}"])
    model = ForwardModel.build(cfg)
    with linear.counting() as tally:
        assert model.state.solve().converged
    assert tally.state > 0  # the preset failed, its KSP reset
    model.state.u.x.array[:] += 1e-6
    model.state.u.x.scatter_forward()
    assert model.state.solve().converged


@pytest.mark.mpi
@pytest.mark.mpi_slow  # 6 s on two ranks; the fast tier's fall-back on two ranks: the adjoint's
def test_a_failed_state_solve_falls_back_to_lu_and_is_counted(shared_tmp, capsys):
    """GAMG allowed two Krylov iterations cannot solve the thin beam's Newton steps: each
    failed solve is said in one line with PETSc's reason, done again with MUMPS LU from the
    same start, and counted; after three in a row the model keeps LU (one line more); the
    state is LU's."""
    sets = ["--set", "parameters.kappa=1.5707963", "--probe", "1,0,0"]
    assert run_cli("solve", BEND, "--out", shared_tmp / "lu", "-q", *sets) == 0
    capsys.readouterr()
    assert run_cli("solve", BEND, "--out", shared_tmp / "gamg", "-q", *sets,
                   "--set", "solver.linear=gamg",
                   "--set", "solver.petsc_options={state_ksp_max_it: 2}") == 0
    captured = capsys.readouterr()
    assert _probes(shared_tmp / "gamg") == pytest.approx(_probes(shared_tmp / "lu"), abs=1e-9)
    use = read_json(shared_tmp / "gamg" / "summary.json")["linear_solver"]
    assert use["preset"] == "gamg" and use["state_fallbacks"] == linear.GIVE_UP_AFTER
    assert use["fallbacks"] == use["state_fallbacks"] + use["adjoint_fallbacks"]
    assert "maximum Krylov iterations after 2 iterations" in use["reasons"][0]
    if MPI.COMM_WORLD.rank == 0:  # the package logs on rank 0 only
        said = (captured.out + captured.err).strip().splitlines()
        lines = [line for line in said if "falls back" in line]
        assert len(lines) == use["state_fallbacks"]
        assert all("\n" not in line and "gamg failed (KSP" in line for line in lines)
        assert said[-1] == ("state solve: solver.linear gamg failed 3 solves in a row; this "
                            "model's later solves use MUMPS LU")


def test_the_exact_fallback_is_factorised_as_auto_factorises_by_size():
    """LU below AUTO_LDLT_DOFS, LDL^T below AUTO_OOC_DOFS, out of core beyond: a failed
    iterative solve of a large body does not fall back to the factor with the most memory."""
    assert linear.exact_preset(linear.AUTO_LDLT_DOFS - 1) == "mumps"
    assert linear.exact_preset(linear.AUTO_LDLT_DOFS) == "mumps_ldlt"
    assert linear.exact_preset(linear.AUTO_OOC_DOFS - 1) == "mumps_ldlt"
    assert linear.exact_preset(linear.AUTO_OOC_DOFS) == "mumps_ooc"


@pytest.mark.mpi
def test_a_large_body_s_failed_solve_falls_back_to_ldlt(shared_tmp, capsys, monkeypatch):
    """The thin beam taken as large (AUTO_LDLT_DOFS 0): GAMG allowed two Krylov iterations
    fails, the solve is done again by MUMPS's LDL^T (said in one line) and lands where LU
    does."""
    sets = ["--set", "parameters.kappa=1.5707963", "--probe", "1,0,0"]
    assert run_cli("solve", BEND, "--out", shared_tmp / "lu_ref", "-q", *sets) == 0
    monkeypatch.setattr(linear, "AUTO_LDLT_DOFS", 0)
    capsys.readouterr()
    assert run_cli("solve", BEND, "--out", shared_tmp / "gamg_ldlt", "-q", *sets,
                   "--set", "solver.linear=gamg",
                   "--set", "solver.petsc_options={state_ksp_max_it: 2}") == 0
    said = capsys.readouterr()
    assert _probes(shared_tmp / "gamg_ldlt") == pytest.approx(_probes(shared_tmp / "lu_ref"),
                                                               abs=1e-9)
    use = read_json(shared_tmp / "gamg_ldlt" / "summary.json")["linear_solver"]
    assert use["state_fallbacks"] == linear.GIVE_UP_AFTER
    if MPI.COMM_WORLD.rank == 0:  # the package logs on rank 0 only
        lines = [line for line in (said.out + said.err).splitlines() if "falls back" in line]
        assert lines and all(line.endswith("falls back to MUMPS LDL^T") for line in lines)


@pytest.mark.mpi
def test_a_failed_adjoint_solve_falls_back_and_the_gradient_is_lus(shared_tmp):
    """A fresh adjoint solve by GAMG limited to one Krylov iteration fails; the fallback's
    gradient is the LU gradient, and the fallback is counted."""
    from shapegrowth.optim.problem import ReducedFunctional
    from shapegrowth.physics.model import ForwardModel

    gradients = []
    for preset, extra in (("mumps", {}), ("gamg", {"adjoint_ksp_max_it": 1})):
        cfg = load(BEAM, [f"mesh.cache_dir={shared_tmp}", f"solver.linear={preset}",
                          "solver.adjoint_reuse=false", f"solver.petsc_options={extra}"])
        with linear.counting() as tally:
            rf = ReducedFunctional(ForwardModel.build(cfg))
            gradients.append(rf.gradient(rf.current()))
        assert tally.adjoint == (1 if extra else 0)
    scale = MPI.COMM_WORLD.allreduce(float(np.abs(gradients[0]).max(initial=0.0)), MPI.MAX)
    assert np.allclose(gradients[1], gradients[0], rtol=0.0, atol=1e-7 * scale)


def test_auto_chooses_lu_for_small_models_ldlt_for_large_3d_ones_out_of_core_beyond():
    assert linear.choose("auto", 5_000, 3) == "mumps"
    assert linear.choose("auto", linear.AUTO_LDLT_DOFS, 3) == "mumps_ldlt"
    assert linear.choose("auto", 10 * linear.AUTO_LDLT_DOFS, 2) == "mumps"
    assert linear.choose("auto", linear.AUTO_OOC_DOFS - 1, 3) == "mumps_ldlt"
    assert linear.choose("auto", linear.AUTO_OOC_DOFS, 3) == "mumps_ooc"
    assert linear.choose("auto", 10 * linear.AUTO_OOC_DOFS, 2) == "mumps"
    assert linear.choose("hypre", 100, 3) in ("hypre", "mumps_ldlt")


def test_auto_gives_a_large_solid_body_of_degree_two_to_the_p_multigrid():
    big, solid = linear.AUTO_PMG_DOFS, linear.AUTO_PMG_ACROSS
    assert linear.choose("auto", big, 3, solid) == "pmg"
    assert linear.choose("auto", big - 1, 3, solid) == "mumps_ldlt"  # small: the factor
    assert linear.choose("auto", big, 3, 0.99 * solid) == "mumps_ldlt"  # a wall
    assert linear.choose("auto", big, 3, None) == "mumps_ldlt"  # degree 1, or mixed
    assert linear.choose("auto", 2 * linear.AUTO_OOC_DOFS, 3, None) == "mumps_ooc"
    assert linear.choose("mumps", big, 3, solid) == "mumps"
    assert linear.why("auto", "pmg", 206_763, 3, 5.94) == (
        "auto: 206 763 state DOFs, 5.9 cells across: a solid body of degree 2 (from 100 000 "
        "DOFs and 4 cells across)")
    assert linear.why("auto", "mumps_ldlt", 149_379, 3, 1.6) == (
        "auto: 149 379 state DOFs, 1.6 cells across: factorised (the p-multigrid takes a "
        "body of degree 2 displacements from 100 000 DOFs and 4 cells across)")
    assert linear.why("pmg", "pmg", 10, 3, None) == "named by solver.linear"


@pytest.mark.mpi
@pytest.mark.parametrize("cell, across", [("hex", lambda n: n / 3),
                                          ("tet", lambda n: n / 3 / 2 ** (1 / 6))])
def test_a_cube_is_a_third_of_its_cells_across(cell, across):
    """2 V / A over the cell size: a unit cube of n^3 hexahedra is n/3 across, of 6 n^3
    tetrahedra (each of volume 1/(6 n^3), the regular one's edge 2^(1/6)/n) n/(3 2^(1/6))."""
    import dolfinx

    from shapegrowth.physics.pmultigrid import elements_across

    kind = {"hex": dolfinx.mesh.CellType.hexahedron, "tet": dolfinx.mesh.CellType.tetrahedron}
    for n in (3, 6):
        mesh = dolfinx.mesh.create_box(MPI.COMM_WORLD, [np.zeros(3), np.ones(3)], [n, n, n],
                                       kind[cell])
        assert elements_across(mesh) == pytest.approx(across(n), rel=1e-12)


@pytest.mark.mpi
def test_auto_says_why_in_the_summary_and_takes_the_p_multigrid_for_a_solid_body(
        monkeypatch, shared_tmp):
    """The thresholds lowered to the tiny models (1 000 DOFs, one cell across): the P2 cube
    (1.2 cells across at mesh size 0.2) goes to the p-multigrid, the thin beam (0.6) to the
    factorisation."""
    monkeypatch.setattr(linear, "AUTO_PMG_DOFS", 1000)
    monkeypatch.setattr(linear, "AUTO_PMG_ACROSS", 1.0)
    for config, sets, preset in ((CUBE, ["model.degree=2", "mesh.size=0.2",
                                         "boundary.clamp=x1_min",
                                         "growth.eigenvalues.initial=[1.1, 1.0, 1.0]"], "pmg"),
                                 (BEND, [], "mumps")):
        out = shared_tmp / preset
        assert run_cli("solve", config, "--out", out, "-q",
                       *[x for s in sets for x in ("--set", s)]) == 0
        use = read_json(out / "summary.json")["linear_solver"]
        assert use["preset"] == preset and use["fallbacks"] == 0
        assert use["reason"].startswith("auto: ") and "cells across" in use["reason"]
        assert ("solid body" in use["reason"]) == (preset == "pmg")


class _Said(logging.Handler):
    """The records of one logger, whatever the CLI's logging set up before (caplog sees
    only what propagates to the root)."""

    def __init__(self) -> None:
        super().__init__(logging.DEBUG)
        self.records: list[logging.LogRecord] = []

    def emit(self, record: logging.LogRecord) -> None:
        self.records.append(record)


def test_a_preset_whose_package_is_missing_degrades_with_one_line(monkeypatch):
    monkeypatch.setattr(linear, "has_package", lambda name: name != "hypre")
    said = _Said()
    linear.log.addHandler(said)
    try:
        assert linear.choose("hypre", 1000, 3) == "mumps_ldlt"
    finally:
        linear.log.removeHandler(said)
    assert [r.getMessage() for r in said.records] == [
        "solver.linear: hypre needs PETSc with hypre, which this PETSc lacks; using mumps_ldlt"]
    monkeypatch.setattr(linear, "has_package", lambda name: False)
    with pytest.raises(ConfigError, match="solver.linear: mumps needs PETSc with mumps"):
        linear.choose("mumps", 1000, 3)


def test_the_out_of_core_factor_goes_where_mumps_ooc_tmpdir_says(monkeypatch, tmp_path):
    """mumps_ooc: a directory that is not there is refused in one line naming the variable
    and the fix; one in memory (tmpfs) is said once, in one line; one on disk is silent."""
    monkeypatch.setenv("MUMPS_OOC_TMPDIR", str(tmp_path / "missing"))
    with pytest.raises(ConfigError) as err:
        linear.choose("mumps_ooc", 1000, 3)
    assert str(err.value).count("\n") == 0 and "MUMPS_OOC_TMPDIR" in str(err.value)
    assert "set MUMPS_OOC_TMPDIR to one on disk" in str(err.value)

    monkeypatch.setenv("MUMPS_OOC_TMPDIR", str(tmp_path))
    linear._say_if_in_memory.cache_clear()
    monkeypatch.setattr(linear, "file_system", lambda path: "tmpfs")
    said = _Said()
    linear.log.addHandler(said)
    try:
        for _ in range(2):
            assert linear.choose("mumps_ooc", 1000, 3) == "mumps_ooc"
        monkeypatch.setattr(linear, "file_system", lambda path: "ext4")
        linear._say_if_in_memory.cache_clear()
        assert linear.choose("mumps_ooc", 1000, 3) == "mumps_ooc"
    finally:
        linear.log.removeHandler(said)
        linear._say_if_in_memory.cache_clear()
    assert [r.getMessage() for r in said.records] == [
        f"solver.linear: mumps_ooc writes its factor to {tmp_path.resolve()}, which is in "
        "memory (tmpfs): it saves no memory there; set MUMPS_OOC_TMPDIR to a directory on disk"]


@pytest.mark.slow  # a process of its own and an out-of-core factor (4.0 s)
def test_the_out_of_core_factors_are_removed_when_the_process_ends(tmp_path):
    """A solve by mumps_ooc in a process of its own writes its factors to a directory of its
    own in MUMPS_OOC_TMPDIR, and nothing is left there when it ends (MUMPS leaves the files
    of the factors still held at exit)."""
    env = {**os.environ, "MUMPS_OOC_TMPDIR": str(tmp_path)}
    done = subprocess.run([sys.executable, "-m", "shapegrowth", "solve", str(BEND), "-q",
                           "--out", str(tmp_path / "out"), "--set", "solver.linear=mumps_ooc",
                           "--set", f"mesh.cache_dir={tmp_path / 'meshes'}"],
                          env=env, capture_output=True, text=True, check=False)
    assert done.returncode == 0, done.stderr
    assert read_json(tmp_path / "out" / "summary.json")["linear_solver"]["preset"] == "mumps_ooc"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["meshes", "out"]


def test_the_file_system_of_a_path_is_its_longest_mount_points(tmp_path):
    table = tmp_path / "mounts"
    table.write_text("/dev/vda / ext4 rw 0 0\ntmpfs /tmp tmpfs rw 0 0\n"
                     "tmpfs /tmp/my\\040disk ext4 rw 0 0\nproc /proc proc rw 0 0\n")
    assert linear.file_system("/tmp", str(table)) == "tmpfs"
    assert linear.file_system("/tmp/ooc", str(table)) == "tmpfs"
    assert linear.file_system("/tmpdir/ooc", str(table)) == "ext4"  # not under /tmp
    assert linear.file_system("/tmp/my disk/ooc", str(table)) == "ext4"
    assert linear.file_system("/proc/self", str(table)) == "proc"
    assert linear.file_system("/x", str(tmp_path / "no table")) == ""
    assert linear.file_system("/proc") == "proc"  # this machine's own table


def test_every_preset_sets_options_for_every_role():
    for name in linear.PRESETS:
        for role in ("state_", "adjoint_", "filter_"):
            opts = linear.preset_options(name, role)
            assert {"ksp_type", "pc_type"} <= set(opts)
        iterative = linear.preset_options(name, "state_")["ksp_type"] != "preonly"
        assert iterative == (name in linear.ITERATIVE)


@pytest.mark.slow
def test_the_million_dof_benchmark_lands_on_its_arc_when_coarsened(shared_tmp):
    """benchmarks/tube_bend_1M.yaml (the largest solve from rest measured: docs/PERFORMANCE.md,
    "Out of core") at mesh size 1.5, one layer (5 904 DOFs), its factor out of core: the
    compatible growth lands on the exact quarter circle (1.2e-4 of the target's size
    measured; the 1 153 920-DOF mesh lands at 5.6e-9)."""
    config = ROOT / "benchmarks" / "tube_bend_1M.yaml"
    assert run_cli("solve", config, "--out", shared_tmp, "-q", "--set", "mesh.size=1.5",
                   "--set", "mesh.layers=1", "--set", "solver.linear=mumps_ooc",
                   "--set", f"mesh.cache_dir={shared_tmp}") == 0
    summary = read_json(shared_tmp / "summary.json")
    assert summary["dofs"]["state"] == 5904
    assert summary["hausdorff_final"] / summary["target_size"] < 5e-4
    assert summary["linear_solver"]["preset"] == "mumps_ooc"
    assert summary["stability"]["stable"]


@pytest.mark.mpi
@pytest.mark.parametrize("preset", ["mumps_ldlt", "mumps"])
def test_the_analysis_alone_estimates_what_the_factorisation_takes(preset, shared_tmp):
    """linear.analyse: MUMPS's analysis of the P2 cube's tangent, its factorisation refused,
    gives the estimates a real factorisation of the same matrix reports, and they bound what
    it took (the factor's entries and its memory, within 1.5x): what a mesh too large to
    factor here is measured by (docs/PERFORMANCE.md)."""
    from shapegrowth import compat
    from shapegrowth.physics.model import ForwardModel

    cfg = load(CUBE, [f"mesh.cache_dir={shared_tmp}", "model.degree=2", "mesh.size=0.25"])
    state = ForwardModel.build(cfg).state
    A = state.A
    state.assemble_tangent(compat.petsc_vec(state.u), A)
    estimate = linear.analyse(A, preset)
    with linear.preset_ksp(A, preset, "analysed_") as ksp:
        ksp.setUp()
        F = ksp.getPC().getFactorMatrix()
        assert F.getMumpsInfog(1) == 0
        assert linear.factor_estimate(F) == estimate
        entries, used_mb = F.getMumpsInfog(29), F.getMumpsInfog(22)
    assert entries <= estimate.entries <= 1.5 * entries
    assert used_mb <= estimate.mb_in_core[1] <= 1.5 * used_mb + 2  # MB are whole numbers
    assert estimate.flops > 0 and estimate.mb_out_of_core[1] <= estimate.mb_in_core[1]
    with pytest.raises(ValueError, match="direct MUMPS preset"):
        linear.analyse(A, "gamg")
