"""Per-topic record rates: a run that lasts hours keeps its bag in the hundreds of MB by
recording some topics at a lower rate than they are published.

The rule is on message stamps only (sim time), so the graph's recorder and the no-ROS engine
keep exactly the same messages: a topic's first message is kept, then each message whose
stamp is at least one period (``round(1e9 / rate)`` ns) after the last kept one. A topic
without a rate, or with rate 0, keeps every message.
"""
from __future__ import annotations

import numpy as np


class RecordRates:
    """``keep(topic, stamp_ns)``: whether this message of ``topic`` is recorded (module docstring)."""

    def __init__(self, rates_hz: dict[str, float]) -> None:
        for topic, rate in rates_hz.items():
            if not (isinstance(rate, (int, float)) and rate >= 0.0 and rate != float("inf")):
                raise ValueError(f"record rate of {topic}: expected a number of Hz >= 0, got {rate!r}")
        self.period_ns = {t: int(round(1e9 / r)) for t, r in rates_hz.items() if r > 0}
        self._next_ns: dict[str, int] = {}
        self.dropped = 0

    def __bool__(self) -> bool:
        return bool(self.period_ns)

    def keep(self, topic: str, stamp_ns: int) -> bool:
        period = self.period_ns.get(topic)
        if period is None:
            return True
        due = self._next_ns.get(topic)
        if due is not None and stamp_ns < due:
            self.dropped += 1
            return False
        self._next_ns[topic] = stamp_ns + period
        return True

    def keep_sorted(self, topic: str, stamps_ns: np.ndarray) -> np.ndarray:
        """:meth:`keep` of each of ``topic``'s messages at ``stamps_ns`` (nondecreasing), in
        order: a bool mask."""
        keep = np.zeros(len(stamps_ns), dtype=bool)
        period = self.period_ns.get(topic)
        if period is None:
            keep[:] = True
            return keep
        due, i = self._next_ns.get(topic), 0
        while i < len(stamps_ns):
            if due is not None:
                i += int(np.searchsorted(stamps_ns[i:], due, side="left"))
                if i >= len(stamps_ns):
                    break
            keep[i] = True
            due, i = int(stamps_ns[i]) + period, i + 1
        self.dropped += len(stamps_ns) - int(np.count_nonzero(keep))
        if due is not None:
            self._next_ns[topic] = due
        return keep


def rate_entries(rates_hz: dict[str, float]) -> list[str]:
    """The recorder's ``record_topic_rates`` parameter ('TOPIC=HZ' entries) of a mapping."""
    return [f"{topic}={float(rate)!r}" for topic, rate in rates_hz.items()]
