"""Yeoh constants from a uniaxial tensile curve: how the lab presets were fitted, and how a
user fits their own elastomer.

An incompressible Yeoh solid W0 = c10 (I1 - 3) + c20 (I1 - 3)^2 + c30 (I1 - 3)^3 stretched by
lambda along one axis (I1 = lambda^2 + 2/lambda) carries the nominal (engineering) stress

    P(lambda) = 2 (lambda - lambda^-2) (c10 + 2 c20 (I1 - 3) + 3 c30 (I1 - 3)^2),

linear in the constants. :func:`fit_yeoh` solves that least-squares problem with the
constants held non-negative (scipy's NNLS on columns scaled to unit size), so that
dW0/dI1 > 0 at every strain: the fitted solid is stable beyond the range it was fitted on,
where an unconstrained fit of the silicones' S-shaped curves gives c30 < 0 and a solid that
softens without bound past the data.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.optimize import nnls

from ..errors import InputError


@dataclass(frozen=True)
class YeohFit:
    """The constants (the stress's unit: MPa for the presets) and how well they fit."""

    c10: float
    c20: float
    c30: float
    points: int  # the tensile curve's points within the stretch range fitted
    largest_stretch: float  # the range fitted: 1 < lambda <= largest_stretch
    rms: float  # the residual's root mean square, relative to the largest stress fitted
    worst: float  # the largest residual, relative to the largest stress fitted

    @property
    def shear_modulus(self) -> float:
        """The small-strain shear modulus 2 c10."""
        return 2 * self.c10


def yeoh_nominal_stress(c: tuple[float, float, float], stretch: np.ndarray) -> np.ndarray:
    """P(lambda) of an incompressible Yeoh solid in uniaxial tension (the module's formula)."""
    return _columns(np.asarray(stretch, dtype=float)) @ np.asarray(c, dtype=float)


def fit_yeoh(strain: np.ndarray, stress: np.ndarray, largest_stretch: float = 3.0) -> YeohFit:
    """Non-negative Yeoh constants of a uniaxial curve: ``strain`` engineering
    (lambda - 1), ``stress`` nominal (force over the undeformed section), fitted on the
    points with 1 < lambda <= ``largest_stretch``."""
    stretch = 1 + np.asarray(strain, dtype=float)
    stress = np.asarray(stress, dtype=float)
    if stretch.shape != stress.shape or stretch.ndim != 1:
        raise InputError("a tensile curve: strain and stress of the same length")
    keep = (stretch > 1) & (stretch <= largest_stretch)
    if keep.sum() < 3:
        raise InputError(f"a tensile curve: {int(keep.sum())} points with 1 < stretch <= "
                         f"{largest_stretch}; give at least 3")
    A = _columns(stretch[keep])
    scale = np.abs(A).max(axis=0)
    c, _ = nnls(A / scale, stress[keep])
    c = c / scale
    residual = A @ c - stress[keep]
    top = float(np.abs(stress[keep]).max())
    return YeohFit(c10=float(c[0]), c20=float(c[1]), c30=float(c[2]), points=int(keep.sum()),
                   largest_stretch=largest_stretch,
                   rms=float(np.sqrt(np.mean(residual ** 2))) / top,
                   worst=float(np.abs(residual).max()) / top)


def read_tensile_curve(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """Engineering strain and stress from a ``;``-separated file whose header row names
    ``Engineering Strain`` and ``Engineering Stress`` (the lab presets' data files, and the
    Soft Robotics Materials Database's); the rows above it (the test's description) are
    skipped."""
    lines = Path(path).read_text(encoding="utf-8").splitlines()
    found = next(((i, c) for i, line in enumerate(lines) if (c := _header(line))), None)
    if found is None:
        raise InputError(f"{path}: no header row naming 'Engineering Strain' and "
                         "'Engineering Stress'")
    first, columns = found[0] + 1, found[1]
    data = []
    for k, row in enumerate(lines[first:], start=first + 1):
        if not row.strip():
            continue
        fields = row.split(";")
        try:
            data.append((float(fields[columns[0]]), float(fields[columns[1]])))
        except (ValueError, IndexError):
            raise InputError(f"{path}, line {k}: no numbers in the engineering strain and "
                             f"stress columns ({row.strip()!r})") from None
    if not data:
        raise InputError(f"{path}: no rows under its header row")
    values = np.array(data)
    return values[:, 0], values[:, 1]


def _header(line: str) -> tuple[int, int] | None:
    """The columns of the engineering strain and stress where ``line`` names both."""
    names = [name.strip() for name in line.split(";")]
    stress = [k for k, name in enumerate(names) if name.startswith("Engineering Stress")]
    if "Engineering Strain" in names and stress:
        return names.index("Engineering Strain"), stress[0]
    return None


def _columns(stretch: np.ndarray) -> np.ndarray:
    """dP/dc10, dP/dc20, dP/dc30 at each stretch."""
    i1 = stretch ** 2 + 2 / stretch - 3
    g = 2 * (stretch - stretch ** -2)
    return np.stack([g, 2 * g * i1, 3 * g * i1 ** 2], axis=1)
