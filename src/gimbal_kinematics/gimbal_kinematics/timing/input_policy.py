"""The input policies of a controller or estimator node (pure Python, no rclpy).

A node chooses its policy once, in its constructor, from its ``timing`` parameter (as
:class:`gimbal_kinematics.ros.node_io.NodeIo` chooses its QoS); its body then feeds every
input message to ``policy.add(kind, stamp_ns, msg)`` and runs its one ``_step`` on each
:class:`Step` that returns, whatever the timing. What differs between the timings lives
here, behind one interface:

* ``add(kind, stamp_ns, msg) -> list[Step]``: the steps the message makes ready, in the
  order the core must see them; each carries the core's time ``t`` [s];
* ``stamp_of(t) -> int``: the absolute stamp [ns] of a core time (what outputs carry);
* ``progress(step) -> int | None``: after a step of the pacing stream, the stamp to
  report on ``~/progress`` (None: nothing to report yet);
* ``report(core, node, nis, nis_verdict) -> (fields, nis_verdict)``: what ``/diagnostics``
  carries; ``diagnostics``: whether the node advertises /diagnostics at all (a lockstep
  node that never did keeps its bags as they were);
* ``counters() -> dict``: the policy's own counters.

Two timings (:data:`gimbal_kinematics.params.table.TIMING_CHOICES`), four shapes of input, each
with a factory that picks the timing's policy:

========================  ==================  ================  ==========================
inputs                    lockstep            free              factory
========================  ==================  ================  ==========================
streams in stamp order    LockstepOrder       FreeOrder         :func:`order_policy`
sampled streams           LockstepSamples     FreeSamples       :func:`sample_policy`
grouped by lockstep step  LockstepGroups      FreeOrder         :func:`grouped_policy`
exact-stamp groups        LockstepSynced      FreeSynced        :func:`synced_policy`
========================  ==================  ================  ==========================

* lockstep: the orchestrator's graph. Stamps are simulation time from 0 (the core's time is
  the stamp in seconds, or k / ``sim_rate_hz`` for a step), ``~/progress`` names the next
  step on the ``sim_rate_hz`` grid, and ``/diagnostics`` carries the core's counters only
  (or is not advertised), so the scenario bags stay as they were; a duplicate or late stamp
  is dropped and counted here, a jump back restarts (:func:`gimbal_kinematics.timing.stamps.judge`);
* free: a driver or a bag. Each stream's stamps are judged
  (:class:`gimbal_kinematics.timing.stream_stats.StreamStats`: duplicates and late samples dropped
  and counted; a single stamp off the stream's timeline an outlier, dropped and counted; a
  clock jump, believed when several samples in a row agree on it
  (:data:`gimbal_kinematics.timing.stamps.JUMP_SAMPLES`, :class:`HeldSamples`), restarts); the core
  runs on seconds since the run's first stamp (integer ns kept: a float64 near 1.8e9 s
  resolves only 2.4e-7 s); ``~/progress`` reports the newest stamp every ``progress_every``
  steps of the pacing stream; ``/diagnostics`` adds the input counters, the node's, the NIS's.

A restart calls the node's ``on_restart(reason)``, which resets its core: the core sees only
checked samples in stamp order (a node that gives no ``on_restart`` still leaves the jump
to its core). The ordered policies release the
streams in stamp order (:class:`gimbal_kinematics.timing.sync.StampOrder`), so a replay at any
speed computes what the run computed; the sampled ones release each sample at once with the
interval it covers.

The controllers' policies (fresh inputs, the stale-input policy) are in
:mod:`gimbal_kinematics.timing.control_policy`.
"""
from __future__ import annotations

from typing import Any, Callable, Mapping, NamedTuple, Sequence

from .stamps import Stamp, is_gap, judge, progress_stamp_ns, step_of_stamp, step_stamp_ns
from .stream_stats import SilenceWatch, StreamStats
from .sync import StampOrder, StampSync, StepGroups


class Step(NamedTuple):
    """One input released to the core: its stream, absolute stamp [ns], the core's time
    of it [s], the message, for a sampled stream the interval it covers [s], and whether it
    is the last input of its lockstep step."""

    kind: str
    stamp_ns: int
    t: float
    msg: Any
    dt: float = 0.0
    ends_step: bool = True


Fields = Mapping[str, Any]


class SampleGrid:
    """The lockstep grid of streams sampled every n steps: which sample at step k, in the
    order given (within a step the first goes first), and the next step that samples any.
    ``first``: stream -> the first step it samples at (0 when absent): a stream made a step
    ahead of its stamp by a node that waits for this one (the servo's next φz) has none at 0."""

    def __init__(self, every: Mapping[str, int], first: Mapping[str, int] | None = None) -> None:
        if not every or any(n < 1 for n in every.values()):
            raise ValueError(f"every stream needs a sampling period of >= 1 step, got {dict(every)}")
        self.every = dict(every)
        self.first = dict(first or {})

    def needs(self, k: int) -> tuple[str, ...]:
        return tuple(stream for stream, n in self.every.items() if k % n == 0 and k >= self.first.get(stream, 0))

    def next_due(self, k: int) -> int:
        """The first step after ``k`` at which a stream samples."""
        return min(k - k % n + n for n in self.every.values())


class _CoreReport:
    """A lockstep policy's core time (the stamp in seconds) and /diagnostics (the core's
    counters only; module docstring)."""

    def stamp_of(self, t: float) -> int:
        return int(round(t * 1e9))

    def counters(self) -> dict[str, int]:
        return {}

    def report(self, core: Fields, node: Fields, nis: Fields, nis_verdict: str | None
               ) -> tuple[dict[str, Any], str | None]:
        return dict(core), None


class LockstepOrder(_CoreReport):
    """Lockstep input policy (module docstring): each stream's stamp judged against its last
    (:func:`gimbal_kinematics.timing.stamps.judge`: a duplicate or late stamp dropped and counted in
    ``rejected``; one more than ``clock_jump_ns`` back restarts, ``on_restart(reason)``
    resetting the node's core), then ``streams`` in stamp order (within a stamp in the order
    given), released when every stream has reached the stamp or after ``max_wait_ns``;
    ``~/progress`` every ``progress_every`` steps of ``rate_hz``; /diagnostics with the
    core's counters."""

    timing = "lockstep"
    diagnostics = True

    def __init__(self, streams: Sequence[str], max_wait_ns: int, rate_hz: float, progress_every: int,
                 clock_jump_ns: int = 0, on_restart: Callable[[str], None] | None = None) -> None:
        self.order = StampOrder(streams, max_wait_ns)
        self.rate_hz = rate_hz
        self.progress_every = int(progress_every)
        self.clock_jump_ns = int(clock_jump_ns)
        self.on_restart = on_restart
        self._last: dict[str, int | None] = dict.fromkeys(streams)
        #: stamps dropped as duplicate or late, over every stream
        self.rejected = 0
        self.silence = SilenceWatch()

    def add(self, kind: str, stamp_ns: int, msg: Any) -> list[Step]:
        last = self._last[kind]
        if last is not None and stamp_ns <= last:
            if judge(stamp_ns, last, self.clock_jump_ns) is not Stamp.JUMPED_BACK:
                self.rejected += 1
                self.silence.heard(0)
                return []
            self._restart(kind, last, stamp_ns)
        self._last[kind] = stamp_ns
        out = [Step(k, s, s * 1e-9, m) for k, (s, m) in self.order.add(kind, stamp_ns, (stamp_ns, msg))]
        self.silence.heard(len(out))
        return out

    def _restart(self, stream: str, last_ns: int, stamp_ns: int) -> None:
        """A clock jump back (a bag looping): forget the old run's buffered inputs and stamps."""
        if self.on_restart is not None:
            self.on_restart(f"clock jumped back on {stream}: {last_ns * 1e-9:.6f} s -> {stamp_ns * 1e-9:.6f} s")
        self.order = StampOrder(self.order.streams, self.order.max_wait_ns)
        self._last = dict.fromkeys(self._last)

    def progress(self, step: Step) -> int | None:
        """The next step's stamp when it starts a new block of ``progress_every`` steps."""
        return progress_stamp_ns(step.stamp_ns, self.rate_hz, self.progress_every)


class LockstepGroups(_CoreReport):
    """Lockstep policy of a node whose inputs are grouped by step
    (:class:`gimbal_kinematics.timing.sync.StepGroups`): an input stamped off the steps its stream
    samples at (``needs(k)``) is rejected and counted (``off_grid``); a complete step is
    released as one step per input, in the order of ``streams``, at the core time k /
    ``rate_hz``; after a step's last input ``~/progress`` names ``next_due(k)`` when that
    starts a new block of ``progress_every`` steps. No /diagnostics. ``logger`` (rclpy's, or
    anything with ``warning``/``info``) hears of rejections and restarts; ``on_restart(reason)``
    of each restart, before the new run's first step (the node resets its core)."""

    timing = "lockstep"
    diagnostics = False

    def __init__(self, streams: Sequence[str], needs: Callable[[int], tuple[str, ...]], rate_hz: float,
                 clock_jump_s: float, next_due: Callable[[int], int], progress_every: int, logger: Any,
                 on_restart: Callable[[str], None] | None = None) -> None:
        self.on_restart = on_restart
        self.streams = tuple(streams)
        self.needs = needs
        self.rate_hz = rate_hz
        self.sync = StepGroups(needs, clock_jump_s * rate_hz)
        self.next_due = next_due
        self.progress_every = int(progress_every)
        self.logger = logger
        self.off_grid = 0
        self.silence = SilenceWatch()

    def add(self, kind: str, stamp_ns: int, msg: Any) -> list[Step]:
        k = step_of_stamp(stamp_ns, self.rate_hz)
        if kind not in self.needs(k):
            self.off_grid += 1
            self.logger.warning(f"{kind} stamped for step {k}, not one of its sample steps: ignored "
                                f"({self.off_grid} off the rate grid)", throttle_duration_sec=1.0)
            self.silence.heard(0)
            return []
        out: list[Step] = []
        restarts = self.sync.restarts
        done = self.sync.add(kind, k, msg, self.logger)
        if self.sync.restarts > restarts and self.on_restart is not None:
            self.on_restart(f"clock jumped back on {kind} to step {k}")
        for step, group in done:
            stamp, t = step_stamp_ns(step, self.rate_hz), step / self.rate_hz
            kinds = [s for s in self.streams if s in group]
            out.extend(Step(s, stamp, t, group[s], ends_step=s == kinds[-1]) for s in kinds)
        self.silence.heard(len(out))
        return out

    @property
    def rejected(self) -> int:
        """Stamps dropped as repeated or late (for a step already released)."""
        return self.sync.rejected

    def progress(self, step: Step) -> int | None:
        if not step.ends_step:
            return None
        k = step_of_stamp(step.stamp_ns, self.rate_hz)
        nxt = self.next_due(k)
        return step_stamp_ns(nxt, self.rate_hz) if nxt // self.progress_every > k // self.progress_every else None


class HeldSamples:
    """The samples a stream's stamp judge holds (the clock-jump rule of
    :mod:`gimbal_kinematics.timing.stamps`): ``take(stream, verdict, stamp_ns, msg)`` returns the
    samples to use now, in order: none while held or rejected, the held ones then this one
    once a jump is believed, this one alone otherwise. ``warn(text)`` hears of each
    rejection and of outliers dropped."""

    def __init__(self, stats: Mapping[str, StreamStats], warn: Callable[[str], None] | None) -> None:
        self.stats = stats
        self.warn = warn
        self._held: dict[str, list[tuple[int, Any]]] = {s: [] for s in stats}
        self._outliers = dict.fromkeys(stats, 0)

    def take(self, stream: str, verdict: Stamp, stamp_ns: int, msg: Any) -> list[tuple[int, Any]]:
        st, held = self.stats[stream], self._held[stream]
        if verdict is Stamp.OK and not held:  # the usual case (a bag replayed at full speed: per message)
            return [(stamp_ns, msg)]
        if st.outliers != self._outliers[stream]:
            held.clear()  # the ones held were outliers (the judge counted them)
        self._say(stream, st, verdict, stamp_ns)
        if verdict is Stamp.HELD:
            held.append((stamp_ns, msg))
            return []
        released = set(st.released)
        kept = [(s, m) for s, m in held if s in released]
        held.clear()
        return [*kept, (stamp_ns, msg)] if verdict.accepted else []

    def _say(self, stream: str, st: StreamStats, verdict: Stamp, stamp_ns: int) -> None:
        new_outliers, self._outliers[stream] = st.outliers - self._outliers[stream], st.outliers
        if self.warn is None:
            return
        if new_outliers:
            self.warn(f"{stream}: {new_outliers} sample(s) with a stamp off the stream's timeline dropped as "
                      "outliers (counted; a clock jump needs several samples in a row)")
        if verdict is Stamp.DUPLICATE or verdict is Stamp.OUT_OF_ORDER:
            self.warn(f"{stream} sample at {stamp_ns * 1e-9:.6f} s dropped: {verdict.value} stamp (counted)")


class FreeOrder:
    """Free-timing input policy (module docstring): each stream's stamps judged, a stamp
    more than ``clock_jump_ns`` back restarts (``on_restart(reason)``: the node resets its
    core; None: the core judges the jump itself, the stamp goes on in order and the time
    origin stays), then the streams in stamp order as in :class:`LockstepOrder`;
    ``~/progress`` every ``progress_every`` steps of the pacing stream ``paced`` (None:
    every step the node reports)."""

    timing = "free"
    diagnostics = True

    def __init__(self, streams: Sequence[str], max_wait_ns: int, clock_jump_ns: int, progress_every: int,
                 on_restart: Callable[[str], None] | None, paced: str | None = None,
                 warn: Callable[[str], None] | None = None) -> None:
        self.order = StampOrder(streams, max_wait_ns)
        self.stats = {s: StreamStats(clock_jump_ns) for s in streams}
        self.progress_every = int(progress_every)
        self.on_restart = on_restart
        self.paced = paced
        self.warn = warn
        #: the run's first stamp [ns], the origin of the core's time
        self.t0_ns: int | None = None
        self._paced = 0
        self.held = HeldSamples(self.stats, warn)

    def add(self, kind: str, stamp_ns: int, msg: Any) -> list[Step]:
        verdict = self.stats[kind].offer(stamp_ns)
        samples = self.held.take(kind, verdict, stamp_ns, msg)
        if not samples:
            return []
        if verdict is Stamp.JUMPED_BACK and self.on_restart is not None:
            self._restart(kind, samples[0][0])
        out: list[Step] = []
        for stamp, item in samples:
            if self.t0_ns is None:
                self.t0_ns = stamp
            t0 = self.t0_ns
            out += [Step(k, s, (s - t0) * 1e-9, m) for k, (s, m) in self.order.add(kind, stamp, (stamp, item))]
        return out

    def _restart(self, stream: str, stamp_ns: int) -> None:
        """A clock jump back (bag loop, restarted driver): forget the old run's buffered
        messages, let the node reset its core, and take this stamp as the new origin."""
        self.on_restart(f"clock jumped back on {stream} to {stamp_ns * 1e-9:.6f} s")
        self.order = StampOrder(self.order.streams, self.order.max_wait_ns)
        for other, st in self.stats.items():
            if other != stream:
                st.last_ns = None  # the other streams' next stamps belong to the new run
        self.t0_ns = None

    @property
    def rejected(self) -> int:
        """Stamps dropped as duplicate or late, over every stream."""
        return sum(st.duplicates + st.out_of_order for st in self.stats.values())

    def stamp_of(self, t: float) -> int:
        return self.t0_ns + int(round(t * 1e9))

    def progress(self, step: Step) -> int | None:
        """This stamp, every ``progress_every`` steps of the pacing stream."""
        if self.paced is not None and step.kind != self.paced:
            return None
        self._paced += 1
        return step.stamp_ns if self._paced % self.progress_every == 0 else None

    def counters(self) -> dict[str, float | int]:
        out: dict[str, float | int] = {}
        for name, st in self.stats.items():
            out.update(st.as_dict(name))
        return out

    def report(self, core: Fields, node: Fields, nis: Fields, nis_verdict: str | None
               ) -> tuple[dict[str, Any], str | None]:
        return {**core, **self.counters(), **node, **nis}, nis_verdict


class LockstepSamples(_CoreReport):
    """Lockstep policy of a sampled node (module docstring): each sample is a step at once,
    covering the nominal ``period_s``; ``~/progress`` names the step one sample after the
    older of the streams' newest, every ``progress_every`` steps of ``rate_hz``. A stamp more
    than ``clock_jump_ns`` before the newest of any stream restarts (``on_restart(reason)``:
    the node resets its core before the sample). No /diagnostics."""

    timing = "lockstep"
    diagnostics = False

    def __init__(self, streams: Sequence[str], rate_hz: float, sample_rate_hz: float, progress_every: int,
                 clock_jump_ns: int = 0, on_restart: Callable[[str], None] | None = None) -> None:
        self.clock_jump_ns, self.on_restart, self._run_newest = int(clock_jump_ns), on_restart, None
        self.rate_hz = rate_hz
        self.period_s = 1.0 / sample_rate_hz
        self.steps_per_sample = int(round(rate_hz / sample_rate_hz))
        self.progress_every = int(progress_every)
        self._newest: dict[str, int | None] = dict.fromkeys(streams)
        self._reported = 0

    def add(self, kind: str, stamp_ns: int, msg: Any) -> list[Step]:
        newest = self._run_newest
        if self.on_restart is not None and judge(stamp_ns, newest, self.clock_jump_ns) is Stamp.JUMPED_BACK:
            self.on_restart(f"backward clock jump on {kind} from {newest * 1e-9:.6f} s to {stamp_ns * 1e-9:.6f} s")
            newest = None
        self._run_newest = stamp_ns if newest is None else max(newest, stamp_ns)
        return [Step(kind, stamp_ns, stamp_ns * 1e-9, msg, self.period_s)]

    def progress(self, step: Step) -> int | None:
        newest = self._newest[step.kind]
        if newest is None or step.stamp_ns > newest:
            self._newest[step.kind] = step.stamp_ns
        if None in self._newest.values():
            return None
        k = step_of_stamp(min(self._newest.values()), self.rate_hz) + self.steps_per_sample  # type: ignore[type-var]
        if k < self._reported + self.progress_every:
            return None
        self._reported = k
        return step_stamp_ns(k, self.rate_hz)


class FreeSamples:
    """Free-timing policy of a sampled node (module docstring): each stream's stamps judged
    (duplicates and late samples dropped, counted); a sample's interval is its stamp minus
    its stream's previous accepted one when that is no gap (the drop rule of
    :mod:`gimbal_kinematics.timing.stamps` at ``period_ns``, so jitter is followed), the nominal
    period for a stream's first sample or the first after a clock jump (which calls
    ``on_restart(reason)`` first: the node resets its core); after a gap the interval is unknown, so the sample is not released
    (counted, ``<stream>_interval_unknown``). The core's time runs from the first stamp.
    ``~/progress``: the older stream's newest stamp every ``progress_every`` samples.
    ``warn(text)`` hears of each sample dropped."""

    timing = "free"
    diagnostics = True

    def __init__(self, streams: Sequence[str], sample_rate_hz: float, clock_jump_ns: int, progress_every: int,
                 warn: Callable[[str], None], on_restart: Callable[[str], None] | None = None) -> None:
        self.on_restart = on_restart
        self.stats = {s: StreamStats(clock_jump_ns) for s in streams}
        self.period_s = 1.0 / sample_rate_hz
        self.period_ns = 1e9 / sample_rate_hz
        self.progress_every = int(progress_every)
        self.warn = warn
        self.t0_ns: int | None = None
        self._last: dict[str, int | None] = dict.fromkeys(streams)
        self.interval_unknown = dict.fromkeys(streams, 0)
        self._samples = 0
        self.held = HeldSamples(self.stats, warn)

    def add(self, kind: str, stamp_ns: int, msg: Any) -> list[Step]:
        verdict = self.stats[kind].offer(stamp_ns)
        out: list[Step] = []
        for i, (stamp, item) in enumerate(self.held.take(kind, verdict, stamp_ns, msg)):
            out += self._sample(kind, stamp, item, new_run=i == 0 and verdict is Stamp.JUMPED_BACK)
        return out

    def _sample(self, kind: str, stamp_ns: int, msg: Any, new_run: bool) -> list[Step]:
        if self.t0_ns is None:
            self.t0_ns = stamp_ns
        last, self._last[kind] = self._last[kind], stamp_ns
        if new_run and self.on_restart is not None:
            self.on_restart(f"backward clock jump on {kind} to {stamp_ns * 1e-9:.6f} s")
        if new_run or last is None:
            dt = self.period_s  # first sample, or a new run (the core reset)
        elif is_gap(stamp_ns - last, self.period_ns):
            self.interval_unknown[kind] += 1
            self.warn(f"{kind} sample at {stamp_ns * 1e-9:.6f} s after a gap of {(stamp_ns - last) * 1e-9:.3f} s: "
                      "its interval is unknown, not integrated")
            return []
        else:
            dt = (stamp_ns - last) * 1e-9
        return [Step(kind, stamp_ns, (stamp_ns - self.t0_ns) * 1e-9, msg, dt)]

    def stamp_of(self, t: float) -> int:
        return self.t0_ns + int(round(t * 1e9))

    def progress(self, step: Step) -> int | None:
        self._samples += 1
        if self._samples % self.progress_every or None in self._last.values():
            return None
        return min(self._last.values())  # type: ignore[type-var]

    def counters(self) -> dict[str, float | int]:
        out: dict[str, float | int] = {}
        for name, st in self.stats.items():
            out.update(st.as_dict(name))
            out[f"{name}_interval_unknown"] = self.interval_unknown[name]
        return out

    def report(self, core: Fields, node: Fields, nis: Fields, nis_verdict: str | None
               ) -> tuple[dict[str, Any], str | None]:
        return {**core, **self.counters(), **node, **nis}, nis_verdict


def order_policy(timing: str, streams: Sequence[str], *, max_wait_ns: int, rate_hz: float, progress_every: int,
                 clock_jump_ns: int, on_restart: Callable[[str], None]) -> LockstepOrder | FreeOrder:
    """The stamp-ordered input policy of ``timing`` (a node's one choice, in its constructor)."""
    if timing == "lockstep":
        return LockstepOrder(streams, max_wait_ns, rate_hz, progress_every, clock_jump_ns, on_restart)
    if timing == "free":
        return FreeOrder(streams, max_wait_ns, clock_jump_ns, progress_every, on_restart)
    raise ValueError(f"parameter 'timing' = {timing!r} is not one of ['free', 'lockstep']")


def sample_policy(timing: str, streams: Sequence[str], *, rate_hz: float, sample_rate_hz: float,
                  progress_every: int, clock_jump_ns: int, warn: Callable[[str], None],
                  on_restart: Callable[[str], None] | None = None) -> LockstepSamples | FreeSamples:
    """The sampled input policy of ``timing`` (a node's one choice, in its constructor):
    streams sampled at ``sample_rate_hz``, lockstep steps at ``rate_hz``; a clock jump back
    calls ``on_restart(reason)``, the node's core reset."""
    if timing == "lockstep":
        return LockstepSamples(streams, rate_hz, sample_rate_hz, progress_every, clock_jump_ns, on_restart)
    if timing == "free":
        return FreeSamples(streams, sample_rate_hz, clock_jump_ns, progress_every, warn, on_restart)
    raise ValueError(f"parameter 'timing' = {timing!r} is not one of ['free', 'lockstep']")


def grouped_policy(timing: str, every: Mapping[str, int], *, rate_hz: float, progress_every: int,
                   clock_jump_s: float, max_wait_ns: int, paced: str, logger: Any,
                   on_restart: Callable[[str], None] | None = None,
                   first: Mapping[str, int] | None = None) -> LockstepGroups | FreeOrder:
    """The input policy of ``timing`` for a node whose lockstep inputs are grouped by step,
    each stream sampled every ``every[stream]`` steps (:class:`SampleGrid`; within a step in
    that order): lockstep :class:`LockstepGroups`; free :class:`FreeOrder` (stamp order,
    ``~/progress`` on the ``paced`` stream). A clock jump back calls ``on_restart(reason)``,
    the node's core reset (None: the core judges the jump itself). ``first``: the lockstep
    grid's first sample step of a stream (:class:`SampleGrid`)."""
    streams, grid = tuple(every), SampleGrid(every, first)
    if timing == "lockstep":
        return LockstepGroups(streams, grid.needs, rate_hz, clock_jump_s, grid.next_due, progress_every, logger,
                              on_restart)
    if timing == "free":
        def warn(text: str) -> None:
            logger.warning(text, throttle_duration_sec=1.0)
        return FreeOrder(streams, max_wait_ns, int(round(clock_jump_s * 1e9)), progress_every, on_restart, paced,
                         warn)
    raise ValueError(f"parameter 'timing' = {timing!r} is not one of ['free', 'lockstep']")


class _Synced(_CoreReport):
    """One step per complete exact-stamp group of ``streams``
    (:class:`gimbal_kinematics.timing.sync.StampSync`), at the core time of its stamp [s]. A stamp
    more than ``clock_jump_ns`` before the last group's restarts (``on_restart(reason)``:
    the node resets its core). ``rejected``: stamps refused (late or repeated), every run."""

    def __init__(self, streams: Sequence[str], clock_jump_ns: int | None = None,
                 on_restart: Callable[[str], None] | None = None) -> None:
        self.streams = tuple(streams)
        self.sync = StampSync(self.streams)
        self.clock_jump_ns, self.on_restart = clock_jump_ns, on_restart
        self._last_ns: int | None = None  # the last group's stamp
        self._rejected_before = 0

    @property
    def rejected(self) -> int:
        return self._rejected_before + self.sync.rejected

    def add(self, kind: str, stamp_ns: int, msg: Any) -> list[Step]:
        jump = self.clock_jump_ns
        if jump is not None and judge(stamp_ns, self._last_ns, jump) is Stamp.JUMPED_BACK:
            if self.on_restart is not None:
                self.on_restart(f"read-out stamp jumped back {(self._last_ns - stamp_ns) * 1e-9:.3f} s "
                                "(clock reset or bag loop)")
            self.restart()
        group = self.sync.add(kind, stamp_ns, msg)
        if group is None:
            return []
        self._last_ns = stamp_ns
        return [Step("group", stamp_ns, stamp_ns * 1e-9, group)]

    def restart(self) -> None:
        self._rejected_before += self.sync.rejected
        self.sync = StampSync(self.streams)
        self._last_ns = None

    def report(self, core: Fields, node: Fields, nis: Fields, nis_verdict: str | None
               ) -> tuple[dict[str, Any], str | None]:
        return {**core, **node, **nis}, nis_verdict


class LockstepSynced(_Synced):
    """Lockstep policy of a node stepping on exact-stamp groups: ``~/progress`` names the
    next group's step, one learned interval (in steps of ``rate_hz``) ahead, every
    ``progress_every`` steps. No /diagnostics."""

    timing = "lockstep"
    diagnostics = False

    def __init__(self, streams: Sequence[str], rate_hz: float, progress_every: int, clock_jump_ns: int | None = None,
                 on_restart: Callable[[str], None] | None = None) -> None:
        super().__init__(streams, clock_jump_ns, on_restart)
        self.rate_hz = rate_hz
        self.progress_every = int(progress_every)
        self._clear()

    def _clear(self) -> None:
        self._last_step: int | None = None
        self._interval_steps = 1
        self._report_at = 0

    def restart(self) -> None:
        super().restart()
        self._clear()

    def progress(self, step: Step) -> int | None:
        k = step_of_stamp(step.stamp_ns, self.rate_hz)
        if self._last_step is not None and k > self._last_step:
            self._interval_steps = k - self._last_step
        self._last_step = k
        if k < self._report_at:
            return None
        self._report_at = k + self.progress_every
        return step_stamp_ns(k + self._interval_steps, self.rate_hz)


class FreeSynced(_Synced):
    """Free-timing policy of a node stepping on exact-stamp groups: ``~/progress`` reports
    the group's stamp every ``progress_every`` groups; /diagnostics."""

    timing = "free"
    diagnostics = True

    def __init__(self, streams: Sequence[str], progress_every: int, clock_jump_ns: int | None = None,
                 on_restart: Callable[[str], None] | None = None) -> None:
        super().__init__(streams, clock_jump_ns, on_restart)
        self.progress_every = int(progress_every)
        self._groups = 0

    def progress(self, step: Step) -> int | None:
        self._groups += 1
        return step.stamp_ns if self._groups % self.progress_every == 0 else None


def synced_policy(timing: str, streams: Sequence[str], *, rate_hz: float, progress_every: int,
                  clock_jump_ns: int | None = None, on_restart: Callable[[str], None] | None = None
                  ) -> LockstepSynced | FreeSynced:
    """The exact-stamp-group input policy of ``timing`` (a node's one choice, in its constructor)."""
    if timing == "lockstep":
        return LockstepSynced(streams, rate_hz, progress_every, clock_jump_ns, on_restart)
    if timing == "free":
        return FreeSynced(streams, progress_every, clock_jump_ns, on_restart)
    raise ValueError(f"parameter 'timing' = {timing!r} is not one of ['free', 'lockstep']")
