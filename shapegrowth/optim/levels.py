"""Coarse-to-fine optimisation (``optimizer.levels``): each level optimises on the config's
mesh refined ``levels[k]`` times, starting from the design the last level ended with, carried
exactly (the refined meshes are nested in the coarse one: a Lagrange field of the design's
degree is the same function there).  The coarse levels are cheap and find the large-scale
design; the fine ones resolve what it leans on.  Later levels run at the last alpha of a
schedule and at the last sharpness of growth.levels' projection (the smooth start and the
continuation towards the levels are the coarse level's job: a fine level that started the
sharpness again at 1 undid the coarse level's near-crisp design, its J up six-fold on scene
1's section with two levels)."""

from __future__ import annotations

import dataclasses
from typing import Any

from ..config import Config
from .verification import refined_config


def level_budgets(cfg: Config) -> tuple[int, ...]:
    """Iterations per level.  ``optimizer.max_iterations`` is the whole budget, shared
    equally, or as ``optimizer.level_iterations`` says - scaled down in proportion (at
    least one per level) where those add up to more; the coarser levels take what rounding
    leaves."""
    opt = cfg.optimizer
    n, total = len(opt.levels), max(opt.max_iterations, len(opt.levels))
    shares = opt.level_iterations
    if shares is None:
        return tuple(total // n + (1 if k < total % n else 0) for k in range(n))
    if sum(shares) <= total:
        return tuple(shares)
    scaled = [max(1, int(s * total / sum(shares))) for s in shares]
    scaled[0] += total - sum(scaled)  # what rounding leaves (may take back from level 0)
    return tuple(max(1, s) for s in scaled)


def level_config(cfg: Config, k: int) -> Config:
    """The config of level ``k``: its mesh, its budget and (after the first) the last alpha
    and the last sharpness.
    A single level at refinement 0 is ``cfg`` itself."""
    opt = cfg.optimizer
    refine, budget = opt.levels[k], level_budgets(cfg)[k]
    changes: dict[str, Any] = {}
    if refine:
        changes["mesh"] = refined_config(cfg, refine).mesh
    if budget != opt.max_iterations:
        changes["optimizer"] = dataclasses.replace(opt, max_iterations=budget)
    hausdorff = cfg.objective.hausdorff
    if k > 0 and len(hausdorff.alphas) > 1:
        last = dataclasses.replace(hausdorff, alpha=hausdorff.alphas[-1])
        changes["objective"] = dataclasses.replace(cfg.objective, hausdorff=last)
    growth = cfg.growth
    if k > 0 and growth.levels is not None and len(growth.sharpness) > 1:
        changes["growth"] = dataclasses.replace(growth, sharpness=growth.sharpness[-1:])
    return dataclasses.replace(cfg, **changes) if changes else cfg
