"""Shapes as weighted point clouds: the body's and the target's clouds, the smooth
Hausdorff distance rho_H (2.9) with its kernels and cell grid, and the debiased shape
divergence.  Imports the config layer and nothing above it."""
