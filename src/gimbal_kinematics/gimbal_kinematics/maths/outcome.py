"""What one call of an estimator or controller core did with its sample, returned by the
call so that a node reads it instead of comparing the core's counters before and after.

:class:`Fed`: the sample ``used`` or ``why`` not (None: used, or nothing to say), the
``output`` it completed (None: none), its NIS contribution (``nis``: the normalised
innovation squared of the update it made; None: no update) and the (t, reason) of each
re-start it made on its own (a re-alignment). The counters stay in the core, for
/diagnostics.
"""
from __future__ import annotations

from typing import Any, NamedTuple


class Fed(NamedTuple):
    """One core call's outcome (module docstring)."""

    used: bool
    why: str | None = None
    output: Any = None
    realigned: tuple[tuple[float, str], ...] = ()
    nis: float | None = None


def refused(why: str) -> Fed:
    """The :class:`Fed` of a sample the core did not use, and why."""
    return Fed(False, why)
