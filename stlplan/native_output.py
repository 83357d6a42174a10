"""What native code prints on file descriptor 1, kept off stdout.

HiGHS prints a banner (``Running HiGHS ...``) with ``printf`` the first time a process makes a
``highspy.Highs`` object, before any option can turn its output off; Pyomo's HiGHS interface
makes that object inside the planner. :func:`discard_highs_banner` makes the first one with file
descriptor 1 pointed at ``/dev/null``, so the banner never reaches the stdout of a program that
plans through :mod:`stlplan.api`. The command line also points file descriptor 1 elsewhere for
the whole solve (:func:`fd1_redirected`), for anything else native code may print.
"""

from __future__ import annotations

import contextlib
import ctypes
import os
import sys
from collections.abc import Iterator

_BANNER = {"discarded": False}


def _flush_native() -> None:
    """Flush the C library's output buffers (what native code printed with ``printf``)."""
    with contextlib.suppress(OSError, AttributeError, TypeError):
        ctypes.CDLL(None).fflush(None)


@contextlib.contextmanager
def fd1_redirected(discard: bool) -> Iterator[None]:
    """Point file descriptor 1 at stderr (or, with ``discard``, at ``/dev/null``) for the block;
    Python's ``sys.stdout`` and the C library's buffers are flushed on either side."""
    sys.stdout.flush()
    try:
        saved = os.dup(1)
        target = os.open(os.devnull, os.O_WRONLY) if discard else os.dup(2)
    except OSError:  # no file descriptor 1: nothing can reach stdout
        yield
        return
    try:
        os.dup2(target, 1)
        yield
    finally:
        sys.stdout.flush()
        _flush_native()
        os.dup2(saved, 1)
        os.close(saved)
        os.close(target)


def discard_highs_banner() -> None:
    """Make this process's first ``highspy.Highs`` object with its banner discarded (once)."""
    if _BANNER["discarded"]:
        return
    import highspy

    with fd1_redirected(discard=True):
        highspy.Highs()
    _BANNER["discarded"] = True
