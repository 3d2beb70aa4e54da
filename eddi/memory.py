"""Keep the memory of freed large arrays in the process instead of handing it back to the system.

An identification makes and drops dozens of arrays of 3-7 MB (a 45 s record at 19.2 kHz: 883k
samples; the free response 460k). glibc's allocator serves such blocks by ``mmap`` (at and above a
threshold that starts at 128 KiB and follows the largest block freed) and returns freed memory at
the top of its heap once more than twice that is free (``trim``): the next call's arrays are
then new pages, each zeroed by the kernel at its first touch. Measured on the in-process identify
of that record (``run_identify``, session 18): ~5,000 page faults a call, 8-12 ms of system CPU
of ~80 ms; with the freed memory kept (below), none, and the user CPU the same.

:func:`keep_freed_memory` sets glibc's ``mmap`` threshold to its largest (32 MiB: every array of a
record up to ~4 M samples comes from the heap) and its trim threshold to 256 MiB (up to that much
freed memory at the heap's top stays with the process for its next arrays; the 45 s record needs
128 MiB for no faults, 64 MiB still faulted every call). The process then holds up to that much
more than it uses between calls instead of giving it back. It is a
process-wide setting, made once, by the engine's entry points (:class:`eddi.fit_record.Pipeline`'s
``condition`` and ``fit``); ``EDDI_KEEP_FREED_MEMORY=0`` in the environment leaves the allocator
alone (a host that wants the memory back: a Dask worker near its limit). Not glibc (macOS,
Windows, musl): nothing is done.
"""

from __future__ import annotations

import os

#: glibc's ``mallopt`` parameters (malloc.h): ``M_TRIM_THRESHOLD``, ``M_MMAP_THRESHOLD``.
_M_TRIM_THRESHOLD = -1
_M_MMAP_THRESHOLD = -3
#: Blocks below this come from the heap (glibc's largest allowed value on 64-bit: 32 MiB).
MMAP_THRESHOLD = 32 * 1024 * 1024
#: Free memory at the heap's top kept before any is given back.
TRIM_THRESHOLD = 256 * 1024 * 1024

#: Whether :func:`keep_freed_memory` was called (it acts once), and what it did.
_STATE: list = [None]


def keep_freed_memory() -> bool:
    """Ask glibc to keep freed memory for the process's next arrays (once; see the module notes).

    Returns whether the allocator was set (False: not glibc, or ``EDDI_KEEP_FREED_MEMORY=0``).
    """
    if _STATE[0] is not None:
        return _STATE[0]
    _STATE[0] = False
    if os.environ.get("EDDI_KEEP_FREED_MEMORY", "").strip() == "0":
        return False
    try:
        import ctypes  # numpy has imported it already

        mallopt = ctypes.CDLL(None).mallopt
    except (OSError, AttributeError):  # not glibc: nothing to set
        return False
    mallopt.argtypes = (ctypes.c_int, ctypes.c_int)
    mallopt.restype = ctypes.c_int
    _STATE[0] = bool(mallopt(_M_MMAP_THRESHOLD, MMAP_THRESHOLD)) and bool(mallopt(_M_TRIM_THRESHOLD, TRIM_THRESHOLD))
    return _STATE[0]
