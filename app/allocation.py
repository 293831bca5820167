"""How this process asks the system for memory, set where a command's peak is large arrays.

``seedtrack track`` on a million points builds and frees arrays of 1 to 16 MB, one stage after
another. By default glibc serves an array freed and asked for again from its heap once the first
one of that size is freed (its mmap threshold rises up to 32 MB), and keeps what is freed there
resident; numpy asks the kernel to back every array of 4 MB or more with 2 MB huge pages. Both
leave the resident set well above what the live arrays need: on 10,000 walkers x 100 frames
(tests/benchmarks/bench_memory.py) they were about 25 MB of a 320 MB peak. Neither changes a
result.
"""

from __future__ import annotations

import ctypes
import ctypes.util

import numpy as np

# glibc's mallopt settings: the free memory its heap keeps rather than gives back, and the size
# from which a block is mapped on its own (returned to the system when freed); setting the
# latter also stops glibc from raising it.
M_TRIM_THRESHOLD, M_MMAP_THRESHOLD = -1, -3
_MAPPED_FROM = 256 * 1024


def set_malloc_options(**settings: int) -> None:
    """Set glibc's ``mallopt`` options for this process, by name of their constant in this module
    (no-op where the C library is not glibc).

    Example
    -------
    >>> set_malloc_options(M_MMAP_THRESHOLD=32 * 1024 * 1024)
    """
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6")
        for name, value in settings.items():
            libc.mallopt(globals()[name], value)
    except (OSError, AttributeError):
        pass  # not glibc


def return_freed_memory() -> None:
    """From now on in this process, give large freed arrays back to the system at once, and back
    arrays with ordinary pages (no-op where the C library is not glibc).

    Example
    -------
    >>> return_freed_memory()
    """
    # numpy's switch for huge pages (the NUMPY_MADVISE_HUGEPAGE variable is read only at import).
    set_huge_pages = getattr(np._core.multiarray, "_set_madvise_hugepage", None)
    if set_huge_pages is not None:
        set_huge_pages(False)
    set_malloc_options(M_MMAP_THRESHOLD=_MAPPED_FROM)
