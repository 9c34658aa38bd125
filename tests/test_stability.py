"""The stability of an equilibrium (physics/stability.py): the lowest eigenvalues of the
tangent, the inertia, and where a growth path loses stability, against Euler's closed form
for a bar held at both ends and grown along its axis; a body far from any threshold is
stable; serial and on 2 ranks."""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import CONFIGS, read_json, run_cli

import shapegrowth as sg
from shapegrowth.io.summary import RunSummary
from shapegrowth.physics import pmultigrid
from shapegrowth.physics.paths import PathWatch
from shapegrowth.physics.stability import Stability, StabilityProblem

BEND = CONFIGS / "tiny" / "beam_bend.yaml"
CUBE = CONFIGS / "tiny" / "cube_uniform.yaml"
SQUARE = CONFIGS / "tiny" / "square_disk.yaml"

# Euler buckling of a column clamped at both ends, P = 4 pi^2 E I / L^2, in the strain its
# held growth puts it under (E cancels): eps = pi^2 / 3 (t / L)^2, t/L = 1/50 for the beam.
EULER_STRAIN = math.pi**2 / 3.0 * (0.02 / 1.0) ** 2  # 1.316e-3


def _solve(shared_tmp, strain: float, *sets: str, name: str = "") -> dict:
    out = shared_tmp / f"strain-{strain:.3e}{name}"
    args = [a for s in sets for a in ("--set", s)]
    assert run_cli("solve", BEND, "--out", out, "-q", "--set", "mesh.cells=hex",
                   "--set", f"mesh.cache_dir={shared_tmp}",
                   "--set", "boundary.clamp=[x1_min, x1_max]",
                   "--set", f"growth.eigenvalues.initial=[{(1 + strain) ** 2}, 1, 1]",
                   "--probe", "0.5,0,0", *args) == 0
    return read_json(out / "summary.json")


@pytest.mark.mpi
def test_a_bar_held_at_both_ends_buckles_at_eulers_strain(shared_tmp):
    """Q2 hexahedra, one through the thickness, 20 along: grown by 0.8 of Euler's strain the
    straight bar is stable, by 1.25 of it unstable with one negative eigenvalue, and the
    path from rest loses stability where the growth strain is Euler's, to 5 % (measured
    1.354e-3 against 1.316e-3: +2.9 %, the width's plate stiffening and the mesh)."""
    below = _solve(shared_tmp, 0.8 * EULER_STRAIN)["stability"]
    assert below["stable"] and below["negative"] == 0 and below["lowest"][0] > 0
    assert below["lost_at"] is None and below["kind"] is None
    above = _solve(shared_tmp, 1.25 * EULER_STRAIN)["stability"]
    assert not above["stable"] and above["negative"] == 1 and above["lowest"][0] < 0
    assert above["lowest"][1] > 0  # one mode only
    assert above["kind"] == "bifurcation"
    # the growth blend is geometric: the stretch at load fraction t is (1 + eps)^t
    strain_lost = (1 + 1.25 * EULER_STRAIN) ** above["lost_at"] - 1.0
    assert strain_lost == pytest.approx(EULER_STRAIN, rel=0.05)
    assert above["branch"] == "followed" and above["switched_at"] is None


def _midspan_deflection(summary: dict) -> float:
    (probe,) = summary["probes"]
    return abs(probe["deformed"][2])


@pytest.mark.mpi
def test_past_eulers_strain_the_switch_finds_the_buckled_bar(shared_tmp):
    """Past the threshold (1.25 of Euler's strain) the straight bar is unstable; solver.branch
    switch leaves it along the critical mode for the buckled bar, stable, whose midspan
    deflection is the inextensible elastica's A = (2L/pi) sqrt(eps - eps_c) (the extra
    length (eps - eps_c) L taken up by w = A/2 (1 - cos 2 pi x/L), the axial strain held at
    the threshold; eps_c the path's own, where it lost stability) to 5 % (measured 0.0108
    against 0.0109).  follow stays straight and unstable."""
    strain = 1.25 * EULER_STRAIN
    followed = _solve(shared_tmp, strain, name="follow")
    assert followed["stability"]["negative"] == 1
    assert _midspan_deflection(followed) < 1e-10
    switched = _solve(shared_tmp, strain, "solver.branch=switch", name="switch")
    stability = switched["stability"]
    assert stability["stable"] and stability["negative"] == 0 and stability["lowest"][0] > 0
    assert stability["branch"] == "switched" and stability["kind"] == "bifurcation"
    assert stability["lost_at"] <= stability["switched_at"] <= 1.0
    eps_c = (1 + strain) ** stability["lost_at"] - 1.0
    elastica = 2.0 / math.pi * math.sqrt(strain - eps_c)
    assert _midspan_deflection(switched) == pytest.approx(elastica, rel=0.05)


@pytest.mark.mpi
def test_negative_eigenvalues_beyond_the_ones_nearest_0_are_found(shared_tmp):
    """Far past the threshold (3.9 of Euler's strain, just short of the third mode's 4) the
    straight bar has two negative eigenvalues, both farther from 0 than the third mode's
    positive one.  Asked for the one nearest 0, the eigenproblem is solved again below 0
    until a negative one is among those found: the most negative, as six modes about 0
    give it (measured -0.342 and -0.230 beside +0.064)."""
    strain = 3.9 * EULER_STRAIN
    cfg = sg.load_config(BEND, ["mesh.cells=hex", f"mesh.cache_dir={shared_tmp}",
                                "boundary.clamp=[x1_min, x1_max]",
                                f"growth.eigenvalues.initial=[{(1 + strain) ** 2}, 1, 1]"])
    model = sg.build_model(cfg)
    assert model.state.solve().converged  # the straight bar, by its symmetry
    six = StabilityProblem(model.state, count=6).assess()
    assert six.negative == 2 and six.lowest[0] < six.lowest[1] < 0 < six.lowest[2]
    assert six.lowest[2] < -six.lowest[1]  # the positive one is nearest 0
    one = StabilityProblem(model.state, count=1).assess()
    assert one.negative == 2 and not one.stable
    assert one.lowest == pytest.approx(six.lowest[:1], rel=1e-6)


@pytest.mark.mpi
def test_the_p_multigrid_finds_the_lowest_eigenvalues_without_a_factorisation(shared_tmp):
    """solver.linear pmg: generalised Davidson preconditioned by the p-multigrid finds the
    LDL^T's lowest
    eigenvalues (to 1e-6; measured 1e-8 and below) of the bar far past its threshold, the two
    negative ones below the positive one nearest 0, with no factor made; asked for one,
    it counts one negative (a lower bound: the inertia is a factorisation's).  The path
    from rest, watched by it at every step, loses stability where the LU's path does."""
    strain = 3.9 * EULER_STRAIN
    sets = ["mesh.cells=hex", f"mesh.cache_dir={shared_tmp}", "boundary.clamp=[x1_min, x1_max]",
            f"growth.eigenvalues.initial=[{(1 + strain) ** 2}, 1, 1]"]
    found = {}
    for linear in ("mumps", "pmg"):
        model = sg.build_model(sg.load_config(BEND, [*sets, f"solver.linear={linear}"]))
        assert model.state.solve().converged
        found[linear] = StabilityProblem(model.state, count=6)
    pmg, ldlt = found["pmg"], found["mumps"]
    after, before = pmg.assess(), ldlt.assess()
    assert pmg.eps.getST().getType() == "precond"
    assert pmg.eps.getST().getKSP().getPC().getType() == "mg"
    assert after.negative == before.negative == 2
    assert after.lowest == pytest.approx(before.lowest, rel=1e-6)
    a, b = pmg.mode.x.array, ldlt.mode.x.array  # the same mode, up to its sign
    assert abs(a @ b) == pytest.approx(np.linalg.norm(a) * np.linalg.norm(b), rel=1e-6)
    one = StabilityProblem(pmg.state, count=1).assess()
    assert one.negative == 1 and one.lowest == pytest.approx(before.lowest[:1], rel=1e-6)
    lu = _solve(shared_tmp, 1.25 * EULER_STRAIN, "solver.linear=mumps", name="lu")
    watched = _solve(shared_tmp, 1.25 * EULER_STRAIN, "solver.linear=pmg", name="pmg")
    assert watched["stability"]["negative"] == 1 and watched["stability"]["kind"] == "bifurcation"
    assert watched["stability"]["lowest"] == pytest.approx(lu["stability"]["lowest"], rel=1e-6)
    assert watched["stability"]["lost_at"] == pytest.approx(lu["stability"]["lost_at"], rel=1e-6)
    assert watched["linear_solver"]["preset"] == "pmg"

@pytest.mark.mpi
@pytest.mark.mpi_slow  # two ranks in the slow tier (5 s)
def test_the_p_multigrid_s_eigensolve_holds_with_a_gamg_coarse_level(shared_tmp, monkeypatch):
    """The beam two tetrahedra thick, slightly bent, its p-multigrid's coarse level by GAMG
    (as beyond 50 000 coarse DOFs): the lowest eigenvalues are the LDL^T's to 1e-6 (measured
    2e-8).  LOBPCG broke down here (LAPACK's sygvd: its Gram matrix not definite)."""
    monkeypatch.setattr(pmultigrid, "DIRECT_COARSE_DOFS", 0)
    sets = ["mesh.layers=2", "parameters.kappa=0.3141592653589793", f"mesh.cache_dir={shared_tmp}"]
    lowest = {}
    for linear in ("mumps", "pmg"):
        model = sg.build_model(sg.load_config(BEND, [*sets, f"solver.linear={linear}"]))
        assert model.state.solve().converged
        if linear == "pmg":
            assert model.state.newton.pmg.coarse_options() == {}  # GAMG
        stability = StabilityProblem(model.state, count=3).assess()
        assert stability.negative == 0
        lowest[linear] = stability.lowest
    assert lowest["pmg"] == pytest.approx(lowest["mumps"], rel=1e-6)

@pytest.mark.mpi
def test_the_ldlt_factorisation_watches_the_path_by_its_inertia(shared_tmp):
    """With the LDL^T (solver.linear mumps_ldlt, and mumps_ooc) the path is watched by the
    factorisation's inertia: the same stability at the end, and the loss placed at the first
    load step found unstable (at or after the crossing the eigenvalues give)."""
    strain = 1.25 * EULER_STRAIN
    lu = _solve(shared_tmp, strain, "solver.linear=mumps", name="lu")["stability"]
    ldlt = _solve(shared_tmp, strain, "solver.linear=mumps_ldlt", name="ldlt")["stability"]
    assert ldlt["negative"] == lu["negative"] == 1
    assert ldlt["lowest"] == pytest.approx(lu["lowest"], rel=1e-6)
    assert ldlt["kind"] == "bifurcation" and ldlt["lost_at"] >= lu["lost_at"]
    # out of core (mumps_ooc; the eigensolve's factor out of core too): the same path, the
    # same loss, the same end
    ooc = _solve(shared_tmp, strain, "solver.linear=mumps_ooc", name="ooc")
    assert ooc["stability"]["negative"] == 1 and ooc["stability"]["lost_at"] == ldlt["lost_at"]
    assert ooc["stability"]["lowest"] == pytest.approx(ldlt["lowest"], rel=1e-9)
    assert ooc["linear_solver"]["preset"] == "mumps_ooc"
    assert ooc["linear_solver"]["fallbacks"] == 0


def _square_pair(linear: str, *sets: str):
    """The square grown unevenly (a stressed equilibrium) on its mesh, solved from rest; and
    the same growth on the mesh refined once, solved there from rest."""
    from shapegrowth.optim.verification import carried_to, refined_config
    from shapegrowth.physics.model import ForwardModel

    cfg = sg.load_config(SQUARE, ["growth.eigenvalues.initial=['2 + 0.25*x1*x2', 2.0]",
                                  f"solver.linear={linear}", *sets])
    coarse = ForwardModel.build(cfg)
    assert coarse.state.solve().converged
    reference = carried_to(coarse, refined_config(cfg, 1))
    assert reference.state.solve().converged
    return coarse, reference


def _largest(values) -> float:
    from mpi4py import MPI

    return MPI.COMM_WORLD.allreduce(float(np.abs(values).max(initial=0.0)), MPI.MAX)


@pytest.mark.mpi
@pytest.mark.parametrize("linear,sets", [("mumps", []), ("mumps_ooc", []),
                                         ("mumps", ["material.formulation=mixed"])],
                         ids=["mumps", "mumps_ooc", "mixed"])
def test_a_carried_start_newton_cannot_take_is_settled_by_shifted_steps(linear, sets,
                                                                         monkeypatch):
    """A coarser mesh's equilibrium carried onto the refined mesh, from which Newton's method
    finds no equilibrium (here: held to one iteration), is taken by shifted Newton steps
    (paths.settle_carried) to the equilibrium found from rest there: the same displacement
    to 1e-8 of its largest, stable; in core and out of core, and for a mixed body (its
    pressure carried as zero); a warm re-solve after them converges from its chord
    predictor.  Where those steps find none
    too, the solve reports both failures and the state is back at the carried start."""
    from shapegrowth.optim.verification import carried_to
    from shapegrowth.physics import paths

    coarse, reference = _square_pair(linear, *sets)
    fine = carried_to(coarse, reference.cfg)
    fine.state.carry(coarse.state.u)
    assert fine.state.carried
    fine.state.newton.snes.setTolerances(max_it=1)  # Newton's method cannot take it
    report, stability, _ = paths.solve_watched(fine.state)
    assert report.converged and report.reached == 1.0 and report.reason == ""
    assert report.newton_iterations == 1 and report.shifted_steps > 0
    assert not fine.state.carried and fine.state.inverted_points() == 0
    scale = _largest(reference.state.u.x.array)
    assert _largest(fine.state.u.x.array - reference.state.u.x.array) < 1e-8 * scale
    assert stability is not None and stability.stable and stability.negative == 0
    # the steps freed Newton's factors (one factorisation in memory at a time); a warm
    # re-solve's chord predictor solves with Newton's KSP again, factored anew
    assert not fine.state.newton.factored_by_preset
    fine.state.put_back(fine.state.snapshot() + 1e-6 * scale)  # the unknown: u (and p)
    warm = fine.state.solve()
    assert warm.converged and warm.chord_steps > 0
    assert _largest(fine.state.u.x.array - reference.state.u.x.array) < 1e-8 * scale

    again = carried_to(coarse, reference.cfg)
    again.state.carry(coarse.state.u)
    start = again.state.snapshot()
    again.state.newton.snes.setTolerances(max_it=1)
    monkeypatch.setattr(paths, "descend", lambda problem, shift, cap: (False, 7))
    failed, _, _ = paths.solve_watched(again.state)
    assert not failed.converged and failed.shifted_steps == 7
    assert failed.reason.startswith("no equilibrium near the carried state (maximum Newton")
    assert failed.reason.endswith("; no equilibrium in 7 shifted Newton steps")
    assert np.array_equal(again.state.snapshot(), start)


@pytest.mark.mpi
def test_shifted_steps_take_no_step_with_an_indefinite_operator(shared_tmp):
    """paths.descend from the straight bar past Euler's strain (one negative eigenvalue),
    nudged along its mode, with a shift 1e-6 of that eigenvalue's magnitude: K + shift M is
    indefinite there, so no step is taken with it; the shift is raised (4x at a time)
    until it is definite, and the steps leave the straight bar for the buckled, stable
    one.  Stepping with the indefinite operator instead pulls the nudge back (by shift /
    (shift + omega^2), about -1e-6): Newton's steps to the unstable straight bar,
    converged there before the shift is raised past the eigenvalue."""
    from shapegrowth.physics import paths
    from shapegrowth.physics.model import ForwardModel

    strain = 1.25 * EULER_STRAIN
    cfg = sg.load_config(BEND, ["mesh.cells=hex", f"mesh.cache_dir={shared_tmp}",
                                "boundary.clamp=[x1_min, x1_max]",
                                f"growth.eigenvalues.initial=[{(1 + strain) ** 2}, 1, 1]"])
    model = ForwardModel.build(cfg)
    assert model.state.solve().converged  # the straight bar: no path watched
    problem = StabilityProblem(model.state)
    straight = problem.assess()
    assert straight.negative == 1 and straight.lowest[0] < 0
    size = 1.0  # the bar's length
    model.state.u.x.array[:] += 1e-3 * size * problem.mode.x.array
    model.state.u.x.scatter_forward()
    converged, steps = paths.descend(problem, 1e-6 * -straight.lowest[0], 0.02 * size)
    assert converged and steps > 0
    buckled = problem.assess()
    assert buckled.negative == 0 and buckled.stable
    assert _largest(model.state.u.x.array[2::3]) > 10 * 1e-3 * size  # it buckled


@pytest.mark.mpi
def test_a_body_far_from_any_threshold_is_stable(shared_tmp):
    """A free cube grown uniformly (stress-free) and the compatible quarter-arc bend of the
    cantilever: every eigenvalue positive."""
    for config, sets in ((CUBE, ["growth.eigenvalues.initial=[1.2, 1.2, 1.2]"]),
                         (BEND, ["parameters.kappa=1.5707963"])):
        out = shared_tmp / config.stem
        args = [a for s in sets for a in ("--set", s)]
        assert run_cli("solve", config, "--out", out, "-q", *args) == 0
        stability = read_json(out / "summary.json")["stability"]
        assert stability["stable"] and stability["negative"] == 0
        assert min(stability["lowest"]) > 0 and stability["lost_at"] is None
        read = RunSummary.from_json(read_json(out / "summary.json")).stability
        assert read is not None and read.stable and read.lowest == tuple(stability["lowest"])


@pytest.mark.mpi
def test_the_state_solvers_own_matrix_serves_as_the_stability_tangent(shared_tmp):
    """A solve from rest assesses K in the state solver's matrix (no second copy of the
    tangent): the same eigenvalues as in a matrix of its own, and the next solve, which
    factors that matrix anew, lands where a fresh model does."""
    from shapegrowth.config import load
    from shapegrowth.physics.model import ForwardModel
    from shapegrowth.physics.stability import StabilityProblem

    cfg = load(BEND, [f"mesh.cache_dir={shared_tmp}", "boundary.clamp=[x1_min, x1_max]",
                      f"growth.eigenvalues.initial=[{(1 + 1.25 * EULER_STRAIN) ** 2}, 1, 1]"])
    model = ForwardModel.build(cfg)
    assert model.state.solve().converged
    own = StabilityProblem(model.state).assess()
    shared_problem = StabilityProblem(model.state, shared_tangent=True)
    assert shared_problem.K is model.state.A
    shared = shared_problem.assess()
    assert shared.negative == own.negative == 1
    assert np.allclose(shared.lowest, own.lowest, rtol=1e-8, atol=1e-12)
    for f in model.growth.eigenvalues:
        f.x.array[:] *= 1.001
    assert model.state.solve().converged
    fresh = ForwardModel.build(cfg)
    for f, g in zip(fresh.growth.eigenvalues, model.growth.eigenvalues):
        f.x.array[:] = g.x.array
    assert fresh.state.solve().converged
    scale = np.abs(fresh.state.u.x.array).max()
    assert np.abs(model.state.u.x.array - fresh.state.u.x.array).max() < 1e-8 * scale


@pytest.mark.mpi
def test_the_mass_matrix_keeps_only_its_nonzeros(shared_tmp):
    """M couples no two components: stored without its zeros it holds a third of the
    tangent's entries in 3D and acts on a vector as the assembled one does."""
    import numpy as np
    from mpi4py import MPI
    from petsc4py import PETSc

    from shapegrowth.config import load
    from shapegrowth.physics.model import ForwardModel
    from shapegrowth.physics.stability import StabilityProblem, without_zeros

    model = ForwardModel.build(load(BEND, [f"mesh.cache_dir={shared_tmp}"]))
    problem = StabilityProblem(model.state)
    full = problem.K.duplicate()  # the tangent's pattern, the mass's values
    model.state.tangent_into(full)
    full.zeroEntries()
    full.axpy(1.0, problem.M, structure=PETSc.Mat.Structure.SUBSET_NONZERO_PATTERN)
    assert without_zeros(full).getInfo()["nz_used"] == problem.M.getInfo()["nz_used"]
    stored = MPI.COMM_WORLD.allreduce(problem.M.getInfo()["nz_used"], MPI.SUM)
    tangent = MPI.COMM_WORLD.allreduce(full.getInfo()["nz_used"], MPI.SUM)
    assert 0.3 < stored / tangent < 0.36
    x, y, z = full.createVecRight(), full.createVecLeft(), full.createVecLeft()
    x.setArray(np.random.default_rng(MPI.COMM_WORLD.rank).standard_normal(x.getLocalSize()))
    full.mult(x, y)
    problem.M.mult(x, z)
    z.axpy(-1.0, y)
    assert z.norm() <= 1e-14 * y.norm()


class _Path:
    """A stand-in for StabilityProblem: the lowest eigenvalues of a path, in order."""

    class state:  # noqa: N801
        class newton:  # noqa: N801  (no LDL^T inertia: every step assessed)
            @staticmethod
            def inertia() -> None:
                return None

    def __init__(self, values):
        self.values = iter(values)

    def assess(self) -> Stability:
        value = next(self.values)
        return Stability((value,), int(value < 0))


@pytest.mark.parametrize("ts, values, converged, expected", [
    ((0.1, 0.3, 0.7, 1.0), (4.0, 3.0, -1.0, -2.0), True, (0.6, "bifurcation")),
    ((0.1, 0.2, 0.25), (4.0, 1.0, 0.01), False, (0.25, "limit_point")),
    ((0.1, 0.2, 0.25), (4.0, 3.0, 2.5), False, (None, None)),  # failed, not at a threshold
    ((0.5, 1.0), (2.0, 1.0), True, (None, None)),
])
def test_where_a_path_loses_stability(ts, values, converged, expected):
    """The crossing of zero, linear between the steps around it (4 -> 3 at 0.3 -> 0.7 with
    3 -> -1: 0.3 + 0.4 x 3/4 = 0.6); a path that failed with its lowest eigenvalue below
    1 % of its first met a limit point where it ended."""
    watch = PathWatch(_Path(values))  # type: ignore[arg-type]
    for t in ts:
        watch(t)
    lost_at, kind = watch.lost(ts[-1], converged)
    assert kind == expected[1]
    assert lost_at == (None if expected[0] is None else pytest.approx(expected[0]))


@pytest.mark.slow  # 11 s serially, 9 s on 2 ranks
@pytest.mark.mpi
def test_a_run_reports_the_stability_of_its_optimum_and_of_its_verified_state(shared_tmp):
    """The cantilever optimised towards the wave: both its optimum and the verified state
    (its growth from rest on the refined mesh) are stable; the refined model's lowest
    eigenvalue is near the run's mesh's (the same body, mesh-independent scale: within
    10 %); summary.json reads back."""
    out = shared_tmp / "run"
    assert run_cli("run", CONFIGS / "tiny" / "beam_wave.yaml", "--out", out, "-q",
                   "--set", "optimizer.max_iterations=3") == 0
    summary = RunSummary.from_json(read_json(out / "summary.json"))
    assert summary.stability is not None and summary.verified is not None
    verified = summary.verified.stability
    assert verified is not None and summary.stability.stable and verified.stable
    assert verified.lowest[0] == pytest.approx(summary.stability.lowest[0], rel=0.1)
    # solve takes the run's best growth (growth.start: run) and grows it from rest as the
    # run did on its own mesh
    solved = shared_tmp / "solved"
    assert run_cli("solve", CONFIGS / "tiny" / "beam_wave.yaml", "--out", solved, "-q",
                   "--set", "growth.start=run", "--set", f"growth.from_run={out}") == 0
    again = read_json(solved / "summary.json")
    assert summary.optimization is not None
    assert again["hausdorff_final"] == pytest.approx(summary.optimization.hausdorff_from_rest,
                                                     rel=1e-6)


@pytest.mark.mpi
def test_a_runs_state_from_rest_takes_the_branch_its_verification_takes(shared_tmp):
    """The optimiser's solves from rest (its first evaluation, a retry, a level's start) are
    watched as the verification's are: past Euler's strain (1.25 of it), with switch the
    run's first state is the buckled bar, stable, its midspan deflection the elastica's to
    5 % (as test_past_eulers_strain_the_switch_finds_the_buckled_bar's; measured 0.01088
    against 0.01086).  Unwatched, as before, it was the straight bar, unstable (follow:
    that test's other half)."""
    import numpy as np
    from mpi4py import MPI

    from shapegrowth.optim.problem import ReducedFunctional

    strain = 1.25 * EULER_STRAIN
    cfg = sg.load_config(BEND, ["mesh.cells=hex", f"mesh.cache_dir={shared_tmp}",
                                "boundary.clamp=[x1_min, x1_max]",
                                f"growth.eigenvalues.initial=[{(1 + strain) ** 2}, 1, 1]",
                                "target.map=[x1, x2, x3]", "solver.branch=switch"])
    rf = ReducedFunctional(sg.build_model(cfg))
    assert rf.model.state.at_rest
    rf(rf.current())
    state = rf.model.state
    assert not state.at_rest
    deflection = MPI.COMM_WORLD.allreduce(
        float(np.abs(state.u.x.array.reshape(-1, 3)[:, 2]).max(initial=0.0)), MPI.MAX)
    now = StabilityProblem(state).assess()
    assert now.stable and now.negative == 0
    eps_c = 1.354e-3  # the path's own threshold, measured (test_a_bar_held_at_both_ends...)
    elastica = 2.0 / math.pi * math.sqrt(strain - eps_c)
    assert deflection == pytest.approx(elastica, rel=0.05)


def _dense(A) -> np.ndarray:
    """An assembled serial PETSc matrix as a dense array."""
    import scipy.sparse

    indptr, indices, values = A.getValuesCSR()
    return scipy.sparse.csr_matrix((values, indices, indptr), shape=A.getSize()).toarray()


@pytest.mark.parametrize("incompressible", [False, True], ids=["mixed", "incompressible"])
def test_a_mixed_body_s_stability_is_its_constrained_tangent_s(incompressible, shared_tmp):
    """The Euler bar past its threshold (1.25 of Euler's strain), mixed (Q2-Q1): the lowest
    eigenvalues and the inertia of the pencil (A, diag(M, 0)) less the pressure DOFs are
    those of the constrained tangent, from a dense elimination of the pressure: K + B^T
    C^-1 B, or K on the null space of B where incompressible (C = 0)."""
    import scipy.linalg
    from mpi4py import MPI

    if MPI.COMM_WORLD.size > 1:
        pytest.skip("a dense serial elimination")
    strain = 1.25 * EULER_STRAIN
    cfg = sg.load_config(BEND, [
        "mesh.cells=hex", f"mesh.cache_dir={shared_tmp}", "boundary.clamp=[x1_min, x1_max]",
        f"growth.eigenvalues.initial=[{(1 + strain) ** 2}, 1, 1]", "model.degree=2",
        "mesh.size=0.1",  # 10 along: 1 000 DOFs, a dense eigenproblem of a second
        "material.incompressible=true" if incompressible else "material.formulation=mixed"])
    model = sg.build_model(cfg)
    assert model.state.solve().converged
    problem = StabilityProblem(model.state, count=3)
    found = problem.assess()
    A, M = _dense(problem.K), _dense(problem.M)
    W = model.state.W
    u_dofs = np.asarray(W.sub(0).collapse()[1]).ravel()  # dolfinx 0.11: a list of one
    p_dofs = np.asarray(W.sub(1).collapse()[1]).ravel()
    assert problem.constraints == len(p_dofs)
    free = u_dofs[np.diag(M)[u_dofs] > 0]  # the clamped rows: identity in K, zero in M
    K, B, C = A[np.ix_(free, free)], A[np.ix_(p_dofs, free)], -A[np.ix_(p_dofs, p_dofs)]
    Mf = M[np.ix_(free, free)]
    if incompressible:
        assert np.abs(C).max() == 0.0
        Z = scipy.linalg.null_space(B)
        values = scipy.linalg.eigh(Z.T @ K @ Z, Z.T @ Mf @ Z, eigvals_only=True,
                                   subset_by_index=[0, 2])
    else:
        values = scipy.linalg.eigh(K + B.T @ np.linalg.solve(C, B), Mf, eigvals_only=True,
                                   subset_by_index=[0, 2])
    assert found.negative == int(np.sum(values < 0)) == 1  # values[2] > 0: all of them
    assert found.lowest == pytest.approx(values, rel=1e-6)


@pytest.mark.mpi
@pytest.mark.parametrize("sets", [["material.formulation=mixed"],
                                  ["material.incompressible=true"]],
                         ids=["mixed", "incompressible"])
def test_a_mixed_bar_held_at_both_ends_buckles_at_eulers_strain(sets, shared_tmp):
    """The displacement's test above for the mixed element (Q2-Q1) and its incompressible
    limit: stable at 0.8 of Euler's strain, one negative eigenvalue at 1.25, and the path
    watched loses stability at Euler's strain, to 5 % (measured +2.5 % and +4.2 %: the
    width's plate stiffening grows with Poisson's ratio, 0.3 and 0.5)."""
    sets = [*sets, "model.degree=2"]
    below = _solve(shared_tmp, 0.8 * EULER_STRAIN, *sets, name="-below")["stability"]
    assert below["stable"] and below["lowest"][0] > 0 and below["lost_at"] is None
    above = _solve(shared_tmp, 1.25 * EULER_STRAIN, *sets, name="-above")["stability"]
    assert above["negative"] == 1 and above["lowest"][0] < 0 < above["lowest"][1]
    assert above["kind"] == "bifurcation"
    strain_lost = (1 + 1.25 * EULER_STRAIN) ** above["lost_at"] - 1.0
    assert strain_lost == pytest.approx(EULER_STRAIN, rel=0.05), strain_lost


@pytest.mark.mpi
@pytest.mark.parametrize("sets", [["material.formulation=mixed"],
                                  ["material.incompressible=true"]],
                         ids=["mixed", "incompressible"])
def test_past_eulers_strain_the_switch_finds_a_mixed_buckled_bar(sets, shared_tmp):
    """The switch's test above for the mixed element (Q2-Q1) and its incompressible limit:
    the unknown (u, p) moves along the whole eigenvector, the shifted steps count the
    inertia less the pressure DOFs, and the buckled bar found is stable with the elastica's
    midspan deflection, to 5 % (measured -0.8 % and -1.3 %)."""
    strain = 1.25 * EULER_STRAIN
    switched = _solve(shared_tmp, strain, *sets, "model.degree=2", "solver.branch=switch",
                      name=f"-switch-{sets[0]}")
    stability = switched["stability"]
    assert stability["stable"] and stability["negative"] == 0 and stability["lowest"][0] > 0
    assert stability["branch"] == "switched" and stability["kind"] == "bifurcation"
    eps_c = (1 + strain) ** stability["lost_at"] - 1.0
    elastica = 2.0 / math.pi * math.sqrt(strain - eps_c)
    assert _midspan_deflection(switched) == pytest.approx(elastica, rel=0.05)
