"""The input policies of a controller or estimator node (pure Python, no rclpy).

A node chooses its policy once, in its constructor, from its ``timing`` parameter (as
:class:`gimbal_kinematics.ros.node_io.NodeIo` chooses its QoS); its body then feeds every
input message to ``policy.add(kind, stamp_ns, msg)`` and runs its one ``_step`` on each
:class:`Step` that returns, whatever the timing. What differs between the timings lives
here, behind one interface:

* ``add(kind, stamp_ns, msg) -> list[Step]``: the steps the message makes ready, in the
  order the core must see them; each carries the core's time ``t`` [s];
* ``stamp_of(t) -> int``: the absolute stamp [ns] of a core time (what outputs carry);
* ``progress(stamp_ns) -> int | None``: after a step of the pacing stream, the stamp to
  report on ``~/progress`` (None: nothing to report yet);
* ``report(core, node, nis, nis_verdict) -> (fields, nis_verdict) | None``: what
  ``/diagnostics`` carries (None: the node publishes none);
* ``counters() -> dict``: the policy's own counters.

Two timings (:data:`gimbal_kinematics.params.TIMING_CHOICES`):

* lockstep (:class:`LockstepOrder`): the orchestrator's graph. Stamps are simulation time
  from 0 (the core's time is the stamp in seconds), ``~/progress`` names the next step on
  the ``sim_rate_hz`` grid, and ``/diagnostics`` carries the core's counters only, so the
  scenario bags stay as they were;
* free (:class:`FreeOrder`): a driver or a bag. Each stream's stamps are judged
  (:class:`gimbal_kinematics.stream_stats.StreamStats`: duplicates and late samples are
  dropped and counted, a clock jump back restarts: the node's ``on_restart`` resets the
  core); the core runs on seconds since the run's first stamp (integer ns kept: a float64
  near 1.8e9 s resolves only 2.4e-7 s); ``~/progress`` reports the newest stamp every
  ``progress_every`` steps of the pacing stream; ``/diagnostics`` adds the input
  counters, the node's and the NIS window.

In both, the streams reach the core in stamp order (:class:`gimbal_kinematics.sync.StampOrder`),
so a replay at any speed computes what the run computed.
"""
from __future__ import annotations

from typing import Any, Callable, Mapping, NamedTuple, Sequence

from .stamps import Stamp, step_of_stamp, step_stamp_ns
from .stream_stats import StreamStats
from .sync import StampOrder


class Step(NamedTuple):
    """One input released to the core: its stream, absolute stamp [ns], the core's time
    of it [s] and the message."""

    kind: str
    stamp_ns: int
    t: float
    msg: Any


Fields = Mapping[str, Any]


class LockstepOrder:
    """Lockstep input policy (module docstring): ``streams`` in stamp order (within a
    stamp in the order given), released when every stream has reached the stamp or after
    ``max_wait_ns``; ``~/progress`` every ``progress_every`` steps of ``rate_hz``.
    ``diagnostics``: whether the node publishes /diagnostics (its core counters) at all."""

    timing = "lockstep"

    def __init__(self, streams: Sequence[str], max_wait_ns: int, rate_hz: float, progress_every: int,
                 diagnostics: bool = True) -> None:
        self.order = StampOrder(streams, max_wait_ns)
        self.rate_hz = rate_hz
        self.progress_every = int(progress_every)
        self.diagnostics = diagnostics

    def add(self, kind: str, stamp_ns: int, msg: Any) -> list[Step]:
        return [Step(k, s, s * 1e-9, m) for k, (s, m) in self.order.add(kind, stamp_ns, (stamp_ns, msg))]

    def stamp_of(self, t: float) -> int:
        return int(round(t * 1e9))

    def progress(self, stamp_ns: int) -> int | None:
        """The next step's stamp when it starts a new block of ``progress_every`` steps."""
        k = step_of_stamp(stamp_ns, self.rate_hz) + 1
        return step_stamp_ns(k, self.rate_hz) if k % self.progress_every == 0 else None

    def counters(self) -> dict[str, int]:
        return {}

    def report(self, core: Fields, node: Fields, nis: Fields, nis_verdict: str | None
               ) -> tuple[dict[str, Any], str | None] | None:
        return (dict(core), None) if self.diagnostics else None


class FreeOrder:
    """Free-timing input policy (module docstring): each stream's stamps judged, a stamp
    more than ``clock_jump_ns`` back restarts (``on_restart(reason)``: the node resets its
    core), then the streams in stamp order as in :class:`LockstepOrder`; ``~/progress``
    every ``progress_every`` steps of the pacing stream."""

    timing = "free"

    def __init__(self, streams: Sequence[str], max_wait_ns: int, clock_jump_ns: int, progress_every: int,
                 on_restart: Callable[[str], None]) -> None:
        self.order = StampOrder(streams, max_wait_ns)
        self.stats = {s: StreamStats(clock_jump_ns) for s in streams}
        self.progress_every = int(progress_every)
        self.on_restart = on_restart
        #: the run's first stamp [ns], the origin of the core's time
        self.t0_ns: int | None = None
        self._paced = 0

    def add(self, kind: str, stamp_ns: int, msg: Any) -> list[Step]:
        verdict = self.stats[kind].offer(stamp_ns)
        if not verdict.accepted:
            return []  # counted; the core already used a later sample of this stream
        if verdict is Stamp.JUMPED_BACK:
            self._restart(kind, stamp_ns)
        if self.t0_ns is None:
            self.t0_ns = stamp_ns
        t0 = self.t0_ns
        return [Step(k, s, (s - t0) * 1e-9, m) for k, (s, m) in self.order.add(kind, stamp_ns, (stamp_ns, msg))]

    def _restart(self, stream: str, stamp_ns: int) -> None:
        """A clock jump back (bag loop, restarted driver): forget the old run's buffered
        messages, let the node reset its core, and take this stamp as the new origin."""
        self.on_restart(f"clock jumped back on {stream} to {stamp_ns * 1e-9:.6f} s")
        self.order = StampOrder(self.order.streams, self.order.max_wait_ns)
        for other, st in self.stats.items():
            if other != stream:
                st.last_ns = None  # the other streams' next stamps belong to the new run
        self.t0_ns = None

    def stamp_of(self, t: float) -> int:
        return self.t0_ns + int(round(t * 1e9))

    def progress(self, stamp_ns: int) -> int | None:
        """This stamp, every ``progress_every`` steps of the pacing stream."""
        self._paced += 1
        return stamp_ns if self._paced % self.progress_every == 0 else None

    def counters(self) -> dict[str, float | int]:
        out: dict[str, float | int] = {}
        for name, st in self.stats.items():
            out.update(st.as_dict(name))
        return out

    def report(self, core: Fields, node: Fields, nis: Fields, nis_verdict: str | None
               ) -> tuple[dict[str, Any], str | None] | None:
        return {**core, **self.counters(), **node, **nis}, nis_verdict


def order_policy(timing: str, streams: Sequence[str], *, max_wait_ns: int, rate_hz: float, progress_every: int,
                 clock_jump_ns: int, on_restart: Callable[[str], None],
                 diagnostics: bool = True) -> LockstepOrder | FreeOrder:
    """The stamp-ordered input policy of ``timing`` (a node's one choice, in its constructor);
    ``diagnostics``: whether the node publishes /diagnostics in lockstep too."""
    if timing == "lockstep":
        return LockstepOrder(streams, max_wait_ns, rate_hz, progress_every, diagnostics)
    if timing == "free":
        return FreeOrder(streams, max_wait_ns, clock_jump_ns, progress_every, on_restart)
    raise ValueError(f"parameter 'timing' = {timing!r} is not one of ['free', 'lockstep']")
