"""When this process started, on the clock deadlines use (``time.perf_counter``).

A command's deadline holds in the wall time its caller sees, Python's own start-up and the
imports included. Linux gives a process's start in ``/proc/self/stat`` (in clock ticks since
boot) beside the time since boot in ``/proc/uptime``; elsewhere the start is taken as the
moment this module is first imported.
"""

from __future__ import annotations

import contextlib
import os
import sys
import time

_IMPORTED = time.perf_counter()

AT_ONCE = False
"""Whether the console command ends the process as soon as its answer is out
(:func:`end_at_once`)."""


def end_at_once() -> None:
    """Have the console command end the process as soon as its answer is written and printed,
    without the interpreter's clean-up of the planner's objects (tenths of a second): a command
    on a deadline (``stlplan replan --deadline``)."""
    global AT_ONCE
    AT_ONCE = True


def exit_now(code: object) -> None:
    """End the process with ``code`` (as :class:`SystemExit` reads it), output flushed."""
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(code if isinstance(code, int) else 0 if code is None else 1)


def process_start() -> float:
    """The ``time.perf_counter`` value at which this process started (module docstring)."""
    with contextlib.suppress(OSError, ValueError, IndexError, AttributeError):
        with open("/proc/self/stat", encoding="ascii") as f:
            fields = f.read().rpartition(")")[2].split()
        with open("/proc/uptime", encoding="ascii") as f:
            uptime = float(f.read().split()[0])
        ticks = os.sysconf("SC_CLK_TCK")
        started_ago = uptime - int(fields[19]) / ticks  # field 22: starttime
        return time.perf_counter() - max(0.0, started_ago)
    return _IMPORTED
