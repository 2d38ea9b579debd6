"""Exact-stamp synchronizer: collect one message per topic for each step (no rclpy)."""
from __future__ import annotations

from typing import Any, Iterable


class StampSync:
    """Group messages of ``topics`` by stamp; a group is complete when every topic has
    delivered its message for that stamp.

    Stamps must rise per topic. A message whose stamp is not newer than the last completed
    group is rejected and counted in ``rejected`` (a late duplicate or a replayed past);
    ``max_pending`` bounds the memory held by groups a topic never completes.
    """

    def __init__(self, topics: Iterable[str], max_pending: int = 1000) -> None:
        self.topics = frozenset(topics)
        if not self.topics:
            raise ValueError("StampSync needs at least one topic")
        self.max_pending = max_pending
        self._pending: dict[int, dict[str, Any]] = {}
        self._last_complete: int | None = None
        self.rejected = 0
        self.dropped_incomplete = 0

    def add(self, topic: str, stamp_ns: int, msg: Any) -> dict[str, Any] | None:
        """Add a message; return its group ({topic: msg}) if this message completes it."""
        if topic not in self.topics:
            raise ValueError(f"topic {topic!r} is not synchronised here")
        if self._last_complete is not None and stamp_ns <= self._last_complete:
            self.rejected += 1
            return None
        group = self._pending.setdefault(stamp_ns, {})
        if topic in group:
            self.rejected += 1
            return None
        group[topic] = msg
        if len(group) < len(self.topics):
            if len(self._pending) > self.max_pending:
                oldest = min(self._pending)
                del self._pending[oldest]
                self.dropped_incomplete += 1
            return None
        # Earlier incomplete groups can no longer complete in order.
        for stamp in [s for s in self._pending if s < stamp_ns]:
            del self._pending[stamp]
            self.dropped_incomplete += 1
        self._last_complete = stamp_ns
        return self._pending.pop(stamp_ns)
