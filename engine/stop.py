"""Stop requests (Ctrl-C, SIGTERM) for a run, seen between steps and inside a step.

:func:`engine.step.run` installs handlers that call :func:`request`; the `nscd` command does
too from its start, so a signal that comes before the run (while a sample is built, or numba
loads its cache) is not lost.  The run looks at :func:`requested` after every step, and the
NLGS loop of a step every few hundred sweeps (:func:`check`, :data:`CHECK_WORK`): a long
step then ends early, :class:`StepInterrupted`, and the run puts the state back as it was
before that step.

Python runs a signal handler only between two bytecodes, never inside a numba kernel: the
kernels are therefore called in chunks of sweeps (:func:`sweeps_between_checks`), whose
results are bit for bit those of one call.
"""
from __future__ import annotations

#: Work between two looks at a stop request inside a step: contact (or link) updates, about
#: 40 ms at the ~21 ns of one update (``docs/speed.md``).
CHECK_WORK = 2_000_000
#: Fewest sweeps between two looks (a paper-scale step of 90 000 contacts: ~0.12 s).
MIN_SWEEPS = 64

_requested = False
_watching = 0


class StepInterrupted(Exception):
    """A stop request seen inside a step: the step was not finished (the run that called
    it puts the state back as it was before the step)."""


def request() -> None:
    """Ask the run going on (or the next one) to stop (what the signal handlers call)."""
    global _requested
    _requested = True


def requested() -> bool:
    return _requested


def clear() -> None:
    """Forget a stop request (the run that honoured it calls this)."""
    global _requested
    _requested = False
_watching = 0


def check() -> None:
    """Raise :class:`StepInterrupted` if a stop was requested."""
    if _requested:
        raise StepInterrupted("stop requested inside a step")


class watching:
    """Within it, NLGS loops look at stop requests (:func:`engine.step.run` enters it for a
    step it can undo); a bare :func:`engine.step.step` runs its loop in one call."""

    def __enter__(self):
        global _watching
        _watching += 1
        return self

    def __exit__(self, *exc):
        global _watching
        _watching -= 1


def is_watching() -> bool:
    return _watching > 0


def sweeps_between_checks(n_contacts: int, n_links: int) -> int:
    """Sweeps of a step's NLGS loop between two looks at a stop request."""
    return max(MIN_SWEEPS, CHECK_WORK // max(int(n_contacts) + int(n_links), 1))


def in_chunks(call, max_iter: int, tol: float, n_work: int):
    """``call(done, m) -> (sweeps, residual)`` runs up to ``m`` more sweeps after ``done``;
    called in chunks of :func:`sweeps_between_checks` sweeps (for ``n_work`` contacts and
    links) until the residual is below ``tol`` or ``max_iter`` sweeps are done, with
    :func:`check` between two chunks.  One call outside :class:`watching`, or when
    ``max_iter`` is within one chunk.  Returns (sweeps, residual)."""
    every = sweeps_between_checks(n_work, 0)
    if not _watching or max_iter <= every:
        return call(0, max_iter)
    done = 0
    while True:
        m = min(every, max_iter - done)
        it, res = call(done, m)
        done += int(it)
        if it < m or res < tol or done >= max_iter:
            return done, res
        check()


__all__ = ["StepInterrupted", "request", "requested", "clear", "check", "watching",
           "is_watching",
           "sweeps_between_checks", "in_chunks", "CHECK_WORK", "MIN_SWEEPS"]
