"""Release messages of several streams in stamp order, whatever order they arrive in (no rclpy).

A filter fed by separate topics sees their messages in the order the middleware delivers
them, which differs between a lockstep run, a replay at full speed and a live system: at
full speed one topic's queue can run ahead of another's, so an INS sample may reach the
filter before the gyro samples that precede it. Fed through :class:`StampOrder`, the
filter sees every message in stamp order, the streams of one stamp in a fixed order, so a
replay computes exactly what the run computed.

A message is released once every stream has delivered a stamp at or after it (nothing
earlier can still come), or once the newest stamp seen is more than ``max_wait_ns`` past
it (a stream that stopped must not stall the others). A message stamped before its own
stream's previous one (out of order, or a bag loop) flushes the buffer and is released at
once, for the filter to judge.
"""
from __future__ import annotations

from collections import deque
from typing import Any, Sequence


class StampOrder:
    """Stamp-ordered merge of ``streams`` (their order is the release order within a stamp)."""

    def __init__(self, streams: Sequence[str], max_wait_ns: int) -> None:
        if not streams or len(set(streams)) != len(streams):
            raise ValueError(f"streams must be distinct names, got {list(streams)!r}")
        if max_wait_ns < 0:
            raise ValueError(f"max_wait_ns must be >= 0, got {max_wait_ns}")
        self.streams = tuple(streams)
        self.max_wait_ns = int(max_wait_ns)
        self._queues: dict[str, deque] = {s: deque() for s in self.streams}
        self._last: dict[str, int | None] = {s: None for s in self.streams}
        self._newest: int | None = None

    def add(self, stream: str, stamp_ns: int, item: Any) -> list[tuple[str, Any]]:
        """Buffer ``item`` of ``stream`` stamped ``stamp_ns``; returns the (stream, item)
        pairs now released, in order."""
        last = self._last[stream]
        if last is not None and stamp_ns < last:
            out = self.flush()
            out.append((stream, item))
            self._last = {s: None for s in self.streams}
            self._newest = None
            return out
        self._last[stream] = stamp_ns
        self._newest = stamp_ns if self._newest is None else max(self._newest, stamp_ns)
        self._queues[stream].append((stamp_ns, item))
        return self._release(force=False)

    def flush(self) -> list[tuple[str, Any]]:
        """Release everything buffered, in order."""
        return self._release(force=True)

    @property
    def pending(self) -> int:
        return sum(len(q) for q in self._queues.values())

    def _release(self, force: bool) -> list[tuple[str, Any]]:
        out: list[tuple[str, Any]] = []
        queues = self._queues
        while True:
            heads = [q[0][0] for q in queues.values() if q]
            if not heads:
                return out
            t = min(heads)
            covered = all(last is not None and last >= t for last in self._last.values())
            if not (force or covered or self._newest - t > self.max_wait_ns):
                return out
            for s in self.streams:
                q = queues[s]
                while q and q[0][0] == t:
                    out.append((s, q.popleft()[1]))
