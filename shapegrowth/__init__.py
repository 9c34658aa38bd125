"""shapegrowth: shape programming by differential growth in hyperelasticity.

Find the growth tensor field C_g that deforms a soft Mooney-Rivlin body into a
target shape (Ortigosa-Martinez et al., "Shape-programming in hyperelasticity
through differential growth", 2024).  See README.md for the map of modules to
the paper's equations.
"""

__version__ = "0.1.0"
