"""Verdict on a message stamp, shared by every message-driven core.

A stamp that is not finite is rejected; one at or before the previous stamp is rejected
as out of order unless it lies more than ``backward_jump_s`` before it, which is a clock
jump (e.g. a bag looping) that calls for a reset rather than a silent rejection.
"""
from __future__ import annotations

import math
from enum import Enum


class Stamp(Enum):
    OK = "ok"
    NONFINITE = "nonfinite"
    OUT_OF_ORDER = "out_of_order"
    JUMPED_BACK = "jumped_back"


def check_stamp(t: float, last: float | None, backward_jump_s: float) -> Stamp:
    """Classify stamp ``t`` [s] against the previous accepted stamp ``last`` [s]."""
    if not math.isfinite(t):
        return Stamp.NONFINITE
    if last is not None and t <= last:
        return Stamp.JUMPED_BACK if last - t > backward_jump_s else Stamp.OUT_OF_ORDER
    return Stamp.OK


class StampGate:
    """Mixin for a core with ``rejected_nonfinite`` and ``rejected_out_of_order`` counters,
    ``reset(reason)`` and ``params.backward_jump_s``: counts a rejected stamp and resets on a
    clock jump (the stamp is then accepted as the first of a new run)."""

    def _stamp_ok(self, t: float, last: float | None, stream: str) -> bool:
        verdict = check_stamp(t, last, self.params.backward_jump_s)
        if verdict is Stamp.NONFINITE:
            self.rejected_nonfinite += 1
        elif verdict is Stamp.OUT_OF_ORDER:
            self.rejected_out_of_order += 1
        elif verdict is Stamp.JUMPED_BACK:
            self.reset(f"{stream} stamp jumped back {last - t:.3f} s (t={t:.3f})")
            return True
        return verdict is Stamp.OK
