"""The optimisation problem: the objective (shape term and complexity), the adjoint, the
reduced functional J(m) with its exact gradient, the Taylor test, and the NLopt driver.
Imports physics, shape and config; nothing above."""
