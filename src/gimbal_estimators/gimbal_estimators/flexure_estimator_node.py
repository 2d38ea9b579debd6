"""``flexure_estimator`` node: paper 5's ship angular-flexure Kalman filter on the two LGUs,
by the attitude-matching method of parameter ``model`` (chosen once, in the constructor):
``simplified`` (the default, paper 5 eq. 5: :class:`~gimbal_estimators.flexure_kf.FlexureKf`)
or ``original`` (paper 5 eq. 1: :class:`~gimbal_estimators.flexure_attitude_matching.AttitudeMatchingKf`,
with the per-unit bias parameters ``lgu_bias_*``). Both take the same messages and publish
the same outputs.

Inputs: ``/ship/lgu1/imu`` and ``/ship/lgu2/imu`` (sensor_msgs/Imu whose
``angular_velocity`` is the incremental angle over the sample divided by the sample
interval Δt = 1/``lgu_rate_hz``). Outputs, all geometry_msgs/Vector3Stamped in LGU1 axes
(roll, pitch, yaw), stamped with the LGU sample that completed the filter step, on private
topics so that several instances (one per quasi-static model) run side by side:

* ``~/flexure``, ``~/flexure_sigma``: total flexure Φ + θ and its 1σ [rad];
* ``~/quasi_static``, ``~/quasi_static_sigma``: Φ and its 1σ [rad];
* ``~/dynamic``, ``~/dynamic_sigma``: θ and its 1σ [rad];
* ``~/bias_diff``, ``~/bias_diff_sigma``: ε1 − ε2 and its 1σ [rad/s];
* ``~/progress`` (rosgraph_msgs/Clock): the time of the next LGU sample the node needs,
  for the vehicle's pacing (the node must see every sample, see below).

Bad input is never fused. The core rejects and counts non-finite or malformed samples,
out-of-order and duplicate stamps; a chi-square gate keeps outliers out; a backward clock
jump (a bag looping) resets it. A lost sample (a gap in either unit's stream, or one
unit's sample without its partner) loses that interval's rotation in the integrated
attitudes, so the filter does not fuse across it: it re-anchors both attitudes at the next
complete pair (θ_d := Φ + θ, covariance carried over) and the node logs it; a gap longer
than ``max_gap_s`` resets. Every reset is logged with its reason.

Timing (parameter ``timing``, :mod:`gimbal_kinematics.ros.node_io`), chosen once in the
constructor as the input policy (:func:`gimbal_kinematics.timing.input_policy.sample_policy`); the
node's body is the same in both:

* ``lockstep`` (what ``gimbal-run`` sets): ``GRAPH_QOS`` everywhere, each sample's interval
  is 1/``lgu_rate_hz``, ``~/progress`` reports the next lockstep step needed, no
  /diagnostics (byte-identical bags).
* ``free`` (the default when started alone): SensorDataQoS inputs, default-QoS outputs; the
  node never waits on a step grid, ``/clock`` or a progress topic. Stamps are kept as
  integer nanoseconds and the core runs on seconds relative to the first stamp seen (a
  float64 near 1.8e9 s resolves only 2.4e-7 s, and the two units pair on equal stamps).
  Each sample's interval Δt is its stamp minus its unit's previous accepted stamp, when
  that is at most 1.5 nominal periods (1/``lgu_rate_hz``, so ±30 % jitter is followed);
  the first sample (and the first after a backward clock jump, which resets) takes the
  nominal period. After a longer gap (a lost sample) the next sample's own interval is
  unknown (its rate is Δα over an interval that ended at the lost sample's stamp or later),
  so it is not integrated: it is counted (``lgu1_interval_unknown``, ``lgu2_interval_unknown``)
  and the core, seeing the hole, drops its partner and re-anchors at the next complete pair.
  Each unit's stamps go through :class:`gimbal_kinematics.timing.stream_stats.StreamStats`
  (received, duplicates, out_of_order, clock_jumps, dropped, jitter_rms, counted on
  /diagnostics as ``lgu1_*``, ``lgu2_*``); duplicates and late samples are dropped
  before the core. /diagnostics (every ``diagnostics_period_s`` of stamp time) carries
  the core's counters, those input counters, ``incompatible_qos`` and the NIS window
  (``nis_*``, 3 dof per measurement update, :class:`.nis.NisWindow`). ``~/progress``
  still reports the older unit's newest stamp every ``progress_every_steps`` samples.
"""
from __future__ import annotations

import sys

from geometry_msgs.msg import Vector3Stamped
from rclpy.node import Node
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import Imu

from gimbal_kinematics.params.table import ParameterError, steps_per_sample
from gimbal_kinematics.ros.node_edge import NodeEdge, input_warnings
from gimbal_kinematics.ros.node_main import run_node
from gimbal_kinematics.ros.params import declare_and_read
from gimbal_kinematics.ros.readiness import announce_when_connected
from gimbal_kinematics.timing.input_policy import Step, sample_policy
from gimbal_kinematics.timing.sync import StampPairs

from . import messages as m
from .flexure_attitude_matching import AttitudeMatchingKf, AttitudeMatchingParams
from .flexure_estimator_params import DESCRIPTION, PARAMS
from .flexure_kf import FlexureEstimate, FlexureKf, FlexureKfParams
from .nis import NisWindow
from .wire import FLEXURE_OUTPUTS as OUTPUTS, flexure_messages  # noqa: F401  (OUTPUTS: the output stems)

#: The two input streams (LGU1, LGU2).
UNITS = ("lgu1", "lgu2")
#: Counters whose increase means a sample was rejected, with the log text.
_REJECTIONS = {"nonfinite": "non-finite value", "malformed": "malformed (rates not provided or > 1 rad)",
               "bad_dt": "interval inconsistent with lgu_rate_hz or its partner",
               "out_of_order": "stamp not after the last fused pair", "duplicates": "duplicate stamp"}
#: Counters whose non-zero value is a WARN on /diagnostics.
WARN_COUNTERS = ("gated", "nonfinite", "malformed", "bad_dt", "out_of_order", "duplicates", "resets",
                 *input_warnings(*UNITS))


class FlexureEstimatorNode(Node):
    def __init__(self, **node_kwargs) -> None:
        super().__init__("flexure_estimator", **node_kwargs)
        values = declare_and_read(self, PARAMS)
        steps_per_sample(values, "lgu_rate_hz")  # refuses a rate that does not divide sim_rate_hz
        if values["filter_period_s"] * values["lgu_rate_hz"] < 1.0 - 1e-9:
            raise ParameterError(f"parameter 'filter_period_s' = {values['filter_period_s']} s is shorter than one "
                                 f"LGU sample (1/lgu_rate_hz = {1.0 / values['lgu_rate_hz']:g} s)")
        # the attitude-matching method: paper 5's simplified filter or the original (eq. 1)
        self.core = (AttitudeMatchingKf(AttitudeMatchingParams.from_values(values)) if values["model"] == "original"
                     else FlexureKf(FlexureKfParams.from_values(values)))
        self.pairs = StampPairs.feeding(self.core)  # the two units' samples, paired by stamp
        self.edge = edge = NodeEdge(self, values)
        # the one choice of timing (module docstring)
        self.policy = sample_policy(values["timing"], UNITS, rate_hz=values["sim_rate_hz"],
                                    sample_rate_hz=values["lgu_rate_hz"], progress_every=values["progress_every_steps"],
                                    clock_jump_ns=int(round(values["clock_jump_s"] * 1e9)), warn=edge.warn,
                                    on_restart=self._restart)
        self.publish_period_ns = int(round(values["publish_period_s"] * 1e9))
        self._last_bin: int | None = None
        self.nis = NisWindow(3, window=values["nis_window"])
        outputs = [f"~/{topic}" for name in OUTPUTS for topic in (name, f"{name}_sigma")]
        edge.advertise_all([(Vector3Stamped, topic) for topic in outputs] + [(Clock, "~/progress")])
        edge.advertise_diagnostics(self.policy)
        self.subs = [edge.subscribe(Imu, f"/ship/lgu{u + 1}/imu", lambda msg, u=u: self._on_lgu(u, msg))
                     for u in (0, 1)]
        # ready once both LGU streams have a publisher and every output its readers
        announce_when_connected(self, edge.pubs["~/progress"], self.subs, [edge.pubs[t] for t in outputs],
                                values["wait_for_subscribers"])

    # ------------------------------------------------------------------ input
    def _restart(self, reason: str) -> None:
        """A clock jump back (the input policy's verdict): the filter starts over."""
        self.core.reset(reason)
        self.get_logger().warning(f"filter reset: {reason} ({self.core.counters['resets']} resets)")

    def _on_lgu(self, unit: int, msg: Imu) -> None:
        for step in self.policy.add(UNITS[unit], m.stamp_ns(msg.header.stamp), msg):
            self._step(unit, step)

    def _step(self, unit: int, step: Step) -> None:
        dalpha = m.lgu_increment(step.msg, step.dt)
        # rates marked not provided go in as an empty increment, which the core counts as malformed
        est = self.pairs.add(unit, step.t, () if dalpha is None else dalpha, step.dt)
        self._log_events(unit, step.stamp_ns)
        if est is not None:
            if not (est.d2 != est.d2):  # an update (accepted or gated); NaN: no innovation
                self.nis.add(est.d2)
            self._publish(step.stamp_ns, est)
        self.edge.progress(self.policy.progress(step))

    def counts(self) -> dict[str, int]:
        """The filter's counters and the pairing's."""
        return {**self.core.counters, **self.pairs.counts}

    def _log_events(self, unit: int, t_ns: int) -> None:
        """What the last sample did (the filter's events, the pairing's refusal), logged."""
        c, warn, t = self.counts(), self.edge.warn, t_ns * 1e-9
        done = {*self.core.events, self.pairs.refused}
        for key, text in _REJECTIONS.items():
            if key in done:
                warn(f"LGU{unit + 1} sample at {t:.3f} s rejected: {text} ({c[key]} so far)")
        if "resets" in done:
            self.get_logger().warning(f"filter reset at {t:.3f} s: {self.core.last_reset_reason} "
                                      f"({c['resets']} resets)")  # every one: not throttled
        elif "reanchors" in done:
            cause = "lost LGU sample(s)" if "gaps" in done else "gated measurements in a row"
            warn(f"{cause} before {t:.3f} s: attitudes re-anchored there (theta_d := Phi + theta, covariance kept; "
                 f"{c['gaps']} gaps, {c['unpaired']} unpaired samples dropped, {c['reanchors']} re-anchors)")
        if "gated" in done:
            warn(f"measurement at {t:.3f} s beyond the chi-square gate, not fused ({c['gated']} gated)")

    # ------------------------------------------------------------------ output
    def _publish(self, t_ns: int, est: FlexureEstimate) -> None:
        if self.publish_period_ns > 0:
            b = t_ns // self.publish_period_ns
            if b == self._last_bin:
                return
            self._last_bin = b
        # serialized by gimbal_estimators.wire (the engine writes the same bytes into its bag)
        self.edge.publish(flexure_messages(t_ns, est))
        self.edge.diagnostics(t_ns, lambda: self.edge.health(t_ns, self.policy, self.counts(), self.nis,
                                                            ready=self.core.initialized, not_ready="no estimate yet",
                                                            warn=WARN_COUNTERS))


def main(argv: list[str] | None = None) -> int:
    return run_node(FlexureEstimatorNode, "flexure_estimator", DESCRIPTION, argv)


if __name__ == "__main__":
    sys.exit(main())
