"""Shared fixtures. Tests marked ``mpi`` are collective: ``make test`` runs them
again under ``mpirun -n 2``, where every rank must call them in the same order."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
from mpi4py import MPI

ROOT = Path(__file__).resolve().parent.parent
CONFIGS = ROOT / "configs"
BIN = Path(sys.executable).parent

# The fast tier (`make test`, the tests not marked `slow`) must stay within minutes: a test
# left unmarked that takes longer than this (its call, in seconds) fails the session, with its
# name and time.  SHAPEGROWTH_FAST_LIMIT_S=0 switches the check off (a loaded machine).
FAST_LIMIT_S = float(os.environ.get("SHAPEGROWTH_FAST_LIMIT_S", "20"))
_too_slow: list[tuple[str, float]] = []


def pytest_runtest_logreport(report: pytest.TestReport) -> None:
    if (report.when == "call" and FAST_LIMIT_S > 0 and "slow" not in report.keywords
            and report.duration > FAST_LIMIT_S):
        _too_slow.append((report.nodeid, report.duration))


def pytest_sessionfinish(session: pytest.Session, exitstatus: int) -> None:
    if not _too_slow:
        return
    reporter = session.config.pluginmanager.get_plugin("terminalreporter")
    if reporter is not None:
        reporter.write_line(f"unmarked tests over {FAST_LIMIT_S:g} s (mark them slow):", red=True)
        for nodeid, seconds in _too_slow:
            reporter.write_line(f"  {seconds:6.1f} s  {nodeid}", red=True)
    if exitstatus == 0:
        session.exitstatus = 1


# The hexahedral leg (`make test-hex`): SHAPEGROWTH_TEST_CELLS=hex makes every config the
# suite builds in this process default to `mesh.cells: hex` (a config or --set that names
# `mesh.cells` keeps its own), so each test that builds a model runs again on quadrilaterals
# and hexahedra.  Tests whose assertion is about simplices (a refinement by splitting, a
# reference value measured on tetrahedra) are marked `simplex` and left out of that leg.
TEST_CELLS = os.environ.get("SHAPEGROWTH_TEST_CELLS", "simplex")
if TEST_CELLS not in ("simplex", "hex"):
    raise pytest.UsageError(f"SHAPEGROWTH_TEST_CELLS={TEST_CELLS!r}: use simplex or hex")


def pytest_configure(config: pytest.Config) -> None:
    if TEST_CELLS != "hex":
        return
    from shapegrowth.config import loading

    plain = loading.apply_overrides

    def with_cells(raw, overrides, errors):
        raw = plain(raw, overrides, errors)
        if isinstance(raw.get("mesh"), dict):
            raw["mesh"].setdefault("cells", TEST_CELLS)
        return raw

    loading.apply_overrides = with_cells


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    if TEST_CELLS != "hex":
        return
    skip = pytest.mark.skip(reason="about simplices (SHAPEGROWTH_TEST_CELLS=hex)")
    for item in items:
        if "simplex" in item.keywords:
            item.add_marker(skip)


@pytest.fixture
def shared_tmp(tmp_path: Path) -> Path:
    """A temporary folder that every MPI rank sees (rank 0's)."""
    return Path(MPI.COMM_WORLD.bcast(str(tmp_path), root=0))


def _compile_kernels(precisions: tuple[str, ...]) -> None:
    """numba compiles rho_H's kernels at their first call (float64's 24 s, float32's 37 s
    more in a fresh clone, read from its cache after): done on clouds of their own, so that
    a test's time is its own (float64's in every process, float32's in the modules that
    take it: a float32 compile in a second worker costs its 37 s again)."""
    import numpy as np

    from shapegrowth.shape.hausdorff import PointCloud, SmoothHausdorff

    rng = np.random.default_rng(0)
    a, b = (PointCloud(rng.random((200, 3)) * [1.0, 0.1, 0.02], np.full(200, 1 / 200))
            for _ in range(2))
    for truncate in (False, True):
        for precision in precisions:
            SmoothHausdorff(alpha=200.0, truncate=truncate, precision=precision)(a, b)


@pytest.fixture(scope="session", autouse=True)
def compiled_kernels() -> None:
    """rho_H's float64 kernels, compiled before a process's first test (_compile_kernels):
    nearly every worker measures a shape early, and the first test to do so was charged the
    compile (test_divergence 24.7 s, test_figures' 3D run 21.6 s on fresh clones)."""
    _compile_kernels(("float64",))


@pytest.fixture(scope="session")
def compiled_kernels32(compiled_kernels: None) -> None:
    """rho_H's float32 kernels too (_compile_kernels; ``pytestmark =
    pytest.mark.usefixtures("compiled_kernels32")``)."""
    _compile_kernels(("float32",))


def rank_share(cloud, comm=MPI.COMM_WORLD):
    """This rank's contiguous share of a point cloud that every rank holds whole, with its
    range (lo, hi) in the whole."""
    from shapegrowth.shape.hausdorff import PointCloud

    n = len(cloud.weights)
    lo, hi = n * comm.rank // comm.size, n * (comm.rank + 1) // comm.size
    return PointCloud(cloud.points[lo:hi], cloud.weights[lo:hi]), lo, hi


def taylor_in_points(H, a, b, dp, eps0: float):
    """Taylor test of rho_H = H(a + m, b) in the points of ``a``, along ``dp`` (n, 3)."""
    import numpy as np

    from shapegrowth.optim.taylor import taylor_test
    from shapegrowth.shape.hausdorff import PointCloud

    n = len(a.weights)

    def J(m):
        return H(PointCloud(a.points + m.reshape(n, 3), a.weights), b, gradient=False).value

    def dJ(m):
        return H(PointCloud(a.points + m.reshape(n, 3), a.weights), b).grad_points.ravel()

    return taylor_test(J, dJ, np.zeros(3 * n), dp.ravel(), eps0=eps0, steps=4)


def design_taylor(problem, seed: int, scale: float, eps0: float, steps: int):
    """The Taylor test (optim.taylor) of a design problem (``ShellDesign``: evaluate(x,
    gradient)) from its current design along ``scale`` times a standard normal step drawn
    with ``seed`` on each rank (collective)."""
    import numpy as np
    from mpi4py import MPI

    from shapegrowth.optim.taylor import taylor_test

    start = problem.current()
    step = scale * np.random.default_rng(seed).standard_normal(start.shape)
    return taylor_test(lambda x: problem.evaluate(x, gradient=False).value.total,
                       lambda x: problem.evaluate(x).gradient, start, step, eps0=eps0,
                       steps=steps, dot=lambda a, b: MPI.COMM_WORLD.allreduce(float(a @ b)))


def shell_taylor_rates(shell, objective, design, step) -> tuple[list[float], list[float]]:
    """A growth shell's Taylor test (optim.taylor): J(m + h dm) - J(m) - h dJ.dm at h 0.1,
    0.05, 0.025 (``design`` m, ``step`` dm, both Functions of one space; J the UFL
    ``objective``, or a callable ``objective(gradient)`` returning J and dJ/dm, None where
    ``gradient`` is false, at the shell's equilibrium), and the rates at which it falls
    (collective)."""
    import dolfinx.fem
    import numpy as np
    import ufl

    from shapegrowth.optim.taylor import taylor_test

    comm = design.function_space.mesh.comm
    if isinstance(objective, ufl.Form):  # a Form is callable too (it replaces arguments)
        form = objective

        def objective(gradient: bool):
            if gradient:
                return shell.gradient(form)
            return comm.allreduce(dolfinx.fem.assemble_scalar(dolfinx.fem.form(form))), None

    owned = design.function_space.dofmap.index_map.size_local * \
        design.function_space.dofmap.index_map_bs

    def grown(m: np.ndarray) -> None:
        design.x.array[:] = m
        assert shell.solve().converged

    def J(m: np.ndarray) -> float:
        grown(m)
        return objective(False)[0]

    def dJ(m: np.ndarray) -> np.ndarray:
        grown(m)
        return objective(True)[1].x.array

    def dot(a: np.ndarray, b: np.ndarray) -> float:
        return comm.allreduce(float(a[:owned] @ b[:owned]))

    result = taylor_test(J, dJ, design.x.array.copy(), step.x.array, eps0=0.1, steps=2,
                         dot=dot)
    return result.residuals, result.rates


def lifted_shell(shell, stretches, config: str, size: float, folder: Path):
    """A growth shell's growth (``stretches``) lifted onto the 3D body of the YAML text
    ``config`` at mesh size ``size`` (written on rank 0 into ``folder``) and grown there from
    rest: optim.shell_lift's ShellLift (collective)."""
    from shapegrowth.config import load
    from shapegrowth.optim.shell_lift import lift_shell
    from shapegrowth.physics.model import ForwardModel

    comm = shell.mesh.comm
    path = folder / "solid.yaml"
    if comm.rank == 0:
        path.write_text(config)
    comm.barrier()
    solid = ForwardModel.build(load(path, [f"mesh.size={size}",
                                            f"output.dir={folder / 'out'}"]), comm)
    return lift_shell(shell, stretches, solid)


def run_cli(*args: str) -> int:
    """Run the CLI in this process (collectively under MPI); returns the exit status."""
    from shapegrowth.commands.cli import main

    return main([str(a) for a in args])


def stl_closed_volume(path: Path) -> float:
    """The volume a binary STL encloses (divergence theorem), after asserting that it is
    closed: its corners merged where equal, every edge bounds an even number of triangles."""
    import numpy as np

    record = np.dtype([("normal", "<f4", 3), ("v", "<f4", (3, 3)), ("attr", "<u2")])
    corners = np.frombuffer(Path(path).read_bytes()[84:], dtype=record)["v"]
    points, index = np.unique(corners.reshape(-1, 3).astype(float), axis=0,
                              return_inverse=True)
    triangles = index.reshape(-1, 3)
    edges = np.sort(np.concatenate([triangles[:, [0, 1]], triangles[:, [1, 2]],
                                    triangles[:, [2, 0]]]), axis=1)
    count = np.unique(edges, axis=0, return_counts=True)[1]
    assert np.all(count % 2 == 0), f"{path}: {np.sum(count % 2)} edges bound one triangle"
    p = points[triangles]
    return float(np.einsum("ij,ij->i", p[:, 0], np.cross(p[:, 1], p[:, 2])).sum() / 6)


def read_json(path: Path) -> dict:
    return json.loads(Path(path).read_text())


def run_program(cmd: list[str], ranks: int = 1, **kwargs) -> subprocess.CompletedProcess:
    """Run a command from the repository root, optionally under mpirun (the package's
    launcher: as root, oversubscribed beyond the cores), capturing its output."""
    from shapegrowth.commands.launch import launch

    return launch([], ranks, program=cmd, one_thread=False, capture_output=True, text=True,
                  cwd=ROOT, **kwargs)


def run_subprocess(args: list[str], ranks: int = 1, **kwargs) -> subprocess.CompletedProcess:
    """Run the installed console script, optionally under mpirun."""
    return run_program([BIN / "shapegrowth", *args], ranks, **kwargs)
