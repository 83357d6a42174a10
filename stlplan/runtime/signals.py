"""Stop requests: Ctrl-C or SIGTERM while HiGHS works ends the solve at its next callback.

A signal handler that raised ``KeyboardInterrupt`` inside HiGHS would unwind through C++ and lose
the incumbent. While planning in the main thread, :func:`stop_on_signals` installs handlers that
only record the request when a solve is running; every :class:`stlplan.planner.backend.session.HighsSession`
polls :func:`should_interrupt` from HiGHS's callbacks and interrupts. The planner then keeps the
best plan found so far (verified by the monitor like any other) with status ``interrupted``.

A second signal is a hard stop: every solve ends at once and nothing is kept. Outside a solve
(building the model, writing outputs) a signal raises :class:`Interrupted` straight away.
"""

from __future__ import annotations

import signal
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from types import FrameType
from typing import Any

CAUGHT = (signal.SIGINT, signal.SIGTERM)


class Interrupted(KeyboardInterrupt):
    """Planning stopped by a signal before anything could be kept."""

    def __init__(self, signum: int = signal.SIGINT) -> None:
        super().__init__(signal.Signals(signum).name)
        self.signum = signum

    @property
    def exit_code(self) -> int:
        """The shell's convention: 128 plus the signal number (130 for Ctrl-C, 143 for TERM)."""
        return 128 + self.signum


@dataclass
class StopState:
    """The request of the current planning call.

    Attributes
    ----------
    signum
        The first signal received, or None.
    hard
        A second signal arrived: stop everything, keep nothing.
    solving
        How many HiGHS solves are running (a signal outside one raises at once).
    depth
        Nested :func:`stop_on_signals` calls (the outermost owns the handlers).
    finishing
        Nested :func:`finishing` blocks: solves that turn the best plan so far into an output.
    enabled
        False in processes whose parent handles signals (:func:`leave_signals_alone`).
    """

    signum: int | None = None
    hard: bool = False
    solving: int = 0
    depth: int = 0
    finishing: int = 0
    enabled: bool = True


STATE = StopState()
_COUNT = threading.Lock()
_LEFT_BEHIND = threading.Event()
_BEHIND: list[threading.Thread] = []


def requested() -> bool:
    """Whether a stop was requested during the current planning call (False outside one)."""
    return STATE.depth > 0 and STATE.signum is not None


def last_signal() -> int | None:
    """The signal that stopped the last planning call (for the exit code), or None."""
    return STATE.signum


def should_interrupt() -> bool:
    """Whether a running solve must stop (inside :func:`finishing`, only on a hard stop), or
    belongs to a search a deadline left behind (:func:`leave_behind`)."""
    return _LEFT_BEHIND.is_set() or (requested() and (STATE.hard or not STATE.finishing))


class LeftBehind(BaseException):
    """Raised in a search a replan's deadline left behind, at its next look at its budget: it
    unwinds at once (:func:`leave_behind`)."""


def leave_behind(search: threading.Thread) -> None:
    """Stop every running solve at its next callback: ``search``, the search a replan's deadline
    left behind (:mod:`stlplan.deadline`), ends as soon as it can: its solves stop at their next
    callback, and its next look at a budget raises :class:`LeftBehind` (:func:`left_behind`)."""
    with _COUNT:
        _BEHIND.append(search)
        _LEFT_BEHIND.set()


def caught_up(search: threading.Thread) -> None:
    """``search`` has ended: once no search is left behind, solves run again."""
    with _COUNT:
        if search in _BEHIND:
            _BEHIND.remove(search)
        if not _BEHIND:
            _LEFT_BEHIND.clear()


def left_behind() -> bool:
    """Whether the running search is one a deadline left behind (:func:`leave_behind`): its
    budgets are spent."""
    return _LEFT_BEHIND.is_set()


def catch_up(timeout: float | None = None) -> bool:
    """Wait for the searches left behind to end (at most ``timeout`` seconds in all), then let
    solves run again; whether they have ended. Every planning run starts with this (in a search
    left behind, it does nothing). A planning run in another thread at the same time as a search
    left behind has its solves stopped too: the flag is the process's."""
    if threading.current_thread() in _BEHIND:
        return True
    end = None if timeout is None else time.perf_counter() + timeout
    for search in list(_BEHIND):
        search.join(None if end is None else max(0.0, end - time.perf_counter()))
        if search.is_alive():
            return False
        caught_up(search)
    return True


@contextmanager
def finishing() -> Iterator[None]:
    """Solves that turn the best plan so far into an output: a first request does not stop them."""
    STATE.finishing += 1
    try:
        yield
    finally:
        STATE.finishing -= 1


def raise_if_hard() -> None:
    """Raise :class:`Interrupted` after a hard stop."""
    if requested() and STATE.hard and STATE.signum is not None:
        raise Interrupted(STATE.signum)


@contextmanager
def solving() -> Iterator[None]:
    """Mark a HiGHS solve as running (signals then only record the request); solves in two
    threads count one at a time."""
    with _COUNT:
        STATE.solving += 1
    try:
        yield
    finally:
        with _COUNT:
            STATE.solving -= 1


def _on_signal(signum: int, frame: FrameType | None) -> None:
    if STATE.solving == 0:
        STATE.signum = STATE.signum or signum
        raise Interrupted(signum)
    if STATE.signum is not None:
        STATE.hard = True
    else:
        STATE.signum = signum


@contextmanager
def held() -> Iterator[None]:
    """Hold SIGINT and SIGTERM back during a short critical section; they arrive after it.

    The signals are blocked for the calling thread and, in the main thread, their handlers are
    replaced by one that only records them: a signal the kernel hands to another thread (HiGHS's
    workers, say) still runs its Python handler in the main thread, where blocking does not
    reach. A recorded signal is raised again, with the earlier handlers back, on leaving.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    arrived: list[int] = []

    def record(signum: int, frame: FrameType | None) -> None:
        arrived.append(signum)

    before = _block()
    saved = {s: signal.signal(s, record) for s in CAUGHT}
    try:
        yield
    finally:
        for s, handler in saved.items():
            if signal.getsignal(s) is record:  # a handler set inside the section stays
                signal.signal(s, handler)
        _unblock(before)
        for signum in dict.fromkeys(arrived):
            signal.raise_signal(signum)


def _block() -> Any:
    """Block the caught signals for this thread; returns the earlier mask (None if unsupported)."""
    if not hasattr(signal, "pthread_sigmask"):
        return None
    return signal.pthread_sigmask(signal.SIG_BLOCK, CAUGHT)


def _unblock(before: Any) -> None:
    if before is not None:
        signal.pthread_sigmask(signal.SIG_SETMASK, before)


def leave_signals_alone() -> None:
    """Never install handlers in this process (a pool worker, stopped by its parent)."""
    STATE.enabled, STATE.depth, STATE.signum, STATE.hard = False, 0, None, False


@contextmanager
def stop_on_signals() -> Iterator[None]:
    """Handle SIGINT and SIGTERM as stop requests for the duration of one planning call.

    Only in the main thread, and only for signals whose handler is Python's default (a caller
    that ignores SIGINT, like a pool worker, keeps ignoring it). The previous handlers come back
    on exit. The request state is reset on entry; nested calls share the outer one.
    """
    if (
        STATE.depth
        or not STATE.enabled
        or threading.current_thread() is not threading.main_thread()
    ):
        yield
        return
    defaults = (signal.default_int_handler, signal.SIG_DFL)
    previous = {c: h for c in CAUGHT if (h := signal.getsignal(c)) in defaults}
    with held():  # installed together with the state, or not at all
        STATE.signum, STATE.hard, STATE.solving, STATE.finishing = None, False, 0, 0
        for caught in previous:
            signal.signal(caught, _on_signal)
        STATE.depth += 1
    try:
        yield
    finally:
        with held():
            STATE.depth -= 1
            for signum, handler in previous.items():
                signal.signal(signum, handler)
