"""Acceptance, "bad input", for ``gyro_bias_ekf`` in free timing (its default).

The node runs in process; a plain rclpy publisher with the default QoS (reliable,
volatile) and messages built from sensor_msgs alone feeds it epoch-stamped data (1.8e9 s)
with each kind of bad input mixed in, each with a payload that would move the estimate
if it were fused:

* a NaN in a field (gimbal gyro q, INS orientation, an encoder angle);
* a gyro stamp going backwards, a duplicate gyro stamp (with a different payload);
* one gyro stamp 3 years ahead and one stamp of zero: single outliers, counted
  (``gyro_outliers``), never a clock jump: no reset, no samples counted as dropped;
* an Imu whose covariance[0] is -1 where a value is needed: the gimbal gyro's angular
  velocity without y/z variances, the INS orientation;
* a JointState without the gimbal's joint names.

Each is counted on /diagnostics (read from the DiagnosticArray keys) and none is fused: the
estimate the node publishes at every clean INS stamp equals that of an independent
:class:`GyroBiasEkf` core fed the clean samples only, the number of measurement updates is
the same, and the INS sample whose attitude is NaN gets the unchanged current estimate.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from ros_harness import harness_node, spin_until

pytestmark = pytest.mark.ros

EPOCH_NS = 1_800_000_000_000_000_000
GYRO_PERIOD_NS = 5_000_000          # 200 Hz
INS_EVERY = 4                       # 50 Hz
N_STEPS = 200                       # 1 s of data
JOINTS = ("turret_azimuth", "gimbal_azimuth", "gimbal_elevation")
W_IE = 7.292115e-5                  # rad/s
BIAS_RAD_S = math.radians(100.0 / 3600.0)
VAR = 1e-8
# step k -> the bad input replacing that step's sample (the clean one is not sent)
BAD_GYRO_NAN, BAD_INS_NAN, BAD_ENC_NAN = 60, 64, 70
BAD_GYRO_NO_RATES, BAD_INS_NO_ATTITUDE, BAD_ENC_NAMES = 80, 84, 90
# after step DUP_AFTER: a gyro at the same stamp and one BACK_STEPS earlier, both absurd
DUP_AFTER, BACK_STEPS = 100, 3
# after step k: one absurd gyro stamped at that time [ns] (3 years ahead, zero): an outlier
OUTLIERS = {110: EPOCH_NS + 3 * 365 * 86_400 * 10**9, 120: 0}


def _stamp(msg, t_ns: int) -> None:
    msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(t_ns, 10**9)


def _gyro(k: int, q: float = None, cov=None, stamp_ns: int | None = None):
    from sensor_msgs.msg import Imu

    msg = Imu()
    _stamp(msg, EPOCH_NS + k * GYRO_PERIOD_NS if stamp_ns is None else stamp_ns)
    msg.header.frame_id = "gimbal_inner_frd"
    msg.orientation_covariance[0] = -1.0
    msg.linear_acceleration_covariance[0] = -1.0
    msg.angular_velocity.y = BIAS_RAD_S if q is None else q
    msg.angular_velocity.z = BIAS_RAD_S - W_IE
    msg.angular_velocity_covariance = list(cov) if cov is not None else [1e6, 0, 0, 0, VAR, 0, 0, 0, VAR]
    return msg


def _encoders(k: int, names=JOINTS, angle: float = 0.0):
    from sensor_msgs.msg import JointState

    msg = JointState()
    _stamp(msg, EPOCH_NS + k * GYRO_PERIOD_NS)
    msg.name = list(names)
    msg.position = [0.0, angle, 0.0]
    msg.velocity = [0.0, 0.0, 0.0]
    return msg


def _ins(k: int, qx: float = 0.0, orientation_cov0: float = VAR):
    from sensor_msgs.msg import Imu

    msg = Imu()
    _stamp(msg, EPOCH_NS + k * GYRO_PERIOD_NS)
    msg.header.frame_id = "base_link_frd"
    msg.orientation.x, msg.orientation.w = qx, math.sqrt(1.0 - qx * qx) if math.isfinite(qx) else 1.0
    msg.orientation_covariance = [orientation_cov0, 0, 0, 0, VAR, 0, 0, 0, VAR]
    msg.angular_velocity.x = W_IE
    msg.angular_velocity_covariance = [VAR, 0, 0, 0, VAR, 0, 0, 0, VAR]
    msg.linear_acceleration_covariance[0] = -1.0
    return msg


def _schedule():
    """[(stream, message, clean)] in publication order; ``clean`` False for bad input."""
    out = []
    for k in range(N_STEPS):
        if k == BAD_ENC_NAN:
            out.append(("encoders", _encoders(k, angle=math.nan), False))
        elif k == BAD_ENC_NAMES:
            out.append(("encoders", _encoders(k, names=("joint_a", "joint_b", "joint_c"), angle=0.5), False))
        else:
            out.append(("encoders", _encoders(k), True))
        if k % INS_EVERY == 0:
            if k == BAD_INS_NAN:
                out.append(("ins", _ins(k, qx=math.nan), False))
            elif k == BAD_INS_NO_ATTITUDE:
                out.append(("ins", _ins(k, qx=0.3, orientation_cov0=-1.0), False))
            else:
                out.append(("ins", _ins(k), True))
        if k == BAD_GYRO_NAN:
            out.append(("gyro", _gyro(k, q=math.nan), False))
        elif k == BAD_GYRO_NO_RATES:
            out.append(("gyro", _gyro(k, q=1.0, cov=(-1.0, 0, 0, 0, 0, 0, 0, 0, 0)), False))
        else:
            out.append(("gyro", _gyro(k), True))
        if k == DUP_AFTER:
            out.append(("gyro", _gyro(k, q=1.0), False))                 # duplicate stamp
            out.append(("gyro", _gyro(k - BACK_STEPS, q=1.0), False))    # stamp going backwards
        if k in OUTLIERS:
            out.append(("gyro", _gyro(k, q=1.0, stamp_ns=OUTLIERS[k]), False))
    return out


def _reference(params, schedule) -> dict[int, np.ndarray]:
    """Bias estimates {INS stamp [ns]: (3,)} of a fresh core fed the clean samples only (the
    INS sample without attitude delivers its rates, as the core's API defines)."""
    from gimbal_estimators import messages as m
    from gimbal_estimators.gyro_bias_ekf import GyroBiasEkf
    from gimbal_estimators.gyro_bias_ekf_stamp import EkfInput
    from gimbal_kinematics.timing.sync import RateSync

    core = EkfInput(GyroBiasEkf(params), RateSync)
    t = lambda msg: (m.stamp_ns(msg.header.stamp) - EPOCH_NS) * 1e-9  # noqa: E731
    for stream, msg, clean in schedule:
        if stream == "ins" and msg.orientation_covariance[0] == -1.0:
            w = msg.angular_velocity
            core.on_ins(t(msg), None, (w.x, w.y, w.z))
        elif not clean:
            continue
        elif stream == "gyro":
            core.on_gyro(t(msg), msg.angular_velocity.y, msg.angular_velocity.z)
        elif stream == "encoders":
            core.on_encoders(t(msg), tuple(msg.position), tuple(msg.velocity))
        else:
            w = msg.angular_velocity
            core.on_ins(t(msg), (0.0, 0.0, 0.0), (w.x, w.y, w.z))  # identity quaternion: zero Euler angles
    outs = {EPOCH_NS + int(round(o.t * 1e9)): np.array(o.bias) for o in core.take_outputs()}
    return outs, core.counters


def test_bad_inputs_are_counted_on_diagnostics_and_never_fused(ros_domain_env):
    from diagnostic_msgs.msg import DiagnosticArray
    from geometry_msgs.msg import Vector3Stamped
    from rclpy.parameter import Parameter
    from sensor_msgs.msg import Imu, JointState

    from gimbal_estimators.gyro_bias_ekf_node import GyroBiasEkfNode

    schedule = _schedule()
    with harness_node(int(ros_domain_env["ROS_DOMAIN_ID"])) as (harness, executor):
        ekf = GyroBiasEkfNode(context=harness.context,
                              parameter_overrides=[Parameter("diagnostics_period_s", value=0.001),
                                                   Parameter("lat_deg", value=0.0),
                                                   Parameter("ins_error_states", value=False)])
        executor.add_node(ekf)
        try:
            assert ekf.policy.timing == "free", "free timing is the default outside gimbal-run"
            pubs = {"gyro": harness.create_publisher(Imu, "/gimbal/imu", 1000),
                    "encoders": harness.create_publisher(JointState, "/gimbal/joint_states", 1000),
                    "ins": harness.create_publisher(Imu, "/ins/imu", 1000)}
            bias: dict[int, np.ndarray] = {}
            diags: list[dict[str, str]] = []
            harness.create_subscription(Vector3Stamped, "/gyro_bias_ekf/bias", lambda msg: bias.__setitem__(
                msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec,
                np.array([msg.vector.x, msg.vector.y, msg.vector.z])), 1000)
            harness.create_subscription(DiagnosticArray, "/diagnostics", lambda msg: diags.extend(
                {kv.key: kv.value for kv in s.values} for s in msg.status if s.hardware_id == ekf.get_name()), 1000)
            assert spin_until(executor, lambda: all(p.get_subscription_count() > 0 for p in pubs.values())
                              and ekf.edge.pubs["~/bias"].get_subscription_count() > 0
                              and ekf.edge.pubs["/diagnostics"].get_subscription_count() > 0, 30.0)
            sent = {s: 0 for s in pubs}
            for stream, msg, _ in schedule:
                pubs[stream].publish(msg)
                sent[stream] += 1
                # one at a time, each seen by the node before the next (best effort on loopback)
                n = sent[stream]
                assert spin_until(executor, lambda: ekf.policy.stats[stream].received >= n, 10.0), (stream, n)
            last_ins = EPOCH_NS + (N_STEPS - INS_EVERY) * GYRO_PERIOD_NS
            assert spin_until(executor, lambda: last_ins in bias and diags
                              and int(diags[-1]["ins_received"]) == sent["ins"], 10.0), \
                (sorted(bias)[-3:], last_ins, diags[-1] if diags else None, ekf.policy.order.pending)
            params = ekf.core.params
            node_counters = ekf.core.counters
        finally:
            executor.remove_node(ekf)
            ekf.destroy_node()

    d = diags[-1]
    # each kind of bad input, counted under its /diagnostics key
    assert int(d["rejected_nonfinite"]) == 3, d           # gyro q, INS orientation, encoder angle
    assert int(d["gyro_duplicates"]) == 1 and int(d["gyro_out_of_order"]) == 1, d
    assert int(d["gyro_not_provided"]) == 1, d
    # the outlier stamps: counted as such, no clock jump, no reset, nothing counted as dropped
    assert int(d["gyro_outliers"]) == len(OUTLIERS), d
    assert int(d["gyro_clock_jumps"]) == 0 and int(d["resets"]) == 0 and node_counters.resets == 0, d
    assert int(d["gyro_dropped"]) == 0, d
    assert int(d["ins_attitude_not_provided"]) == 1, d
    assert int(d["joint_names_missing"]) == 1, d
    # (the last /diagnostics goes out with the last INS update, before the last few gyro samples)
    assert N_STEPS - INS_EVERY + 2 + len(OUTLIERS) <= int(d["gyro_received"]) <= N_STEPS + 2 + len(OUTLIERS), d
    assert int(d["ins_rates_not_provided"]) == 0 and int(d["incompatible_qos"]) == 0, d
    assert d["nis_verdict"] in ("insufficient", "consistent", "conservative", "overconfident"), d

    # none fused: the node's estimates are the clean-input core's, update for update
    ref, ref_counters = _reference(params, schedule)
    assert node_counters.updates == ref_counters.updates > 0
    assert node_counters.gated == ref_counters.gated == 0
    clean_ins = [EPOCH_NS + k * GYRO_PERIOD_NS for k in range(0, N_STEPS, INS_EVERY)
                 if k not in (BAD_INS_NAN, BAD_INS_NO_ATTITUDE)]
    assert set(clean_ins) <= set(ref)
    for t_ns in clean_ins:
        np.testing.assert_allclose(bias[t_ns], ref[t_ns], rtol=0.0, atol=1e-15, err_msg=str(t_ns))
    # the NaN INS sample is answered with the current estimate: one the clean-input core had
    # already produced before that stamp (the latest update it had completed), nothing new
    t_bad = EPOCH_NS + BAD_INS_NAN * GYRO_PERIOD_NS
    assert any(np.array_equal(bias[t_bad], v) for t, v in ref.items() if t < t_bad), bias[t_bad]
    # and the filter did learn something from the clean data (the test can fail)
    assert not np.allclose(ref[clean_ins[-1]], ref[clean_ins[1]], rtol=0.0, atol=1e-12)
