"""Operator LOS rate command shaper: what the LOS rate controller adds to its stabilisation
reference when a person slews the sight (paper 1's operator, §1 and §6).

Input. A commanded inertial LOS rate in the sight frame m, (q, r) [rad/s] about m-y
(elevation, +q raises the LOS) and m-z (azimuth, +r turns it right), the order of the
controller's ``rate_command_qr``, stamped in integer nanoseconds (:meth:`set_rate`,
``geometry_msgs/Vector3Stamped`` y, z: a two-axis gimbal cannot roll the LOS, so x is not
commandable). Or a ``sensor_msgs/Joy`` axes array (:meth:`set_joy`), mapped as ROS teleop
nodes do: rate = scale × axis, full deflection ±1 giving ±``joy_scale_rad_s`` (rad/s, the
unit of teleop_twist_joy's ``scale_angular``, so a teleop configuration carries over). The
joy node's convention is stick up = +1 and stick left = +1; left is −r in the FRD sight
frame, hence ``joy_invert_azimuth`` defaults to True. The dead zone is joy_node's own
``deadzone`` parameter, not repeated here.

Output. At each controller step (:meth:`step`, its stamp in ns) the shaped command: each
axis follows the command in force with its acceleration limited to ``max_accel_deg_s2``,
exactly as a continuous-time slew-rate limiter would for the piecewise-constant command.
A command takes effect at its own stamp, not at the next step: the interval since the last
step is split at every command stamp and at the dead-man deadline, and each piece moves
the output towards the target then in force by at most a·Δt. For a step command v stamped
t_c the output is therefore min(|v|, a (t − t_c)) · sign v, wherever t_c falls between
steps. The limit is per axis because each axis has its own torque authority (paper 1's
gimbal: azimuth and elevation torquers with different limits and inertias).

Rate limit and bad input. A command with an axis above ``max_rate_deg_s`` is rejected and
counted, not clipped: a rate above the limit is bad input, counted and never acted on,
because it means the sender's scaling disagrees with ours (a deg-for-rad error is 57×), so
clipping would turn a wrong message into a full-rate slew; the previous valid command stays
in force and the dead-man retires it. The joystick path cannot exceed the limit: a
``joy_scale_rad_s`` above it is refused at construction. Also rejected and counted:
non-finite rates, a joystick message too short for the configured axes or with an axis
outside [−1, 1], a command stamp at or before the newest accepted one (duplicate or out of
order), a command already older than ``timeout_s`` at the newest step (stale: it would stop
at once), and one stamped more than ``timeout_s`` ahead of it (a different clock; holding it
would defeat the dead-man). Step stamps follow the project's stamp rule: at or before the
last step and within ``clock_jump_s`` of it, rejected and counted (the output is returned
unchanged); further back, the clock jumped (a bag loop) and the shaper resets (output and
commands forgotten). Those stamp rules are the node's timing policy
(:class:`gimbal_kinematics.timing.control_policy.CommandStamps`): the shaper takes only the
values (:meth:`OperatorCommand.check_rate`, :meth:`OperatorCommand.check_joy`, each
returning what it did) and, at each step, the commands that step reached, in stamp order.

Dead-man. A command older than ``timeout_s`` stops the slew: the target becomes zero at
stamp + timeout and the output ramps to zero under the acceleration limit, so a slew at v
stops by stamp + timeout + |v|/a (``last_stop_ns`` records when, ``deadman_stops`` counts
the lapses of a moving command). The controller is then back to holding (:attr:`holding`).

Defaults (argued; the paper gives none):

* ``max_rate_deg_s`` = 10: twice the 5 °/s slew the tests command, ten times the simulated
  operator's and the automatic LOS hold's 1 °/s ceilings, so neither is ever rejected.
* ``max_accel_deg_s2`` = 100 (1.75 rad/s²): paper 1's gimbal at rest has joint inertias
  M(0) of 0.110 and 0.060 kg·m² (azimuth, elevation), so the slew asks for 0.19 and
  0.11 N·m, under 7 % of the 3 and 2 N·m torquers: the stabilisation keeps its authority;
  a 5 °/s slew is reached in 50 ms.
* ``timeout_s`` = 0.5: ten periods of joy_node's default 20 Hz autorepeat, twist_mux's
  customary input timeout.

Pure Python, scalar maths (the controller calls :meth:`step` at its loop rate).
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from numbers import Integral

from gimbal_kinematics.maths.outcome import Fed, refused
from gimbal_kinematics.maths.validate import positive
from gimbal_kinematics.params.table import ParameterError

#: Relative slack on the rate limit, for a sender converting the same limit from degrees.
RATE_LIMIT_SLACK = 1e-9
#: Slack on a joystick axis beyond ±1 (joy_node normalises; float rounding only).
JOY_RANGE_SLACK = 1e-6


@dataclass(frozen=True)
class OperatorCommandParams:
    """Shaper parameters (validated, immutable); module docstring for the defaults.

    Attributes:
        max_rate_deg_s: largest commanded LOS rate per axis [°/s]; above: rejected.
        max_accel_deg_s2: acceleration limit of the shaped command per axis [°/s²].
        timeout_s: dead-man: a command older than this stops the slew [s].
        joy_azimuth_axis, joy_elevation_axis: Joy ``axes`` indices (distinct, >= 0).
        joy_scale_rad_s: rate at full deflection [rad/s], <= the rate limit; None: the
            rate limit.
        joy_invert_azimuth, joy_invert_elevation: flip an axis' sign.
    """

    max_rate_deg_s: float = 10.0
    max_accel_deg_s2: float = 100.0
    timeout_s: float = 0.5
    joy_azimuth_axis: int = 0
    joy_elevation_axis: int = 1
    joy_scale_rad_s: float | None = None
    joy_invert_azimuth: bool = True
    joy_invert_elevation: bool = False

    def __post_init__(self) -> None:
        for name in ("max_rate_deg_s", "max_accel_deg_s2", "timeout_s"):
            positive(name, getattr(self, name))
        for name in ("joy_azimuth_axis", "joy_elevation_axis"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, Integral) or value < 0:
                raise ValueError(f"{name} must be an integer >= 0, got {value!r}")
        if self.joy_azimuth_axis == self.joy_elevation_axis:
            raise ValueError(f"joy_azimuth_axis and joy_elevation_axis must differ, both are {self.joy_azimuth_axis}")
        if self.joy_scale_rad_s is not None:
            positive("joy_scale_rad_s", self.joy_scale_rad_s)
            limit = math.radians(self.max_rate_deg_s)
            if self.joy_scale_rad_s > limit * (1.0 + RATE_LIMIT_SLACK):
                raise ValueError(f"joy_scale_rad_s must be <= the rate limit max_rate_deg_s = {limit} rad/s "
                                 f"(full deflection would be refused), got {self.joy_scale_rad_s!r}")
        for name in ("joy_invert_azimuth", "joy_invert_elevation"):
            if not isinstance(getattr(self, name), bool):
                raise ValueError(f"{name} must be a bool, got {getattr(self, name)!r}")

    @classmethod
    def from_values(cls, v: dict) -> OperatorCommandParams:
        """The shaper's parameters from a ``los_rate_controller`` node's values (its
        ``operator_*`` and ``joy_*``; ``joy_scale_rad_s`` 0 means the rate limit);
        :class:`ParameterError` names the node's parameter refused."""
        try:
            return cls(max_rate_deg_s=v["operator_max_rate_deg_s"], max_accel_deg_s2=v["operator_max_accel_deg_s2"],
                       timeout_s=v["operator_timeout_s"], joy_azimuth_axis=v["joy_azimuth_axis"],
                       joy_elevation_axis=v["joy_elevation_axis"],
                       joy_scale_rad_s=v["joy_scale_rad_s"] or None, joy_invert_azimuth=v["joy_invert_azimuth"],
                       joy_invert_elevation=v["joy_invert_elevation"])
        except ValueError as exc:
            text = str(exc)
            if text.startswith(("max_rate_deg_s", "max_accel_deg_s2", "timeout_s")):
                text = "operator_" + text
            raise ParameterError(f"parameter {text}") from exc


_NONFINITE = refused("non-finite rate")
_OVER_LIMIT = refused("rate above max_rate_deg_s")
_BAD_JOY = refused("joystick axes missing or outside [-1, 1]")


class OperatorCommand:
    """Rate- and acceleration-limited operator LOS rate command with a dead-man (module
    docstring). :meth:`check_rate` / :meth:`check_joy` per message, :meth:`step` per loop
    with the commands its step reached (the node's
    :class:`~gimbal_kinematics.timing.control_policy.CommandStamps`)."""

    def __init__(self, params: OperatorCommandParams | None = None) -> None:
        self.params = params if params is not None else OperatorCommandParams()
        p = self.params
        self.max_rate = math.radians(p.max_rate_deg_s)
        self.max_accel = math.radians(p.max_accel_deg_s2)
        self._rate_bound = self.max_rate * (1.0 + RATE_LIMIT_SLACK)
        self._timeout_ns = int(round(p.timeout_s * 1e9))
        scale = self.max_rate if p.joy_scale_rad_s is None else float(p.joy_scale_rad_s)
        self._joy_gain = (-scale if p.joy_invert_elevation else scale, -scale if p.joy_invert_azimuth else scale)
        self._joy_len = max(p.joy_azimuth_axis, p.joy_elevation_axis) + 1
        self.rejected_nonfinite = 0
        self.rejected_over_limit = 0
        self.rejected_joy = 0
        self.deadman_stops = 0
        self.resets = 0
        self.last_reset_reason = ""
        self._clear()

    def _clear(self) -> None:
        self._out = [0.0, 0.0]               # shaped (q, r) at the last step [rad/s]
        self._target = (0.0, 0.0)            # command in force at the last step [rad/s]
        self._cmd_ns: int | None = None      # stamp of the command in force (None: none)
        self._t_ns: int | None = None        # last step stamp
        self._stopping = False               # a dead-man lapse is ramping the output down
        self.last_stop_ns: int | None = None  # when the output reached zero after the last lapse

    def reset(self, reason: str = "") -> None:
        """Forget the output, the command in force and the last step (counters are kept)."""
        self._clear()
        if reason:
            self.resets += 1
            self.last_reset_reason = reason

    # ------------------------------------------------------------------ inputs
    @property
    def output(self) -> tuple[float, float]:
        """Shaped (q, r) [rad/s] at the last step."""
        return (self._out[0], self._out[1])

    @property
    def holding(self) -> bool:
        """No slew: the output and the command in force are zero (the controller holds; a
        command not yet reached by a step waits in the node's timing policy)."""
        return self._out[0] == 0.0 and self._out[1] == 0.0 and self._target == (0.0, 0.0)

    def check_rate(self, q: float, r: float) -> Fed:
        """A commanded LOS rate (q about m-y, r about m-z) [rad/s]: what it did, its
        ``output`` the rate (q, r) when usable (module docstring for the rejections)."""
        try:
            q, r = float(q), float(r)
        except (TypeError, ValueError):
            self.rejected_nonfinite += 1
            return _NONFINITE
        if not (math.isfinite(q) and math.isfinite(r)):
            self.rejected_nonfinite += 1
            return _NONFINITE
        if abs(q) > self._rate_bound or abs(r) > self._rate_bound:
            self.rejected_over_limit += 1
            return _OVER_LIMIT
        return Fed(True, output=(q, r))

    def check_joy(self, axes: Sequence[float]) -> Fed:
        """A ``sensor_msgs/Joy`` axes array: what it did, its ``output`` the rate (q, r)."""
        p = self.params
        try:
            el, az = float(axes[p.joy_elevation_axis]), float(axes[p.joy_azimuth_axis])
        except (TypeError, ValueError, IndexError):
            self.rejected_joy += 1
            return _BAD_JOY
        if not (math.isfinite(el) and math.isfinite(az)):
            self.rejected_nonfinite += 1
            return _NONFINITE
        if abs(el) > 1.0 + JOY_RANGE_SLACK or abs(az) > 1.0 + JOY_RANGE_SLACK:
            self.rejected_joy += 1
            return _BAD_JOY
        el, az = max(-1.0, min(1.0, el)), max(-1.0, min(1.0, az))
        return Fed(True, output=(self._joy_gain[0] * el, self._joy_gain[1] * az))

    # ------------------------------------------------------------------ step
    def step(self, released) -> tuple[float, float]:
        """Advance the shaped command to a step; returns (q, r) [rad/s]. ``released`` is what
        the node's :class:`~gimbal_kinematics.timing.control_policy.CommandStamps` hands over:
        the step stamp [ns], the commands it reached in stamp order and, after a clock jump,
        why to start over; None (a refused step stamp) keeps the output."""
        if released is None:
            return self.output
        if released.reset:
            self.reset(released.reset)
        t = released.stamp_ns
        s = t if self._t_ns is None else self._t_ns
        commands, i = released.commands, 0
        while True:
            deadline = None if self._cmd_ns is None else self._cmd_ns + self._timeout_ns
            nxt = commands[i][0] if i < len(commands) else None
            if deadline is not None and deadline <= t and (nxt is None or deadline < nxt):
                s = self._advance(s, deadline)
                self._lapse()
            elif nxt is not None:
                s = self._advance(s, nxt)
                self._cmd_ns, self._target = commands[i]
                i += 1
                self._stopping = False
            else:
                self._advance(s, t)
                break
        self._t_ns = t
        return self.output

    def _lapse(self) -> None:
        """Dead-man: the command in force timed out; the target becomes zero."""
        if self._target != (0.0, 0.0) or self._out != [0.0, 0.0]:
            self.deadman_stops += 1
            self._stopping = True
        self._cmd_ns = None
        self._target = (0.0, 0.0)

    def _advance(self, s: int, e: int) -> int:
        """Move the output towards the target over [s, e] (a late command's stamp before s
        takes effect at s); returns the new segment start."""
        if e <= s:
            return s
        dv = self.max_accel * (e - s) * 1e-9
        if self._stopping:
            need = max(abs(self._out[0]), abs(self._out[1]))
            if need <= dv:
                self.last_stop_ns = s + int(round(need / self.max_accel * 1e9))
                self._stopping = False
        for i in (0, 1):
            diff = self._target[i] - self._out[i]
            self._out[i] = self._target[i] if -dv <= diff <= dv else self._out[i] + (dv if diff > 0.0 else -dv)
        return e

    def counters(self) -> dict[str, int | str]:
        """Counters for /diagnostics (name -> value); the stamp counters are the node's
        timing policy's."""
        return {
            "rejected_nonfinite": self.rejected_nonfinite, "rejected_over_limit": self.rejected_over_limit,
            "rejected_joy": self.rejected_joy, "deadman_stops": self.deadman_stops, "resets": self.resets,
            "last_reset_reason": self.last_reset_reason,
        }


    def diagnostics(self, stamp_counters: dict[str, int]) -> dict[str, int | str]:
        """The operator's /diagnostics fields (``operator_*``, in :data:`DIAGNOSTICS` order):
        the node's command policy's counters (``stamp_counters``) and the shaper's."""
        both = {**stamp_counters, **self.counters()}
        return {f"operator_{k}": both[k] for k in DIAGNOSTICS}


#: The operator's counters on /diagnostics, in order: the node's CommandStamps' and the shaper's.
DIAGNOSTICS = ("commands_accepted", "rejected_nonfinite", "rejected_over_limit", "rejected_joy", "rejected_duplicate",
               "rejected_out_of_order", "rejected_stale", "rejected_future", "rejected_step_stamps", "deadman_stops",
               "resets", "last_reset_reason")
