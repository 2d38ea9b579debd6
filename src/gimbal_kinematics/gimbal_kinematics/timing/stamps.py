"""The one stamp vocabulary: a verdict on each stamp and the rule that counts dropped
samples (pure Python, no rclpy). Every stamp check of the project uses it: the input
policies' (:mod:`gimbal_kinematics.timing.input_policy`), the free-timing ones
(:class:`gimbal_kinematics.timing.sync.FreshInputs`, :class:`gimbal_kinematics.timing.stream_stats.StreamStats`),
and, inline for speed, the LOS rate controller's per-sample path (same rule, same
``clock_jump_s``).

Verdict of a stamp ``t`` against its stream's last accepted one, ``last`` (:func:`judge`;
seconds or integer nanoseconds, as long as ``t``, ``last`` and ``clock_jump`` agree):

* ``NONFINITE``: ``t`` is NaN or infinite: rejected;
* ``DUPLICATE``: ``t == last``: rejected (not new data);
* ``OUT_OF_ORDER``: ``t < last`` by at most ``clock_jump``: rejected (a late sample, its
  successor was already used: a consumer never steps back in time);
* ``JUMPED_BACK``: ``t`` more than ``clock_jump`` before ``last``: the clock jumped back (a
  bag looping, a restarted driver); accepted as the first stamp of a new run, the
  consumer resets;
* ``OK``: anything later (or the first stamp).

The clock-jump rule of a stream (:class:`gimbal_kinematics.timing.stream_stats.StreamStats`, the
free-timing policies' judge): one stamp is not enough to believe a jump. A stamp more than
``clock_jump`` from the stream's timeline, back or ahead, is ``HELD``; the jump is believed
(``JUMPED_BACK``, or ``JUMPED_AHEAD``: accepted, no reset, no samples counted as dropped)
only when :data:`JUMP_SAMPLES` stamps in a row agree on the new timeline (each after the
one before, by at most ``clock_jump``); the held samples then go on in order. A stamp back
on the old timeline first shows the held ones were outliers (a single message 3 years
ahead, a stamp of zero): they are dropped and counted, and nothing resets.

Drop rule (:func:`dropped_samples`): an interval longer than :data:`GAP_PERIODS` nominal
periods counts ``round(interval / period) − 1`` samples as dropped. Why 1.5: with interval
jitter up to ±30 % (:data:`JITTER_FRACTION`, what a driver on a loaded machine shows), one
sample's interval lies in 0.7–1.3 periods and a single drop's in 1.4–2.6, so the threshold
halfway between one and two periods reads jitter as jitter and almost every drop as a
drop (both overlap only between 1.4 and 1.5), and rounding the ratio counts several drops in
one gap. The nominal period is the stream's configured one where the node has it (a
controller's driving gyro: ``sim_rate_hz``), else the median of its recent intervals
(:class:`gimbal_kinematics.timing.stream_stats.StreamStats`: a driver's or a bag's real rate).
An interval off the period by more than :data:`JITTER_FRACTION` but not a gap counts as
jittered (:func:`jittered`).
"""
from __future__ import annotations

import math
from enum import Enum

#: An interval longer than this many nominal periods holds dropped samples.
GAP_PERIODS = 1.5
#: An interval off the nominal period by more than this fraction is jittered.
JITTER_FRACTION = 0.3
#: Stamps in a row that must agree on a new timeline before a clock jump is believed.
JUMP_SAMPLES = 3


class Stamp(Enum):
    """Verdict on one stamp (module docstring)."""

    OK = "ok"
    NONFINITE = "nonfinite"
    DUPLICATE = "duplicate"
    OUT_OF_ORDER = "out_of_order"
    JUMPED_BACK = "jumped_back"
    JUMPED_AHEAD = "jumped_ahead"
    HELD = "held"

    @property
    def accepted(self) -> bool:
        """Whether the stamp is used (OK; JUMPED_BACK as the first of a new run; JUMPED_AHEAD)."""
        return self is Stamp.OK or self is Stamp.JUMPED_BACK or self is Stamp.JUMPED_AHEAD


def judge(t: float, last: float | None, clock_jump: float) -> Stamp:
    """The verdict on stamp ``t`` against the last accepted stamp ``last`` (module docstring)."""
    if not math.isfinite(t):
        return Stamp.NONFINITE
    if last is None or t > last:
        return Stamp.OK
    if t == last:
        return Stamp.DUPLICATE
    return Stamp.JUMPED_BACK if last - t > clock_jump else Stamp.OUT_OF_ORDER


def is_gap(interval: float, period: float) -> bool:
    """Whether ``interval`` holds dropped samples at nominal ``period`` (the drop rule)."""
    return interval > GAP_PERIODS * period


def dropped_samples(interval: float, period: float) -> int:
    """Samples dropped in ``interval`` at nominal ``period`` (module docstring)."""
    return max(0, int(round(interval / period)) - 1) if is_gap(interval, period) else 0


def jittered(interval: float, period: float) -> bool:
    """Whether an interval that is not a gap is off ``period`` by more than
    :data:`JITTER_FRACTION` of it."""
    return not is_gap(interval, period) and abs(interval - period) > JITTER_FRACTION * period


class StampCounts:
    """What a free-timing stamp check counts by this vocabulary, for /diagnostics: stamps
    rejected as ``duplicates`` and ``out_of_order``, samples ``dropped`` in the gaps (the drop
    rule). The common part of :class:`gimbal_kinematics.timing.stream_stats.StreamStats` and
    :class:`gimbal_kinematics.timing.sync.FreshInputs`, which add their own counters."""

    def __init__(self) -> None:
        self.duplicates = 0
        self.out_of_order = 0
        self.dropped = 0

    def count_rejected(self, verdict: Stamp) -> bool:
        """Count a DUPLICATE or OUT_OF_ORDER ``verdict``; whether it was one."""
        if verdict is Stamp.DUPLICATE:
            self.duplicates += 1
            return True
        if verdict is Stamp.OUT_OF_ORDER:
            self.out_of_order += 1
            return True
        return False


def step_stamp_ns(k: int, rate_hz: float) -> int:
    """Stamp [ns] of lockstep step ``k`` at ``rate_hz`` (``round(k·1e9 / rate_hz)``: stamps
    never accumulate floating-point error)."""
    return int(round(k * 1e9 / rate_hz))


def step_of_stamp(stamp_ns: int, rate_hz: float) -> int:
    """Lockstep step of a stamp [ns] at ``rate_hz`` (inverse of :func:`step_stamp_ns`)."""
    return int(round(stamp_ns * rate_hz / 1e9))


def progress_stamp_ns(stamp_ns: int, rate_hz: float, every: int) -> int | None:
    """What ``~/progress`` reports after the step stamped ``stamp_ns`` [ns]: the next step's
    stamp when that step starts a new block of ``every`` steps, else None."""
    k = step_of_stamp(stamp_ns, rate_hz) + 1
    return step_stamp_ns(k, rate_hz) if k % every == 0 else None
