"""Stamp bookkeeping of one input stream in free timing (pure Python, no rclpy).

A driver's or a bag's stamps are absolute (wall clock or epoch, ~1.8e9 s) and irregular:
jitter, dropped samples, duplicates, samples out of order. :class:`StreamStats` judges each
stamp against the stream's last accepted one (the verdicts and the drop rule of
:mod:`gimbal_kinematics.timing.stamps`) and counts what it saw, for ``/diagnostics``:

* ``received``: every stamp offered;
* ``duplicates``: a stamp equal to the last accepted one (rejected);
* ``out_of_order``: a stamp before the last accepted one, by no more than ``jump_ns``
  (rejected: the sample is late, its successor was already used);
* ``jumps``: clock jumps, back (a bag loop, a clock reset: the consumer resets) or ahead
  (no reset), each believed only when :data:`~gimbal_kinematics.timing.stamps.JUMP_SAMPLES` stamps
  in a row agree on the new timeline (the clock-jump rule of :mod:`gimbal_kinematics.timing.stamps`);
* ``outliers``: stamps off the timeline by more than ``jump_ns`` that the next stamp on
  the timeline showed to be single outliers (a message 3 years ahead, a stamp of zero):
  dropped, never a reset and never a gap;
* ``dropped``: samples missing from the gaps (the drop rule), the nominal period being the
  median of the last :data:`PERIOD_WINDOW` accepted intervals that were not gaps (so it
  follows the sensor's real rate; a late sample rejected as out of order leaves a gap and
  counts here too); a gap longer than ``jump_ns`` is a clock jump, not drops;
* ``jitter_rms``: RMS of (interval / period − 1) over the accepted intervals that are not
  gaps [-].

Stamps are integer nanoseconds: near 1.8e9 s a float64 second has a resolution of 2.4e-7 s,
too coarse for a 1 kHz stream's intervals; integers lose nothing.

:class:`SilenceWatch` notices the other way a stream goes wrong for a lockstep node: inputs
heard, and no step released.
"""
from __future__ import annotations

import math
import statistics
import time
from collections import deque
from typing import Callable

from .stamps import JUMP_SAMPLES, Stamp, StampCounts, dropped_samples, is_gap, judge

#: Accepted intervals the nominal period is the median of.
PERIOD_WINDOW = 51


class StreamStats(StampCounts):
    """Verdicts and counters of one stream (module docstring)."""

    def __init__(self, jump_ns: int) -> None:
        if jump_ns <= 0:
            raise ValueError(f"jump_ns must be > 0, got {jump_ns}")
        super().__init__()
        self.jump_ns = int(jump_ns)
        self.last_ns: int | None = None
        self.received = 0
        self.jumps = 0
        self.outliers = 0
        self._intervals: deque[int] = deque(maxlen=PERIOD_WINDOW)
        self._jitter_sq = 0.0
        self._jitter_n = 0
        self._held: list[int] = []
        #: after a believed jump: the held stamps, accepted before the one just offered
        self.released: tuple[int, ...] = ()

    @property
    def period_ns(self) -> float | None:
        """Nominal period [ns]: median of the recent accepted intervals (None before two)."""
        return float(statistics.median(self._intervals)) if self._intervals else None

    @property
    def jitter_rms(self) -> float:
        """RMS relative deviation of the intervals from the nominal period [-]."""
        return math.sqrt(self._jitter_sq / self._jitter_n) if self._jitter_n else 0.0

    def offer(self, stamp_ns: int) -> Stamp:
        """Judge ``stamp_ns`` [ns] and count it (module docstring). OK, JUMPED_BACK and
        JUMPED_AHEAD are accepted (the stamp becomes the last one; after a jump the held
        stamps, :attr:`released`, go first), DUPLICATE and OUT_OF_ORDER are not, HELD waits
        for the clock-jump rule (stamps are integers: never NONFINITE)."""
        self.received += 1
        self.released = ()
        last = self.last_ns
        # the usual case first (a bag replayed at full speed goes through here per message)
        if last is not None and last < stamp_ns <= last + self.jump_ns and not self._held:
            self.last_ns = stamp_ns
            self._interval(stamp_ns - last)
            return Stamp.OK
        if last is not None and abs(stamp_ns - last) > self.jump_ns:
            return self._hold(stamp_ns)
        if self._held:  # back on the timeline: the held stamps were outliers
            self.outliers += len(self._held)
            self._held = []
        verdict = judge(stamp_ns, last, self.jump_ns)
        if self.count_rejected(verdict):
            return verdict
        self.last_ns = stamp_ns
        if last is not None:
            self._interval(stamp_ns - last)
        return Stamp.OK

    def _hold(self, stamp_ns: int) -> Stamp:
        """A stamp off the timeline: held until :data:`JUMP_SAMPLES` in a row agree on a jump."""
        held = self._held
        if held and not held[-1] < stamp_ns <= held[-1] + self.jump_ns:
            self.outliers += len(held)  # they do not agree with this one: single outliers
            held = []
        held.append(stamp_ns)
        self._held = held
        if len(held) < JUMP_SAMPLES:
            return Stamp.HELD
        back = held[0] < self.last_ns
        self._held, self.released, self.last_ns = [], tuple(held[:-1]), held[-1]
        self.jumps += 1
        self._intervals.clear()
        for a, b in zip(held, held[1:]):
            self._interval(b - a)
        return Stamp.JUMPED_BACK if back else Stamp.JUMPED_AHEAD

    def _interval(self, dt: int) -> None:
        """Count an accepted interval [ns]: drops in a gap, else jitter and the period window."""
        period = self.period_ns
        if period is not None and is_gap(dt, period):
            self.dropped += dropped_samples(dt, period)
            return  # a gap: neither a period sample nor jitter
        if period is not None:
            self._jitter_sq += (dt / period - 1.0) ** 2
            self._jitter_n += 1
        self._intervals.append(dt)

    def as_dict(self, prefix: str) -> dict[str, float | int]:
        """The counters named ``<prefix>_<counter>``, for a diagnostics KeyValue list."""
        return {f"{prefix}_received": self.received, f"{prefix}_duplicates": self.duplicates,
                f"{prefix}_out_of_order": self.out_of_order, f"{prefix}_clock_jumps": self.jumps,
                f"{prefix}_outliers": self.outliers, f"{prefix}_dropped": self.dropped,
                f"{prefix}_jitter_rms": round(self.jitter_rms, 4)}


#: Seconds a lockstep node hears inputs without releasing a step before it says so.
SILENCE_S = 5.0


class SilenceWatch:
    """Notices a lockstep node that hears inputs but releases no step (started alone, with
    no step grid: a saved ``timing: lockstep`` replayed by a player). ``heard(released)``
    after each input (``released``: the steps it made ready) returns, once per silence, the
    text to log; ``now_ns`` is the clock (steady time in a node, injected by tests)."""

    def __init__(self, after_s: float = SILENCE_S, now_ns: Callable[[], int] = time.monotonic_ns) -> None:
        self.after_ns = int(round(after_s * 1e9))
        self.now_ns = now_ns
        self._since: int | None = None
        self._inputs = 0
        self._warned = False
        self.alarm: str | None = None

    def heard(self, released: int) -> str | None:
        if released:
            self._since, self._inputs, self._warned = None, 0, False
            return None
        now = self.now_ns()
        self._inputs += 1
        if self._since is None:
            self._since = now
        if self._warned or now - self._since < self.after_ns:
            return None
        self._warned = True
        self.alarm = (f"{self._inputs} inputs in {(now - self._since) * 1e-9:.1f} s and no step released: parameter "
                      "'timing' is 'lockstep', which steps only on the orchestrator's step grid (/clock and every "
                      "input of a step). Started alone (a driver, gimbal-bag play), run with timing free: "
                      "--ros-args -p timing:=free")
        return self.alarm

    def take(self) -> str | None:
        """The alarm not yet logged, once."""
        text, self.alarm = self.alarm, None
        return text
