"""The one input-sync toolkit of every node and message-driven core (pure Python, no rclpy).

A node's inputs arrive on separate topics in whatever order the middleware delivers them;
what the node computes must not depend on that order, or a replay would not reproduce a run.

* :class:`StampOrder`: release several streams in stamp order (a filter fed at any replay
  speed sees the same sequence), with a bounded wait for a stream that stopped.
* :class:`StepGroups`: group inputs by lockstep step and release the steps in order, each
  once every input due at that step has arrived (a controller whose command k the vehicle
  waits for, an estimator that must see every step).
* :class:`EagerStepGroups`: the same grouping, but a complete step goes at once, ahead of
  older incomplete ones (a controller that must not stall behind a lost input).
* :class:`StampSync`: group one message per topic by exact stamp (a simulator node that
  needs every truth topic of a step).
* :class:`FreshInputs`: free timing, no grid: a step on each sample of a driving stream with
  the newest sample of the others, each no older than its maximum age (a controller fed by
  a driver or a bag).
* :class:`RateSync`: multi-rate grouping for a gyro-propagated filter: each gyro sample goes
  out with the joint angles and reference rates interpolated to its stamp, each reference
  attitude with the joint angles of its stamp, once the integration has reached it.
* :class:`StampPairs`: pair two streams sample by sample on equal stamps, for a core that
  takes both samples of a stamp at once (two ring-laser-gyro units of one flexure filter).

StampOrder: a message is released once every stream has delivered a stamp at or after it
(nothing earlier can still come), or once the newest stamp seen is more than ``max_wait_ns``
past it. A message stamped before its own stream's previous one (out of order, or a bag
loop) flushes the buffer and is released at once, for the filter to judge.
"""
from __future__ import annotations

import math
from collections import deque
from typing import Any, Callable, Iterable, NamedTuple, Sequence

from .stamps import Stamp, StampCounts, dropped_samples, jittered, judge


# ----------------------------------------------------------------------------------------
# StampOrder: several streams released in stamp order, whatever order they arrive in.
# ----------------------------------------------------------------------------------------
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


# ----------------------------------------------------------------------------------------
# StepGroups: a node's inputs grouped by lockstep step, each step released once complete.
# ----------------------------------------------------------------------------------------
class StepGroups:
    """Pending inputs by step (module docstring).

    A message for a step at or before the last released one is rejected and counted in
    ``rejected``, unless it lies more than ``backjump_steps`` back: that is a clock jump (a
    replayed bag looping), so everything pending is dropped, ``restarts`` counts it and the
    message starts the new run.
    """

    def __init__(self, needs: Callable[[int], tuple[str, ...]], backjump_steps: float) -> None:
        self.needs = needs
        self.backjump_steps = float(backjump_steps)
        self._pending: dict[int, dict[str, Any]] = {}
        self.last_step: int | None = None
        self.rejected = 0
        self.restarts = 0

    def admit(self, kind: str, k: int, logger: Any = None) -> bool:
        """Whether input ``kind`` of step ``k`` still counts: False (counted in ``rejected``)
        for a step at or before the last released one, unless it lies more than
        ``backjump_steps`` back; then everything pending is dropped and the run restarts
        (True). :meth:`add` calls it; a node calls it alone for an input it uses at once
        instead of adding it (e.g. an estimate between the steps that wait for one). A
        node's ``logger`` (rclpy's, or anything with ``info``/``warning``) hears of restarts
        and, at most once a second, of rejections."""
        last = self.last_step
        if last is not None and k <= last:
            if last - k <= self.backjump_steps:
                self.rejected += 1
                if logger is not None:
                    logger.warning(f"{kind} stamped for step {k}, already past step {last}: ignored "
                                   f"({self.rejected} rejected)", throttle_duration_sec=1.0)
                return False
            self._pending.clear()
            self.last_step = None
            self.restarts += 1
            if logger is not None:
                logger.info(f"inputs jumped back from step {last} to {k} (a replay looping?): restarting")
        return True

    def add(self, kind: str, k: int, msg: Any, logger: Any = None) -> list[tuple[int, dict[str, Any]]]:
        """Add input ``kind`` of step ``k``; returns the steps it completes, in order, as
        (step, {kind: msg}) (empty when it completes none or is rejected, see :meth:`admit`)."""
        if not self.admit(kind, k, logger):
            return []
        self._pending.setdefault(k, {})[kind] = msg
        done = []
        for step in sorted(self._pending):
            group = self._pending[step]
            if not all(need in group for need in self.needs(step)):
                break
            del self._pending[step]
            self.last_step = step
            done.append((step, group))
        return done


# ----------------------------------------------------------------------------------------
# EagerStepGroups: each step released the moment it is complete, whatever is still pending.
# ----------------------------------------------------------------------------------------
class EagerStepGroups:
    """Inputs grouped by step like :class:`StepGroups`, but each step is released the moment
    its inputs (``needs(step)``) are in, ahead of older steps still waiting: a controller
    whose loop must not stall behind an input that was lost (in lockstep the steps complete
    in order anyway). Nothing is rejected: a repeated input replaces the pending one of its
    step, and a late one opens its step again (the core judges the stamps). Incomplete steps
    more than ``stale_steps`` older than a released one are forgotten, counted in
    ``dropped``.
    """

    def __init__(self, needs: Callable[[int], tuple[str, ...]], stale_steps: int) -> None:
        self.needs = needs
        self.stale_steps = int(stale_steps)
        self._pending: dict[int, dict[str, Any]] = {}
        self.dropped = 0

    def add(self, kind: str, k: int, msg: Any, logger: Any = None) -> dict[str, Any] | None:
        """Add input ``kind`` of step ``k``; returns step k's inputs ({kind: msg}) when this
        completes it, else None. A node's ``logger`` hears, at most once a second, of the
        steps forgotten."""
        group = self._pending.setdefault(k, {})
        group[kind] = msg
        if not all(need in group for need in self.needs(k)):
            return None
        del self._pending[k]
        for step in [s for s in self._pending if s < k - self.stale_steps]:
            del self._pending[step]
            self.dropped += 1
            if logger is not None:
                logger.warning(f"step {step}: inputs never complete; skipped ({self.dropped} skipped)",
                               throttle_duration_sec=1.0)
        return group


# ----------------------------------------------------------------------------------------
# StampSync: one message per topic collected for each exact stamp.
# ----------------------------------------------------------------------------------------
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


# ----------------------------------------------------------------------------------------
# FreshInputs: free timing. A step on each sample of one driving stream, with the newest
# sample of every other stream if it is fresh enough.
# ----------------------------------------------------------------------------------------
class FreeStep(NamedTuple):
    """One step of free timing, on a driving sample.

    ``t_ns``: its stamp relative to the first stamp seen (int ns; in float seconds near
    1.8e9 s a double resolves only ~0.2 µs, relative to the start it keeps every ns);
    ``dt_ns``: since the previous driving sample (0 for the first after a start);
    ``inputs``: the newest sample of each other stream, None when it has none;
    ``stale``: the streams with no sample, or whose newest is older than their maximum age;
    ``restarted``: the stamps jumped back (a bag looping): the consumer starts over.
    """

    t_ns: int
    dt_ns: int
    inputs: dict[str, Any]
    stale: tuple[str, ...]
    restarted: bool


class FreshInputs(StampCounts):
    """Free-timing gate of a controller: it steps on each sample of ``driver`` (the gyro),
    with the newest sample of each stream of ``max_age_ns`` (stream → its maximum age [ns],
    measured in stamps against the driving sample) that is no older than that.

    Bad stamps, per stream, against the newest accepted one: the same stamp again is a
    duplicate, an earlier one is out of order; both are rejected and counted (a consumer
    never steps back in time). One more than ``backjump_ns`` earlier is a clock jump (a
    replayed bag looping): every stream is forgotten, the time origin starts again and
    ``restarts`` counts it. Driving intervals are checked against ``period_ns``, the
    nominal driving period, by the drop rule of :mod:`gimbal_kinematics.timing.stamps` (dropped
    samples, jittered intervals). Nothing here waits: each driving sample is a step at once.
    """

    def __init__(self, driver: str, max_age_ns: dict[str, int], period_ns: int, backjump_ns: int) -> None:
        if driver in max_age_ns:
            raise ValueError(f"the driving stream {driver!r} has no maximum age")
        if period_ns <= 0 or backjump_ns < 0 or any(a < 0 for a in max_age_ns.values()):
            raise ValueError("period_ns must be > 0, backjump_ns and the maximum ages >= 0")
        self.driver = driver
        self.max_age_ns = dict(max_age_ns)
        self.period_ns = int(period_ns)
        self.backjump_ns = int(backjump_ns)
        self.t0_ns: int | None = None
        self._newest: dict[str, tuple[int, Any]] = {}
        self.accepted = {s: 0 for s in (driver, *max_age_ns)}
        super().__init__()
        self.restarts = 0
        self.jittered = 0
        self.stale_steps = 0

    def _admit(self, stream: str, stamp_ns: int) -> Stamp:
        """The stamp's verdict; a rejected one counted."""
        newest = self._newest.get(stream)
        verdict = judge(stamp_ns, None if newest is None else newest[0], self.backjump_ns)
        self.count_rejected(verdict)
        return verdict

    def add(self, stream: str, stamp_ns: int, item: Any) -> FreeStep | None:
        """Take ``item`` of ``stream`` stamped ``stamp_ns`` (absolute, int ns); returns the
        step a driving sample makes, None for another stream's sample or a rejected one."""
        if stream not in self.accepted:
            raise ValueError(f"unknown stream {stream!r}")
        verdict = self._admit(stream, stamp_ns)
        if not verdict.accepted:
            return None
        restarted = verdict is Stamp.JUMPED_BACK
        if restarted:
            self._newest.clear()
            self.t0_ns = None
            self.restarts += 1
        if self.t0_ns is None:
            self.t0_ns = stamp_ns
        self.accepted[stream] += 1
        previous = self._newest.get(stream)
        self._newest[stream] = (stamp_ns, item)
        if stream != self.driver:
            return None
        dt = 0 if previous is None else stamp_ns - previous[0]
        if dt:
            self.dropped += dropped_samples(dt, self.period_ns)
            self.jittered += jittered(dt, self.period_ns)
        inputs: dict[str, Any] = {}
        stale = []
        for other, max_age in self.max_age_ns.items():
            newest = self._newest.get(other)
            if newest is None or stamp_ns - newest[0] > max_age:
                stale.append(other)
                inputs[other] = None if newest is None else newest[1]
            else:
                inputs[other] = newest[1]
        if stale:
            self.stale_steps += 1
        return FreeStep(stamp_ns - self.t0_ns, dt, inputs, tuple(stale), restarted)

    def counters(self) -> dict[str, int]:
        """The counters by name (for /diagnostics)."""
        out = {f"accepted_{s}": n for s, n in self.accepted.items()}
        out.update(duplicates=self.duplicates, out_of_order=self.out_of_order, restarts=self.restarts,
                   dropped=self.dropped, jittered=self.jittered, stale_steps=self.stale_steps)
        return out


# ----------------------------------------------------------------------------------------
# RateSync: multi-rate grouping for a gyro-propagated filter.
# ----------------------------------------------------------------------------------------
def interpolate(hist: deque, t: float) -> tuple[float, float, float] | None:
    """Linear interpolation of a (t, a, b, c) history at ``t`` (held beyond its ends);
    drops the entries no longer needed for later times."""
    if not hist:
        return None
    while len(hist) > 1 and hist[1][0] <= t:
        hist.popleft()
    h0 = hist[0]
    if len(hist) == 1 or t <= h0[0]:
        return h0[1], h0[2], h0[3]
    h1 = hist[1]
    f = (t - h0[0]) / (h1[0] - h0[0])
    return (h0[1] + f * (h1[1] - h0[1]), h0[2] + f * (h1[2] - h0[2]), h0[3] + f * (h1[3] - h0[3]))


class RateSync:
    """Group a gyro stream (q, r), a joint-angle stream and a reference (INS) stream of
    rates and optional attitudes, all checked and in stamp order on one clock, for a filter.

    A gyro sample waits until joint angles and reference rates stamped at or after it are in
    (or ``max_wait_s`` past it, the latest values then held); ``integrate(t, q, r, angles,
    rates)`` then gets it with both interpolated linearly to its stamp (None before the
    first). A reference attitude goes to ``fuse(t, attitude, angles)``, with the angles
    interpolated to its stamp, once the gyro samples up to it are integrated (of several
    reached at once only the newest). An attitude stamped strictly between two gyro samples
    no more than ``max_gap_s`` apart is fused at its own stamp: the gyro rates are
    interpolated to it and integrated there first. Each input returns what the last
    ``fuse`` it led to returned (None when none)."""

    def __init__(self, max_wait_s: float, max_gap_s: float, integrate: Callable, fuse: Callable,
                 max_pending: int = 100) -> None:
        self.max_wait_s, self.max_gap_s = max_wait_s, max_gap_s
        self._integrate, self._fuse, self._max_pending = integrate, fuse, max_pending
        self.clear()

    def clear(self) -> None:
        """Forget every queued sample (a new run)."""
        self._t_newest = float("-inf")
        self._t_last: float | None = None  # stamp of the last gyro sample integrated
        self._gyro: deque[tuple[float, float, float]] = deque()
        self._angles: deque[tuple[float, float, float, float]] = deque()
        self._rates: deque[tuple[float, float, float, float]] = deque()
        # attitudes not fused yet, oldest first (bounded: a stopped gyro must not grow it)
        self._pending: deque[tuple[float, Any]] = deque(maxlen=self._max_pending)
        self._raw_prev: tuple[float, float, float] | None = None

    def gyro(self, t: float, q: float, r: float) -> Any:
        self._gyro.append((t, q, r))
        return self._taken(t)

    def angles(self, t: float, angles: Sequence[float]) -> Any:
        self._angles.append((t, angles[0], angles[1], angles[2]))
        return self._taken(t)

    def reference(self, t: float, attitude: Any, rates: Sequence[float]) -> Any:
        """Reference rates at ``t``, with an attitude to fuse (None: rates only)."""
        self._rates.append((t, rates[0], rates[1], rates[2]))
        if attitude is not None:
            self._pending.append((t, attitude))
        return self._taken(t)

    def _taken(self, t: float) -> Any:
        if t > self._t_newest:
            self._t_newest = t
        self._release()
        return self._fuse_reached()

    def _step(self, t: float, q: float, r: float) -> None:
        self._t_last = t
        self._integrate(t, q, r, interpolate(self._angles, t), interpolate(self._rates, t))
        self._raw_prev = (t, q, r)

    def _release(self) -> None:
        """Integrate the queued gyro samples whose angles and rates are in (or that waited
        longer than ``max_wait_s``)."""
        gq, ang, rat = self._gyro, self._angles, self._rates
        while gq:
            t = gq[0][0]
            if (not ang or ang[-1][0] < t or not rat or rat[-1][0] < t) and self._t_newest - t <= self.max_wait_s:
                return
            sample = gq.popleft()
            self._split_at_pending(*sample)
            self._step(*sample)

    def _split_at_pending(self, t: float, q: float, r: float) -> None:
        """Fuse the attitudes stamped strictly between the last gyro sample and this one at
        their own stamps (a gap longer than ``max_gap_s`` is never interpolated across)."""
        pend, raw = self._pending, self._raw_prev
        if raw is None or t - raw[0] > self.max_gap_s:
            return
        while pend and raw[0] < pend[0][0] < t:
            tp = pend[0][0]
            f = (tp - raw[0]) / (t - raw[0])
            raw = (tp, raw[1] + f * (q - raw[1]), raw[2] + f * (r - raw[2]))
            self._step(*raw)
            self._fuse_reached()

    def _fuse_reached(self) -> Any:
        """Fuse the newest pending attitude the integration has reached (older ones reached
        at the same time, e.g. across a gyro gap, are superseded by it)."""
        pend, t_last = self._pending, self._t_last
        if t_last is None:
            return None
        while len(pend) > 1 and pend[1][0] <= t_last:
            pend.popleft()
        out = None
        while pend and t_last >= pend[0][0]:
            t, attitude = pend.popleft()
            angles = interpolate(self._angles, t)
            if angles is not None:
                res = self._fuse(t, attitude, angles)
                if res is not None:
                    out = res
        return out


# ----------------------------------------------------------------------------------------
# StampPairs: two streams paired on equal stamps.
# ----------------------------------------------------------------------------------------
class StampPairs:
    """Two streams (unit 0 and 1) paired sample by sample on equal stamps [s], each pair
    handed to ``fuse(t, sample_0, sample_1)`` and its result returned by :meth:`add`.

    Each sample first goes through ``check(t, *sample)``, the core's own judgement of the
    values: None refuses it (the core counts why), otherwise it returns ``(t, *checked)``.
    A checked sample stamped at or before ``taken()`` (the stamp the core has reached; NaN:
    nothing yet) is out of order; one whose stream already holds that stamp is a duplicate.
    A sample waits for its partner, at most ``max_pending`` a stream (the oldest is dropped,
    counted unpaired); once a pair completes, the older samples of either stream can never
    pair and are dropped, counted unpaired. :meth:`clear` forgets the waiting samples (the
    core calls it when it starts over)."""

    COUNTERS = ("out_of_order", "duplicates", "unpaired")

    def __init__(self, check: Callable[..., tuple | None], fuse: Callable[[float, Any, Any], Any],
                 taken: Callable[[], float], max_pending: int = 64) -> None:
        if not isinstance(max_pending, int) or isinstance(max_pending, bool) or max_pending < 1:
            raise ValueError(f"max_pending must be an integer >= 1, got {max_pending!r}")
        self._check, self._fuse, self._taken, self.max_pending = check, fuse, taken, max_pending
        self._pending: tuple[dict[int, tuple], dict[int, tuple]] = ({}, {})
        self.counts: dict[str, int] = dict.fromkeys(self.COUNTERS, 0)
        #: Why :meth:`add` refused its sample (``out_of_order``, ``duplicates``), or None.
        self.refused: str | None = None

    @classmethod
    def feeding(cls, core: Any, max_pending: int = 64) -> StampPairs:
        """Pairs for a core that takes two streams' samples by pairs: its ``check_sample``,
        ``on_pair`` and ``paired_until`` (the stamp of the last pair it took), and its ``on_reset``,
        set here so that the core starting over forgets the waiting samples."""
        pairs = cls(core.check_sample, core.on_pair, lambda: core.paired_until, max_pending)
        core.on_reset = pairs.clear
        return pairs

    def clear(self) -> None:
        self._pending[0].clear()
        self._pending[1].clear()

    def add(self, unit: int, t: Any, *sample: Any) -> Any:
        """A sample of stream ``unit`` (0 or 1) stamped ``t`` [s]: ``fuse``'s result when it
        completes a pair, else None."""
        self.refused = None
        checked = self._check(t, *sample)
        if checked is None:
            return None
        t, sample = checked[0], checked[1:]
        c, taken = self.counts, self._taken()
        if not math.isnan(taken) and t <= taken:
            c["out_of_order"] += 1
            self.refused = "out_of_order"
            return None
        key = round(t * 1e9)
        mine, other = self._pending[unit], self._pending[1 - unit]
        if key in mine:
            c["duplicates"] += 1
            self.refused = "duplicates"
            return None
        partner = other.pop(key, None)
        if partner is None:
            mine[key] = sample
            if len(mine) > self.max_pending:
                del mine[min(mine)]
                c["unpaired"] += 1
            return None
        # Samples older than a complete pair can no longer find their partner.
        for dct in self._pending:
            stale = [k for k in dct if k < key]
            for k in stale:
                del dct[k]
            c["unpaired"] += len(stale)
        return self._fuse(t, sample, partner) if unit == 0 else self._fuse(t, partner, sample)
