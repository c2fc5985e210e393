"""How a training process uses the machine.

Measured on two cores (docs/results/speed.md, "The levers of a training step"): a training step allocates and
frees tensors of tens of megabytes (donkeycar's linear model: 55 MB for the first layer's activations of a batch of
128). glibc's malloc hands blocks that large out with mmap and returns them with munmap, so every step touches fresh
pages and the kernel zeroes them again: a quarter of a step. `keep_freed_memory` tells malloc to serve them from its
heap and keep what is freed there for the next step (the process's peak memory stays what it was; it is not given
back until the process ends)."""

from __future__ import annotations

import ctypes
import ctypes.util

_M_TRIM_THRESHOLD, _M_MMAP_MAX = -1, -4  # mallopt's parameters (malloc.h)
_done = False


def keep_freed_memory() -> bool:
    """Once per process, where the C library is glibc: large blocks from malloc's heap, and freed memory kept for
    reuse rather than given back to the system at once. Returns whether it applies (False elsewhere: musl, macOS)."""
    global _done
    if _done:
        return True
    name = ctypes.util.find_library("c")
    try:
        libc = ctypes.CDLL(name)
        mallopt = libc.mallopt
        libc.gnu_get_libc_version  # glibc's own: mallopt means what is assumed here
    except (OSError, AttributeError, TypeError):
        return False
    _done = bool(mallopt(_M_MMAP_MAX, 0)) and bool(mallopt(_M_TRIM_THRESHOLD, 1 << 30))
    return _done
