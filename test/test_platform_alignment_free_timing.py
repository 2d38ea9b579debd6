"""platform_alignment in free timing (its default when started alone): epoch stamps near
1.8e9 s with ±30 % interval jitter, a duplicate and a late sample, the joint and the
accelerometer arriving in either order; the published alignment follows the independent
kinematic truth as in lockstep, and /diagnostics carries the counters and the NIS window."""
from __future__ import annotations

import math
from collections import defaultdict

import numpy as np
import rclpy
from geometry_msgs.msg import Vector3Stamped
from rclpy.context import Context
from rclpy.serialization import deserialize_message
import pytest

from gimbal_estimators.platform_alignment_node import OUTPUTS, PlatformAlignmentNode
from gimbal_estimators.rotation_alignment import RotationAlignmentParams
from gimbal_kinematics.maths.four_gimbal import BidirectionalRotation
from gimbal_kinematics.ros import messages as m
from kinematic_alignment import KinematicPlatformTruth
from ros_harness import ros_args

pytestmark = pytest.mark.ros
ARCSEC = math.radians(1.0 / 3600.0)
ARCMIN = math.radians(1.0 / 60.0)
DEG_H = ARCSEC
LAT_DEG = 40.0
EPOCH_NS = 1_800_000_000_000_000_000
PERIOD_NS = 100_000_000  # 10 Hz


def test_jittered_epoch_stamps_align_like_the_truth_and_bad_stamps_are_counted():
    lat = math.radians(LAT_DEG)
    g = RotationAlignmentParams(lat_deg=LAT_DEG).gravity
    eps_s = np.array([0.02, -0.03, 0.0]) * DEG_H
    bias = np.array([60e-6, -90e-6, 0.0]) * 9.80665
    truth = KinematicPlatformTruth(lat, np.array([-25.0, -36.0, 1020.0]) * ARCSEC, eps_s,
                                   rotation=BidirectionalRotation(), gravity=g)
    phi0 = truth.misalignment_enu()
    rng = np.random.default_rng(16)
    context = Context()
    rclpy.init(context=context)
    node = PlatformAlignmentNode(context=context, cli_args=ros_args({"lat_deg": LAT_DEG}),
                                 use_global_arguments=False)
    sent = defaultdict(list)
    try:
        assert node.policy.timing == "free"
        for name, pub in ((n, node.edge.pubs[f"~/{n}"]) for n in OUTPUTS):
            # serialized by the node (gimbal_estimators.wire): decoded by rclpy's own deserializer
            pub.publish = lambda data, out=sent[name]: out.append(deserialize_message(data, Vector3Stamped))
        node.edge.pubs["~/progress"].publish = lambda data: sent["progress"].append(m.clock_from_cdr(data))
        node.edge.pubs["/diagnostics"].publish = sent["diag"].append
        t_ns = EPOCH_NS
        for i in range(6001):
            if i:
                dt_ns = int(PERIOD_NS * (1.0 + rng.uniform(-0.3, 0.3)))
                truth.step(dt_ns * 1e-9)
                t_ns += dt_ns
            psi, rate = truth.psi_state(truth.t)
            joint = m.joint_state_msg(t_ns, ("platform_azimuth",), (psi,), (rate,))
            imu = m.imu_msg(t_ns, "platform_frd", linear_acceleration=tuple(truth.specific_force_s() + bias))
            # the middleware may deliver either first: stamp order puts the joint first
            first, second = (("imu", imu), ("joint", joint)) if i % 2 else (("joint", joint), ("imu", imu))
            node._on_input(*first)
            node._on_input(*second)
            if i == 1000:
                node._on_input("imu", imu)  # duplicate stamp
            if i == 2000:
                late = m.imu_msg(t_ns - 2 * PERIOD_NS, "platform_frd", linear_acceleration=(0.0, 0.0, -g))
                node._on_input("imu", late)  # stamp going backwards
        core = node.core
    finally:
        node.destroy_node()
        rclpy.shutdown(context=context)

    c = core.counters
    assert c.rejected_nonfinite == c.rejected_stale_joint == 0 and c.resets == 0
    # a block closes on the first sample at least block_s (1 s) after its start: ~1.05 s each
    assert 540 <= len(sent["status"]) <= 600 and all(len(sent[n]) == len(sent["status"]) for n in OUTPUTS)
    age, updates, converged = (sent["status"][-1].vector.x, sent["status"][-1].vector.y,
                               sent["status"][-1].vector.z)
    assert age == pytest.approx(truth.t, abs=1.0) and converged == 1.0
    assert m.stamp_ns(sent["status"][-1].header.stamp) > EPOCH_NS + 599 * 10**9  # absolute stamps out
    # the same accuracy as the lockstep test (test_platform_alignment_node.py)
    init = np.array([sent["initial_misalignment"][-1].vector.x, sent["initial_misalignment"][-1].vector.y,
                     sent["initial_misalignment"][-1].vector.z])
    expected = np.array([phi0[1], phi0[0], -phi0[2]])
    assert np.all(np.abs(init[:2] - expected[:2]) < 0.2 * ARCSEC), (init - expected) / ARCSEC
    assert abs(init[2] - expected[2]) < 0.25 * ARCMIN
    now = sent["misalignment"][-1].vector
    phi_t = truth.misalignment_enu()
    assert abs(now.x - phi_t[1]) < 0.3 * ARCSEC and abs(now.y - phi_t[0]) < 0.3 * ARCSEC
    drift = sent["gyro_drift"][-1].vector
    assert np.allclose([drift.x, drift.y], eps_s[:2], atol=1e-3 * DEG_H)
    d = {kv.key: kv.value for kv in sent["diag"][-1].status[0].values}
    assert int(d["imu_duplicates"]) == 1 and int(d["imu_out_of_order"]) == 1, d
    assert int(d["joint_duplicates"]) == 0 and int(d["imu_dropped"]) == 0, d
    assert 0.1 < float(d["imu_jitter_rms"]) < 0.25, d      # uniform ±30 %: RMS 0.17
    assert int(d["updates"]) == len(sent["status"]) and int(d["incompatible_qos"]) == 0, d
    assert int(d["nis_dof"]) == 2 and int(d["nis_window"]) == 50
    assert float(d["nis_lower_95"]) < 2.0 < float(d["nis_upper_95"])
    # noise-free accelerometers: the innovations are far below the assumed noise
    assert d["nis_verdict"] == "conservative", d
    # progress: the newest accelerometer stamp, absolute, every progress_every_steps samples
    assert all(p > EPOCH_NS for p in sent["progress"])
