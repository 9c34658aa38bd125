"""Freed memory handed back to the system.

A factorisation's memory that MUMPS frees stays with the process: glibc's allocator keeps
freed pages for its own later use, and a process's resident size (its peak, summary.json
``peak_memory_mb``) counts them.  Where a large solver frees much and another allocates much
next (the state's Newton factor, then the stability's shift-and-invert factor), :func:`trim`
between them hands the free pages back (glibc's ``malloc_trim``), so that the second does
not stack on the first.  Measured: scene 1's beam grown from rest out of core with its path's
stability watched, 2 ranks, peak 796 -> 559 MB at 21k DOFs (docs/PERFORMANCE.md, "Out of
core").  Where the C library has no ``malloc_trim`` (not glibc), nothing is done.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import functools
from collections.abc import Callable


@functools.cache
def _malloc_trim() -> Callable[[int], int] | None:
    name = ctypes.util.find_library("c")
    try:
        libc = ctypes.CDLL(name)
        function = libc.malloc_trim
    except (OSError, AttributeError, TypeError):
        return None
    function.argtypes, function.restype = [ctypes.c_size_t], ctypes.c_int
    return function


def trim() -> bool:
    """Hand this process's freed heap pages back to the system (glibc's ``malloc_trim(0)``);
    whether any were (False also where the C library cannot)."""
    function = _malloc_trim()
    return bool(function(0)) if function is not None else False
