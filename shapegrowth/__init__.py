"""shapegrowth: shape programming by differential growth in hyperelasticity.

Find the growth tensor field C_g that deforms a soft Mooney-Rivlin body into a
target shape (Ortigosa-Martinez et al., "Shape-programming in hyperelasticity
through differential growth", 2024).  See README.md for the map of modules to
the paper's equations.

The public API is flat::

    from shapegrowth import load_config, build_model, ReducedFunctional, taylor_test

Its names are imported on first use, so ``import shapegrowth`` loads no FEniCSx module
and changes nothing (the command line sets the BLAS threads before they load).
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from .version import __version__

# name -> (module, attribute)
_API = {
    "load_config": ("shapegrowth.config", "load"),
    "config_from_dict": ("shapegrowth.config", "from_dict"),
    "Config": ("shapegrowth.config", "Config"),
    "ConfigError": ("shapegrowth.errors", "ConfigError"),
    "InputError": ("shapegrowth.errors", "InputError"),
    "StateSolveError": ("shapegrowth.errors", "StateSolveError"),
    "ForwardModel": ("shapegrowth.physics.model", "ForwardModel"),
    "build_model": ("shapegrowth.physics.model", "build_model"),
    "Growth": ("shapegrowth.physics.growth", "Growth"),
    "StateProblem": ("shapegrowth.physics.state", "StateProblem"),
    "PointCloud": ("shapegrowth.shape.hausdorff", "PointCloud"),
    "SmoothHausdorff": ("shapegrowth.shape.hausdorff", "SmoothHausdorff"),
    "Objective": ("shapegrowth.optim.objective", "Objective"),
    "ReducedFunctional": ("shapegrowth.optim.problem", "ReducedFunctional"),
    "taylor_test": ("shapegrowth.optim.taylor", "taylor_test"),
    "Driver": ("shapegrowth.optim.driver", "Driver"),
    "DriverSettings": ("shapegrowth.optim.driver", "DriverSettings"),
    "Callback": ("shapegrowth.optim.interface", "Callback"),
    "Status": ("shapegrowth.status", "Status"),
    "Outcome": ("shapegrowth.status", "Outcome"),
    "RunSummary": ("shapegrowth.io.summary", "RunSummary"),
    "lift": ("shapegrowth.optim.lift", "lift"),
    "Lifted": ("shapegrowth.io.records", "Lifted"),
    "optimize": ("shapegrowth.commands.run", "run_optimization"),
    "solve": ("shapegrowth.commands.solve", "solve_forward"),
    "Sweep": ("shapegrowth.commands.study", "Sweep"),
    "run_study": ("shapegrowth.commands.study", "run_study"),
    "pareto_front": ("shapegrowth.commands.study", "pareto_front"),
    "evaluate_at": ("shapegrowth.compat", "evaluate_at_points"),
    "surface": ("shapegrowth.io.plotting", "surface"),
    "draw": ("shapegrowth.io.plotting", "draw"),
    "read_surface": ("shapegrowth.shape.surface_repair", "read_surface"),
    "write_stl": ("shapegrowth.shape.surface_formats", "write_stl"),
    "RigidFit": ("shapegrowth.shape.rigid_fit", "RigidFit"),
    "fit_yeoh": ("shapegrowth.config.lab_fits", "fit_yeoh"),
    "read_tensile_curve": ("shapegrowth.config.lab_fits", "read_tensile_curve"),
}
__all__ = [
    "__version__",
    "load_config",
    "config_from_dict",
    "Config",
    "ConfigError",
    "InputError",
    "StateSolveError",
    "ForwardModel",
    "build_model",
    "Growth",
    "StateProblem",
    "PointCloud",
    "SmoothHausdorff",
    "Objective",
    "ReducedFunctional",
    "taylor_test",
    "Driver",
    "DriverSettings",
    "Callback",
    "Status",
    "Outcome",
    "RunSummary",
    "lift",
    "Lifted",
    "optimize",
    "solve",
    "Sweep",
    "run_study",
    "pareto_front",
    "evaluate_at",
    "surface",
    "draw",
    "read_surface",
    "write_stl",
    "RigidFit",
    "fit_yeoh",
    "read_tensile_curve",
]

if TYPE_CHECKING:
    from .commands.run import run_optimization as optimize
    from .commands.solve import solve_forward as solve
    from .commands.study import Sweep, pareto_front, run_study
    from .compat import evaluate_at_points as evaluate_at
    from .config import Config
    from .config import from_dict as config_from_dict
    from .config import load as load_config
    from .config.lab_fits import fit_yeoh, read_tensile_curve
    from .errors import ConfigError, InputError, StateSolveError
    from .io.plotting import draw, surface
    from .io.records import Lifted
    from .io.summary import RunSummary
    from .optim.driver import Driver, DriverSettings
    from .optim.interface import Callback
    from .optim.lift import lift
    from .optim.objective import Objective
    from .optim.problem import ReducedFunctional
    from .optim.taylor import taylor_test
    from .physics.growth import Growth
    from .physics.model import ForwardModel, build_model
    from .physics.state import StateProblem
    from .shape.hausdorff import PointCloud, SmoothHausdorff
    from .shape.rigid_fit import RigidFit
    from .shape.surface_formats import write_stl
    from .shape.surface_repair import read_surface
    from .status import Outcome, Status


def __getattr__(name: str) -> Any:
    if name not in _API:
        raise AttributeError(f"module 'shapegrowth' has no attribute {name!r}")
    module, attribute = _API[name]
    # MPI before FEniCSx: the pip wheel of dolfinx finds its MPICH library through mpi4py
    # (imported after dolfinx it is not found without LD_LIBRARY_PATH); the command line
    # imports mpi4py first too
    importlib.import_module("mpi4py.MPI")
    value = getattr(importlib.import_module(module), attribute)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(__all__)
