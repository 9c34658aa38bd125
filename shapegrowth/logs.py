"""Logging for the ``shapegrowth`` logger: progress lines from rank 0 only."""

from __future__ import annotations

import logging
import sys

from mpi4py import MPI


def configure(level: int = logging.INFO, comm: MPI.Comm = MPI.COMM_WORLD) -> None:
    """Send the package's log records to stdout on rank 0; silence the other ranks."""
    quiet_jit()
    logger = logging.getLogger("shapegrowth")
    for handler in list(logger.handlers):
        logger.removeHandler(handler)
    logger.propagate = False
    if comm.rank == 0:
        handler = logging.StreamHandler(sys.stdout)
        handler.setFormatter(logging.Formatter("%(message)s"))
        logger.addHandler(handler)
        logger.setLevel(level)
    else:
        logger.addHandler(logging.NullHandler())
        logger.setLevel(logging.CRITICAL + 1)


def quiet_jit() -> None:
    """Keep the form compiler's chatter out of the output.

    ffcx calls ``logging.basicConfig()`` when imported, and distutils lowers the
    root logger to INFO while it compiles, which would print every compiler
    command; the root handlers are held at WARNING instead.
    """
    import ffcx  # noqa: F401  (its import installs the root handler)

    for handler in logging.getLogger().handlers:
        handler.setLevel(logging.WARNING)
