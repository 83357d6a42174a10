"""Pyomo's HiGHS interface without its capture of the process's output, for the planner.

Around every solve, Pyomo's HiGHS interface points the process's file descriptors 1 and 2 and
Python's ``sys.stdout`` and ``sys.stderr`` at a stream of its own, and back afterwards. Two
solves in two threads (parts solved side by side, :mod:`stlplan.planner.core.side_by_side`) would
restore each other's streams out of order. The planner turns HiGHS's output off
(``output_flag``) and keeps its banner off stdout (:mod:`stlplan.native_output`), so its solves
need no capture: within :func:`solves`, in the calling thread only, the interface captures
nothing. Any other use of Pyomo's HiGHS interface in the process is left as it was.
"""

from __future__ import annotations

import contextlib
import threading
from collections.abc import Iterator
from typing import Any

import pyomo.contrib.solver.solvers.highs as _pyomo_highs

_CAPTURE = _pyomo_highs.capture_output
_OURS = threading.local()


def _capture_unless_planning(*args: Any, **kwargs: Any) -> Any:
    if getattr(_OURS, "depth", 0):
        return contextlib.nullcontext()
    return _CAPTURE(*args, **kwargs)


_pyomo_highs.capture_output = _capture_unless_planning


@contextlib.contextmanager
def solves() -> Iterator[None]:
    """The block's HiGHS calls through Pyomo, in this thread, capture no output."""
    _OURS.depth = getattr(_OURS, "depth", 0) + 1
    try:
        yield
    finally:
        _OURS.depth -= 1
