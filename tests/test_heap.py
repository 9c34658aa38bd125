"""heap.trim: freed heap pages back to the system (what keeps a second factorisation from
stacking on the first's freed memory in the resident size)."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from shapegrowth import heap


def _resident_mb() -> float:
    pages = int(Path("/proc/self/statm").read_text().split()[1])
    return pages * os.sysconf("SC_PAGE_SIZE") / 2**20


@pytest.mark.skipif(heap._malloc_trim() is None, reason="the C library has no malloc_trim")
def test_trim_hands_freed_heap_pages_back():
    """200 MB in 2 KB blocks (malloc's heap, below its mmap threshold), freed but the last,
    which pins the heap's top: the process keeps them until trimmed."""
    blocks = [bytearray(2048) for _ in range(100_000)]
    for block in blocks:  # touched: resident
        block[0] = 1
    last = blocks[-1]
    del blocks
    before = _resident_mb()
    assert heap.trim()
    after = _resident_mb()
    assert before - after > 100.0, (before, after)
    assert last[0] == 1  # what is still held stays
