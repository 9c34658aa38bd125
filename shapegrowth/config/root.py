"""The whole config, :class:`Config`: valid by construction.

The loader (loading.py) builds it from YAML through the schema (schema.py) and the cross-field
rules (checks.py); a ``Config`` made any other way - in Python, or by ``dataclasses.replace``
of a loaded one - goes through the same conversion, checks and resolution in
``__post_init__``, so no ``Config`` holds an invalid value or an unresolved default."""

from __future__ import annotations

import dataclasses
from collections.abc import Iterator
from contextlib import contextmanager
from contextvars import ContextVar
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from .checks import resolve_and_check
from .numerics import (
    ObjectiveConfig,
    OptimizerConfig,
    OutputConfig,
    SolverConfig,
    VerifyConfig,
)
from .reduction import Section, section_of
from .schema import build, option
from .sections import (
    GEOMETRY_PARAMS,
    BoundaryConfig,
    ConfigError,
    GeometryConfig,
    GrowthConfig,
    LoadsConfig,
    MaterialConfig,
    MeshConfig,
    ModelConfig,
    TargetConfig,
)

# True while the loader builds a Config (its parts are checked once, when it is whole)
_TRUSTED: ContextVar[bool] = ContextVar("shapegrowth_config_trusted", default=False)


@contextmanager
def _trusted() -> Iterator[None]:
    token = _TRUSTED.set(True)
    try:
        yield
    finally:
        _TRUSTED.reset(token)


def validated(raw: dict[str, Any], errors: list[str]) -> Config | None:
    """The Config of mapping ``raw``: the schema's types and ranges, then the cross-field
    rules and the defaults that depend on other keys; each problem appended to ``errors``."""
    with _trusted():
        cfg = build(Config, raw, "", errors)
        if cfg is not None:
            cfg = resolve_and_check(cfg, errors)
    return cfg


@dataclass(frozen=True)
class Config:
    name: str = option("name of the run")
    geometry: GeometryConfig = option("reference body")
    mesh: MeshConfig = option("mesh generation")
    boundary: BoundaryConfig = option("Dirichlet data")
    parameters: dict[str, float] = option("extra named numbers usable in expressions", {})
    model: ModelConfig = option("discretisation", ModelConfig())
    material: MaterialConfig = option("material", MaterialConfig())
    loads: LoadsConfig = option("external loads", LoadsConfig())
    growth: GrowthConfig = option("growth tensor C_g (5.2)-(5.5)", GrowthConfig())
    target: TargetConfig | None = option("target shape", None)
    objective: ObjectiveConfig = option("objective", ObjectiveConfig())
    optimizer: OptimizerConfig = option("optimiser", OptimizerConfig())
    solver: SolverConfig = option("state solver", SolverConfig())
    verify: VerifyConfig = option("the verified shape error of a run", VerifyConfig())
    output: OutputConfig = option("outputs", OutputConfig())

    # ---- derived views used across the package -------------------------------------------
    @property
    def dim(self) -> int:
        return self.model.dim

    @property
    def section(self) -> Section:
        """What the mesh stands for: the solid, a plane body, or a reduced 3D body."""
        m = self.model
        return section_of(m.dim, self.geometry.kind, m.reduction)

    @property
    def growth_dim(self) -> int:
        """Eigen-directions of C_g: 3 for a 3D body, reduced or not; 2 for a plane body."""
        return 3 if self.model.dim == 3 or self.section.reduced or self.shell else 2

    @property
    def shell(self) -> bool:
        """A thin 3D body modelled by its mid-surface's growth shell (model.reduction)."""
        return self.model.dim == 2 and self.model.reduction == "shell"

    @property
    def expression_params(self) -> dict[str, float]:
        """Numbers an expression may name: geometry parameters and ``parameters``."""
        names = {k: getattr(self.geometry, k) for k in GEOMETRY_PARAMS[self.geometry.kind]}
        names.update(self.parameters)
        return {k: float(v) for k, v in names.items() if v is not None}

    @property
    def cylinder_axis(self) -> int:
        """Axis of ``r, theta`` in expressions: X1 for a tube, X3 otherwise."""
        return 1 if self.geometry.kind == "tube" else 3

    @property
    def output_dir(self) -> Path:
        return Path(self.output.dir or f"results/{self.name}")

    @property
    def quadrature_degree(self) -> int:
        return self.model.quadrature_degree or 2 * self.model.degree

    def to_dict(self) -> dict[str, Any]:
        return dataclasses.asdict(self)

    def __post_init__(self) -> None:
        """A Config made in Python (``Config(...)``, ``dataclasses.replace``) is converted,
        checked and resolved as a loaded one is: every problem raised together as one
        :class:`ConfigError`, and no field left at an unresolved ``None`` default."""
        if _TRUSTED.get():
            return  # made by the loader, which checks the whole once it is built
        errors: list[str] = []
        cfg = validated(self.to_dict(), errors)
        if errors or cfg is None:
            raise ConfigError(errors or ["config: not a valid config"])
        for f in dataclasses.fields(self):
            object.__setattr__(self, f.name, getattr(cfg, f.name))
