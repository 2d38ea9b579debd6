"""Stamp bookkeeping of one input stream in free timing (pure Python, no rclpy).

A driver's or a bag's stamps are absolute (wall clock or epoch, ~1.8e9 s) and irregular:
jitter, dropped samples, duplicates, samples out of order. :class:`StreamStats` judges each
stamp against the stream's last accepted one and counts what it saw, for ``/diagnostics``:

* ``received``: every stamp offered;
* ``duplicates``: a stamp equal to the last accepted one (rejected);
* ``out_of_order``: a stamp before the last accepted one, by no more than ``jump_ns``
  (rejected: the sample is late, its successor was already used);
* ``jumps``: a stamp more than ``jump_ns`` before the last one (a bag loop, a clock reset:
  accepted, as the first of a new run; the consumer resets);
* ``dropped``: samples missing from the gaps, ``round(gap / period) - 1`` for a gap longer
  than 1.5 nominal periods, the nominal period being the median of the last
  :data:`PERIOD_WINDOW` accepted intervals (so it follows the sensor's real rate, and ±30 %
  interval jitter is never read as a drop; a dropped sample's two intervals of up to
  ±30 % each fall below 1.5 periods 1.4 % of the time and are then missed; a late sample
  rejected as out of order leaves a gap and counts here too);
* ``jitter_rms``: RMS of (interval / period − 1) over the accepted intervals that are not
  gaps [-].

Stamps are integer nanoseconds: near 1.8e9 s a float64 second has a resolution of 2.4e-7 s,
too coarse for a 1 kHz stream's intervals; integers lose nothing.
"""
from __future__ import annotations

import math
import statistics
from collections import deque
from enum import Enum

#: Accepted intervals the nominal period is the median of.
PERIOD_WINDOW = 51
#: A gap longer than this many nominal periods counts its missing samples as dropped.
GAP_PERIODS = 1.5


class Verdict(Enum):
    OK = "ok"
    DUPLICATE = "duplicate"
    OUT_OF_ORDER = "out_of_order"
    JUMPED_BACK = "jumped_back"


class StreamStats:
    """Verdicts and counters of one stream (module docstring)."""

    def __init__(self, jump_ns: int) -> None:
        if jump_ns <= 0:
            raise ValueError(f"jump_ns must be > 0, got {jump_ns}")
        self.jump_ns = int(jump_ns)
        self.last_ns: int | None = None
        self.received = 0
        self.duplicates = 0
        self.out_of_order = 0
        self.jumps = 0
        self.dropped = 0
        self._intervals: deque[int] = deque(maxlen=PERIOD_WINDOW)
        self._jitter_sq = 0.0
        self._jitter_n = 0

    @property
    def period_ns(self) -> float | None:
        """Nominal period [ns]: median of the recent accepted intervals (None before two)."""
        return float(statistics.median(self._intervals)) if self._intervals else None

    @property
    def jitter_rms(self) -> float:
        """RMS relative deviation of the intervals from the nominal period [-]."""
        return math.sqrt(self._jitter_sq / self._jitter_n) if self._jitter_n else 0.0

    def offer(self, stamp_ns: int) -> Verdict:
        """Judge ``stamp_ns`` [ns] and count it; OK and JUMPED_BACK are accepted (the stamp
        becomes the last one), DUPLICATE and OUT_OF_ORDER are not."""
        self.received += 1
        last = self.last_ns
        if last is None:
            self.last_ns = stamp_ns
            return Verdict.OK
        if stamp_ns == last:
            self.duplicates += 1
            return Verdict.DUPLICATE
        if stamp_ns < last:
            if last - stamp_ns <= self.jump_ns:
                self.out_of_order += 1
                return Verdict.OUT_OF_ORDER
            self.jumps += 1
            self.last_ns = stamp_ns
            self._intervals.clear()
            return Verdict.JUMPED_BACK
        dt = stamp_ns - last
        self.last_ns = stamp_ns
        period = self.period_ns
        if period is not None and dt > GAP_PERIODS * period:
            self.dropped += max(0, int(round(dt / period)) - 1)
            return Verdict.OK  # a gap: neither a period sample nor jitter
        if period is not None:
            self._jitter_sq += (dt / period - 1.0) ** 2
            self._jitter_n += 1
        self._intervals.append(dt)
        return Verdict.OK

    def as_dict(self, prefix: str) -> dict[str, float | int]:
        """The counters named ``<prefix>_<counter>``, for a diagnostics KeyValue list."""
        return {f"{prefix}_received": self.received, f"{prefix}_duplicates": self.duplicates,
                f"{prefix}_out_of_order": self.out_of_order, f"{prefix}_clock_jumps": self.jumps,
                f"{prefix}_dropped": self.dropped, f"{prefix}_jitter_rms": round(self.jitter_rms, 4)}
