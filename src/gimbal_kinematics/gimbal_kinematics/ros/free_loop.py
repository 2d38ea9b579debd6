"""Free timing's stale-input policy, and why (the controllers' input policy
:class:`gimbal_kinematics.control_policy.FreeControl` applies the same rule,
:class:`gimbal_kinematics.control_policy.StaleRule`; this class is its ROS-edge form for a
node that steps on a :class:`gimbal_kinematics.sync.FreshInputs` gate itself, publishing
through its :class:`~gimbal_kinematics.ros.node_io.NodeIo` and the one diagnostics builder,
:mod:`gimbal_kinematics.ros.diagnostics`).

A controller in ``timing: free`` steps on each sample of its driving gyro with the newest
other inputs (:class:`gimbal_kinematics.sync.FreshInputs`). This class holds that gate, the
counters of inputs that could not be used, the stale-input policy and ``/diagnostics``:

* a stale or missing measurement *zeroes* the command (zero torque or voltage lets the
  gimbal coast; a command computed from inputs that no longer hold can drive it into a
  stop, and the papers say nothing about lost inputs), counted in ``stale_commands``;
* a stale or missing *estimate* (``held``: another node's gyro-bias or attitude estimate)
  does not: the loop goes on with the last estimate it took (none yet: no correction, as
  the lockstep loop before the filter's first output), counted in ``stale_estimate_steps``.
  A bias changes over hours, so the last estimate is still the best correction, and the
  rate loop stays closed on the gyro; zeroing torque instead lets the gimbal follow the
  vehicle (an estimator starting a few samples late cost the real-time rehearsal over a
  degree of LOS in a tenth of a second);
* when the inputs are fresh again the loop restarts (the core reset: it was open), counted
  in ``restarts_after_stale``; a clock jump back (a bag looping) resets it too;
* every ``diagnostics_period_s`` of stamp time one DiagnosticStatus carries every counter
  (WARN while an input is stale: the command is zeroed).
"""
from __future__ import annotations

from typing import Any, Callable

from diagnostic_msgs.msg import DiagnosticArray

from gimbal_kinematics.control_policy import RESTART_FRESH, RESTART_JUMP, StaleRule
from gimbal_kinematics.sync import FreeStep, FreshInputs

from .diagnostics import health_msg

COUNTERS = ("stale_commands", "stale_estimate_steps", "restarts_after_stale", "malformed", "rejected_no_rates",
            "rejected_nonfinite", "rejected_joint_names")


class FreeLoop:
    """The free-timing state of one controller node (module docstring)."""

    def __init__(self, node: Any, io: Any, driver: str, max_age_s: dict[str, float], period_s: float,
                 backjump_s: float, diagnostics_period_s: float, held: tuple[str, ...] = ()) -> None:
        unknown = set(held) - set(max_age_s)
        if unknown:
            raise ValueError(f"held streams {sorted(unknown)} are not inputs")
        self.node = node
        self.io = io
        self.gate = FreshInputs(driver, {k: int(round(a * 1e9)) for k, a in max_age_s.items()},
                                int(round(period_s * 1e9)), int(round(backjump_s * 1e9)))
        self.counts = dict.fromkeys(COUNTERS, 0)
        self.rule = StaleRule(held, lambda text: node.get_logger().warning(text, throttle_duration_sec=1.0),
                              self.counts)
        self._diag_period_ns = int(round(diagnostics_period_s * 1e9))
        self._next_diag_ns: int | None = None
        self.pub_diag = io.advertise(DiagnosticArray, "/diagnostics", "free")

    def count(self, counter: str, text: str) -> None:
        """Count an input not used (or a command zeroed) and warn, at most once a second."""
        self.counts[counter] += 1
        self.node.get_logger().warning(f"{text} ({self.counts[counter]} {counter})", throttle_duration_sec=1.0)

    def seconds(self, stamp_ns: int) -> float:
        """A stamp as seconds after the first stamp seen [s]."""
        return (stamp_ns - self.gate.t0_ns) * 1e-9

    def fresh(self, step: FreeStep, reset: Callable[[str], None]) -> bool:
        """Whether the core may run on ``step``; False (counted): zero the command. Held
        streams that are stale are counted but do not stop it (module docstring)."""
        if step.restarted:
            reset(RESTART_JUMP)
        zero, resumed = self.rule.judge(step.stale)
        if resumed:
            reset(RESTART_FRESH)
        return not zero

    @property
    def was_stale(self) -> bool:
        """Whether the last step's command was zeroed."""
        return self.rule.was_stale

    def diagnostics(self, t_ns: int, extra: dict[str, int]) -> None:
        """Publish the counters (and the core's ``extra`` ones) when a period has passed."""
        if self._next_diag_ns is not None and t_ns < self._next_diag_ns:
            return
        self._next_diag_ns = t_ns + self._diag_period_ns
        counters = {**self.gate.counters(), **self.counts, "incompatible_qos": self.io.incompatible_qos, **extra}
        self.pub_diag.publish(health_msg(t_ns, self.node.get_name(), counters, stale=self.was_stale))
