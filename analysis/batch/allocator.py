"""The memory allocator tuned for a process that decodes frames (glibc's thresholds)."""

from __future__ import annotations

__all__ = ["keep_frame_buffers"]

_ALLOCATOR_TUNED = False


def keep_frame_buffers() -> None:
    """Let glibc reuse freed frame-sized buffers instead of returning them to the kernel.

    Every frame allocates a few 0.3-1 MB temporaries; above glibc's default 128 KiB mmap
    threshold each is a fresh mmap, page-faulted and zeroed, then unmapped. That costs
    memory bandwidth that two workers on two cores share: with the threshold at 32 MiB,
    a batch with ``jobs=2`` ran ~1.5x faster here. glibc only; a no-op elsewhere.
    """
    global _ALLOCATOR_TUNED
    if _ALLOCATOR_TUNED:
        return
    _ALLOCATOR_TUNED = True
    import ctypes
    import ctypes.util

    name = ctypes.util.find_library("c")
    try:
        libc = ctypes.CDLL(name or "libc.so.6")
        mallopt = libc.mallopt
    except (OSError, AttributeError):
        return
    m_trim_threshold, m_mmap_threshold = -1, -3  # from glibc's malloc.h
    mallopt(m_mmap_threshold, 32 * 1024 * 1024)
    mallopt(m_trim_threshold, 128 * 1024 * 1024)
