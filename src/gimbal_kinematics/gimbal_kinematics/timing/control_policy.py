"""The input policies of the controller nodes (pure Python, no rclpy): the controllers'
side of :mod:`gimbal_kinematics.timing.input_policy`, one interface, two timings.

A controller node validates each input once, as it arrives (an input it cannot use becomes
``None``, counted by the node), hands it to ``policy.add(kind, stamp_ns, value)`` and runs
its one ``_step`` on each :class:`ControlStep` returned, whatever the timing. What differs
between the timings lives here:

* lockstep (:class:`LockstepControl`): the orchestrator's graph. A step k is released when
  the inputs it needs (``needs(k)``) stamped k are in (:class:`~gimbal_kinematics.timing.sync.StepGroups`,
  or :class:`~gimbal_kinematics.timing.sync.EagerStepGroups` for a loop that must not stall behind
  a lost input); an input that could not be used is in the step as ``None``, so the node
  holds its last command. An estimate stamped off the steps that wait for it is released
  at once as a step without a command (``command`` false). Nothing is ever zeroed.
* free (:class:`FreeControl`): a driver or a bag. Each sample of the driving stream is a
  command step with the newest fresh inputs (:class:`~gimbal_kinematics.timing.sync.FreshInputs`);
  an input that could not be used is not taken. A stale or missing measurement sets
  ``zero_command`` (counted, ``stale_commands``); a stale or missing estimate (``held``)
  is left out of the step, so the core keeps the last one (``stale_estimate_steps``); the
  loop restarts (``resets``) after a clock jump back and when the inputs are fresh again
  after a stale period (``restarts_after_stale``).

Why zero and why hold, in free timing:

* a stale or missing measurement *zeroes* the command: zero torque or voltage lets the
  gimbal coast, while a command computed from inputs that no longer hold can drive it into
  a stop (the papers say nothing about lost inputs);
* a stale or missing *estimate* (another node's gyro-bias or attitude estimate) does not:
  the loop goes on with the last estimate it took (none yet: no correction, as the lockstep
  loop before the filter's first output). A bias changes over hours, so the last estimate
  is still the best correction, and the rate loop stays closed on the gyro; zeroing torque
  instead lets the gimbal follow the vehicle (an estimator starting a few samples late cost
  the real-time rehearsal over a degree of LOS in a tenth of a second);
* when the inputs are fresh again the loop restarts (the core reset: it was open); a clock
  jump back (a bag looping) resets it too.

``counters()`` is what ``/diagnostics`` adds to the node's own counters; ``diagnostics``
says whether the node advertises /diagnostics at all (a lockstep controller never did).
"""
from __future__ import annotations

import math
from numbers import Integral
from typing import Any, Callable, Mapping, NamedTuple, Sequence, TypeVar

from .stream_stats import SilenceWatch
from .stamps import step_of_stamp, step_stamp_ns
from .sync import EagerStepGroups, FreshInputs, StepGroups

#: the free policy's own counters, in /diagnostics order
FREE_COUNTERS = ("stale_commands", "stale_estimate_steps", "restarts_after_stale")
RESTART_JUMP = "stamps jumped back (a bag looping?): restarted"
RESTART_FRESH = "inputs fresh again after a stale period: loop restarted"


class Sample(NamedTuple):
    """A validated input as the core takes it: its core time [s] and value."""

    t: float
    value: Any


class ControlStep(NamedTuple):
    """What the node's ``_step`` does once: the command's stamp [ns] and core time [s]; the
    inputs of the step (kind -> :class:`Sample`, or None for one that could not be used; a
    kind absent was not sampled, or is a stale estimate); whether it makes a command (False:
    an estimate to use as it comes); whether the command is zeroed; the reasons to reset the
    core first, in order."""

    stamp_ns: int
    t: float
    inputs: Mapping[str, Sample | None]
    command: bool = True
    zero_command: bool = False
    resets: tuple[str, ...] = ()


class LockstepControl:
    """Lockstep controller policy (module docstring). ``needs(k)``: the inputs step k waits
    for; ``estimates``: kinds used at once when stamped off the steps that wait for them;
    ``ticks``: kinds that only pace steps (``/clock``, the node subscribes to them), ignored
    at steps that do not need them; ``eager_stale_steps``: release each step the moment it is complete
    (:class:`~gimbal_kinematics.timing.sync.EagerStepGroups`, incomplete steps that many steps older
    forgotten) instead of in order, each stream's stamps judged (a repeated or late step of a
    stream dropped, counted in ``rejected``; one more than ``clock_jump_s`` back restarts, the
    next step carrying the reset) so the core sees them in order; ``sample_hold``: kinds whose
    newest sample (or None, for one that could not be used or none yet) is in every step,
    at the step's time (a core fed each input every step); ``stamp_time``: a step's core time
    is its stamp in seconds (default: k / ``rate_hz``). In order, a clock jump back of more
    than ``clock_jump_s`` starts the steps over, the first step of the new run carrying the
    reset. ``logger`` hears of rejections and restarts."""

    timing = "lockstep"
    diagnostics = False

    def __init__(self, needs: Callable[[int], tuple[str, ...]], rate_hz: float, clock_jump_s: float, *,
                 estimates: Sequence[str] = (), ticks: Sequence[str] = (), eager_stale_steps: int | None = None,
                 sample_hold: Sequence[str] = (), stamp_time: bool = False, logger: Any = None) -> None:
        self.needs = needs
        self.rate_hz = rate_hz
        self.estimates = frozenset(estimates)
        self.ticks = tuple(ticks)
        self.logger = logger
        self.stamp_time = stamp_time
        self._held: dict[str, Sample | None] = dict.fromkeys(sample_hold)
        self.eager = eager_stale_steps is not None
        self.sync: StepGroups | EagerStepGroups = (EagerStepGroups(needs, eager_stale_steps) if self.eager
                                                   else StepGroups(needs, clock_jump_s * rate_hz))
        self.backjump_steps = clock_jump_s * rate_hz
        self._last_k: dict[str, int] = {}  # eager: each stream's newest step
        self._resets: tuple[str, ...] = ()  # for the next step released
        self.rejected = 0
        self.silence = SilenceWatch()

    def add(self, kind: str, stamp_ns: int, value: Any) -> list[ControlStep]:
        out = self._add(kind, stamp_ns, value)
        self.silence.heard(len(out))
        return out

    def _add(self, kind: str, stamp_ns: int, value: Any) -> list[ControlStep]:
        k = step_of_stamp(stamp_ns, self.rate_hz)
        sample = None if value is None else Sample(stamp_ns * 1e-9, value)
        if (kind in self.ticks or kind in self.estimates) and kind not in self.needs(k):
            # a tick a gyro sample paces anyway; an estimate at a step that does not wait for one
            if kind in self.ticks or not self.sync.admit(kind, k, self.logger) or sample is None:  # type: ignore[union-attr]
                return []
            return [ControlStep(stamp_ns, sample.t, {kind: sample}, command=False)]
        if self.eager:
            if not self._in_order(kind, k):
                return []
            group = self.sync.add(kind, k, sample, self.logger)
            done = [] if group is None else [(k, group)]
        else:
            restarts = self.sync.restarts  # type: ignore[union-attr]
            done = self.sync.add(kind, k, sample, self.logger)
            if self.sync.restarts > restarts:  # type: ignore[union-attr]
                self._resets = (RESTART_JUMP,)
        return [self._step(step, group) for step, group in done]

    def _in_order(self, kind: str, k: int) -> bool:
        """Whether ``kind``'s step ``k`` comes after its last (eager steps; class docstring)."""
        last = self._last_k.get(kind)
        if last is not None and k <= last:
            if last - k <= self.backjump_steps:
                self.rejected += 1
                if self.logger is not None:
                    self.logger.warning(f"{kind} stamped for step {k}, not after its step {last}: ignored "
                                        f"({self.rejected} rejected)", throttle_duration_sec=1.0)
                return False
            self._last_k.clear()
            self.sync = EagerStepGroups(self.needs, self.sync.stale_steps)  # type: ignore[union-attr]
            self._resets = (RESTART_JUMP,)
        self._last_k[kind] = k
        return True

    def _step(self, k: int, group: dict[str, Sample | None]) -> ControlStep:
        stamp = step_stamp_ns(k, self.rate_hz)
        t = stamp * 1e-9 if self.stamp_time else k / self.rate_hz
        held = self._held
        if held:
            for kind in held:
                if kind in group:
                    held[kind] = group[kind]
            group.update((kind, None if s is None else Sample(t, s.value)) for kind, s in held.items())
        resets, self._resets = self._resets, ()
        return ControlStep(stamp, t, group, resets=resets)

    def counters(self) -> dict[str, int]:
        return {}


class StaleRule:
    """The stale-input rule of free timing (module docstring), on the streams a step found
    ``stale``: a stale measurement zeroes the command (``stale_commands``), a stale ``held``
    estimate keeps the loop running (``stale_estimate_steps``), the first step fresh again
    after a zeroed one restarts the loop (``restarts_after_stale``). Counts into ``counts``
    (a dict of its own by default); ``warn(text)`` hears of each step counted."""

    def __init__(self, held: Sequence[str], warn: Callable[[str], None],
                 counts: dict[str, int] | None = None) -> None:
        self.held = frozenset(held)
        self.warn = warn
        self.counts = dict.fromkeys(FREE_COUNTERS, 0) if counts is None else counts
        self.was_stale = False

    def judge(self, stale: Sequence[str]) -> tuple[bool, bool]:
        """(zero the command, restart the loop first) for a step whose ``stale`` streams these are."""
        zeroing = [s for s in stale if s not in self.held]
        if len(zeroing) < len(stale):
            self._count("stale_estimate_steps", f"{', '.join(s for s in stale if s in self.held)} older "
                        "than its maximum age or missing: the last estimate kept")
        if zeroing:
            self._count("stale_commands", f"{', '.join(zeroing)} older than its maximum age or missing: "
                        "command zeroed")
            self.was_stale = True
            return True, False
        if self.was_stale:
            self.was_stale = False
            self.counts["restarts_after_stale"] += 1
            return False, True
        return False, False

    def _count(self, counter: str, text: str) -> None:
        self.counts[counter] += 1
        self.warn(f"{text} ({self.counts[counter]} {counter})")


class FreeControl:
    """Free-timing controller policy (module docstring): steps on each sample of ``driver``
    with the inputs of ``max_age_s`` (kind -> maximum age [s]) no older than that;
    ``period_s``: the driver's nominal period (drop and jitter counts); ``held``: the
    estimates whose staleness keeps the loop running; ``on_arrival``: estimates used as they
    come (a step without a command), never in a command step; ``once``: inputs given to the
    core only in the first command step after they arrive (and again after a restart);
    ``finite``: inputs whose non-finite samples are not taken (``on_nonfinite(kind)``: the
    node counts them; other inputs' are the core's to judge). ``warn(text)`` hears of each
    step counted."""

    timing = "free"
    diagnostics = True
    ticks: tuple[str, ...] = ()  # a gyro sample is a step: nothing else paces the loop

    def __init__(self, driver: str, max_age_s: Mapping[str, float], period_s: float, clock_jump_s: float, *,
                 held: Sequence[str] = (), on_arrival: Sequence[str] = (), once: Sequence[str] = (),
                 finite: Sequence[str] = (), on_nonfinite: Callable[[str], None] = lambda kind: None,
                 warn: Callable[[str], None] = lambda text: None) -> None:
        unknown = (set(held) | set(on_arrival) | set(once)) - set(max_age_s)
        if unknown:
            raise ValueError(f"streams {sorted(unknown)} are not inputs")
        self.gate = FreshInputs(driver, {k: int(round(a * 1e9)) for k, a in max_age_s.items()},
                                int(round(period_s * 1e9)), int(round(clock_jump_s * 1e9)))
        self.driver = driver
        self.on_arrival = frozenset(on_arrival)
        self.once = tuple(once)
        self.finite = frozenset(finite)
        self.on_nonfinite = on_nonfinite
        self.rule = StaleRule(held, warn)
        self.counts = self.rule.counts
        self._fed: dict[str, int | None] = dict.fromkeys(self.once)

    def seconds(self, stamp_ns: int) -> float:
        """A stamp as seconds after the first stamp seen [s]."""
        return (stamp_ns - self.gate.t0_ns) * 1e-9

    def add(self, kind: str, stamp_ns: int, value: Any) -> list[ControlStep]:
        if value is None:
            return []  # not usable: counted by the node, never fused
        if kind in self.finite and not all(map(math.isfinite, value)):
            self.on_nonfinite(kind)
            return []
        gate = self.gate
        if kind in self.on_arrival:
            accepted = gate.accepted[kind]
            gate.add(kind, stamp_ns, (stamp_ns, value))
            if gate.accepted[kind] == accepted:
                return []
            t = self.seconds(stamp_ns)
            return [ControlStep(stamp_ns, t, {kind: Sample(t, value)}, command=False)]
        step = gate.add(kind, stamp_ns, (stamp_ns, value))
        if step is None:
            return []
        resets = (RESTART_JUMP,) if step.restarted else ()
        if step.restarted:
            self._fed = dict.fromkeys(self.once)
        t = step.t_ns * 1e-9
        zero, resumed = self.rule.judge(step.stale)
        if zero:
            self._fed = dict.fromkeys(self.once)
            return [ControlStep(stamp_ns, t, {}, zero_command=True, resets=resets)]
        if resumed:
            resets += (RESTART_FRESH,)
        inputs = {self.driver: Sample(t, value)}
        for other, item in step.inputs.items():
            if other in self.on_arrival or other in step.stale:
                continue  # a stale estimate: the core keeps the last one
            t_in, v = item
            if other in self._fed:
                fed = self._fed[other]
                if fed is not None and t_in <= fed:
                    continue
                self._fed[other] = t_in
            inputs[other] = Sample(self.seconds(t_in), v)
        return [ControlStep(stamp_ns, t, inputs, resets=resets)]

    def counters(self) -> dict[str, int]:
        return {**self.gate.counters(), **self.counts}


class ArrivalCheck:
    """Slow inputs judged as they arrive, before a free policy holds them (a vehicle's INS fix
    and velocity): a stamp at or before its stream's last accepted one is ``"out_of_order"``,
    one more than ``max_age_ns`` behind the newest ``driver`` stamp is ``"stale"``; None
    accepts it (and it becomes its stream's last)."""

    def __init__(self, driver: str, streams: Sequence[str], max_age_ns: int) -> None:
        self.driver, self.max_age_ns = driver, int(max_age_ns)
        self._last: dict[str, int | None] = dict.fromkeys((driver, *streams))

    def heard(self, kind: str, stamp_ns: int) -> None:
        """Any input as it arrives: the newest ``driver`` stamp is the age reference."""
        if kind == self.driver:
            self._last[kind] = max(stamp_ns, self._last[kind] or stamp_ns)

    def last(self, kind: str) -> int | None:
        """The stamp of ``kind``'s last accepted sample [ns] (None: none yet)."""
        return self._last[kind]

    def verdict(self, kind: str, stamp_ns: int) -> str | None:
        last, newest = self._last[kind], self._last[self.driver]
        if last is not None and stamp_ns <= last:
            return "out_of_order"
        if newest is not None and newest - stamp_ns > self.max_age_ns:
            return "stale"
        self._last[kind] = stamp_ns
        return None


_Built = TypeVar("_Built")


def control_policy(timing: str, *, lockstep: Callable[[], _Built], free: Callable[[], _Built]) -> _Built:
    """What the matching factory builds for ``timing``: the controller policy, or anything else
    that depends on the node's one choice of timing, made in its constructor."""
    if timing == "lockstep":
        return lockstep()
    if timing == "free":
        return free()
    raise ValueError(f"parameter 'timing' = {timing!r} is not one of ['free', 'lockstep']")


# ------------------------------------------------------------------ commands a step loop shapes
class Released(NamedTuple):
    """What :class:`CommandStamps` hands a shaper at a step: the step's stamp [ns], the
    commands that have come by it as (stamp [ns], value), oldest first, and ``reset``: why
    the shaper starts over first ('' : it does not)."""

    stamp_ns: int
    commands: tuple[tuple[int, Any], ...] = ()
    reset: str = ""


def _int_stamp(stamp_ns: object) -> int:
    """A stamp must be an integer [ns]; anything else is a caller's bug, not data."""
    if isinstance(stamp_ns, bool) or not isinstance(stamp_ns, Integral):
        raise TypeError(f"stamps are integer nanoseconds, got {stamp_ns!r}")
    return int(stamp_ns)


#: :class:`CommandStamps`' counters
COMMAND_COUNTERS = ("commands_accepted", "rejected_duplicate", "rejected_out_of_order", "rejected_stale",
                    "rejected_future", "rejected_step_stamps")


class CommandStamps:
    """The stamp rule of a command stream that a step loop shapes (the operator's LOS rate
    commands, :mod:`gimbal_control.operator_command`), so the shaper gets checked commands
    in stamp order and never judges a stamp.

    A command (:meth:`add`, its value already checked) is refused and counted when its stamp
    is at or before the newest accepted one (``rejected_duplicate``,
    ``rejected_out_of_order``), already ``timeout_s`` old at the newest step
    (``rejected_stale``: it would stop at once) or more than ``timeout_s`` ahead of it
    (``rejected_future``: a different clock; holding it would defeat the dead-man). The
    accepted ones wait here until a step reaches their stamp. Before the first step there is
    no clock: the first step drops those already stale or too far ahead. A step stamp
    (:meth:`step`) at or before the last one and within ``clock_jump_s`` of it is refused and
    counted (``rejected_step_stamps``: None, the shaper keeps its output); further back, the
    clock jumped (a bag loop): the waiting commands are forgotten and the step says why the
    shaper starts over."""

    def __init__(self, timeout_s: float, clock_jump_s: float) -> None:
        self.timeout_ns = int(round(timeout_s * 1e9))
        self.jump_ns = int(round(clock_jump_s * 1e9))
        self.counts = dict.fromkeys(COMMAND_COUNTERS, 0)
        self._clear()

    def _clear(self) -> None:
        self._waiting: list[tuple[int, Any]] = []  # accepted, not yet reached by a step
        self._last_cmd_ns: int | None = None       # newest accepted command stamp
        self._t_ns: int | None = None              # last step stamp

    def _too_far(self, stamp: int, now: int) -> bool:
        """Whether a command stamped ``stamp`` is stale or too far ahead at ``now`` (counted)."""
        if stamp - now > self.timeout_ns:
            self.counts["rejected_future"] += 1
            return True
        if stamp + self.timeout_ns <= now:
            self.counts["rejected_stale"] += 1
            return True
        return False

    def add(self, stamp_ns: int, value: Any) -> bool:
        """A checked command stamped ``stamp_ns``; returns whether its stamp is accepted.
        ``value`` None (a command whose value the shaper refused) is not judged."""
        t = _int_stamp(stamp_ns)
        if value is None:
            return False
        if self._t_ns is not None and self._too_far(t, self._t_ns):
            return False
        last = self._last_cmd_ns
        if last is not None and t <= last:
            self.counts["rejected_duplicate" if t == last else "rejected_out_of_order"] += 1
            return False
        self._waiting.append((t, value))
        self._last_cmd_ns = t
        self.counts["commands_accepted"] += 1
        return True

    def step(self, stamp_ns: int) -> Released | None:
        """The commands a step stamped ``stamp_ns`` reaches; None: the step stamp is refused."""
        t = _int_stamp(stamp_ns)
        last, reset = self._t_ns, ""
        if last is not None and t <= last:
            if last - t <= self.jump_ns:
                self.counts["rejected_step_stamps"] += 1
                return None
            reset = f"step stamp jumped back {(last - t) * 1e-9:.3f} s (to {t} ns)"
            self._clear()
            last = None
        if last is None:  # the first step: the clock to judge the early commands by
            self._waiting = [c for c in self._waiting if not self._too_far(c[0], t)]
            self._last_cmd_ns = self._waiting[-1][0] if self._waiting else None
        n = 0
        while n < len(self._waiting) and self._waiting[n][0] <= t:
            n += 1
        reached, self._waiting = tuple(self._waiting[:n]), self._waiting[n:]
        self._t_ns = t
        return Released(t, reached, reset)

    def counters(self) -> dict[str, int]:
        """Counters for /diagnostics (name -> value, :data:`COMMAND_COUNTERS`)."""
        return dict(self.counts)
