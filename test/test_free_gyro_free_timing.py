"""free_gyro_positioning in free timing (its default when started alone): epoch-stamped
read-outs (1.8e9 s, the spin-axis reference moved to that epoch) give the fixes the core
computes on the simulation's time axis from 0, a NaN read-out and a duplicate stamp are
counted on /diagnostics, and progress reports the newest stamp, not a step grid."""
from __future__ import annotations

import math

import pytest
import rclpy
from geometry_msgs.msg import Vector3Stamped
from sensor_msgs.msg import NavSatFix
from rclpy.context import Context
from rclpy.serialization import deserialize_message

from gimbal_estimators.free_gyro_positioning import FreeGyroPositioning, FreeGyroPositioningParams
from gimbal_estimators.free_gyro_positioning_params import PARAMS
from gimbal_estimators.free_gyro_positioning_node import IMU, SPIN_A, SPIN_B, FreeGyroPositioningNode
from gimbal_kinematics.ros import messages as m
from gimbal_kinematics.maths.rotations import euler321_from_quat, euler321_to_quat
from test_free_gyro_node import RATE, messages_of, node_params, readouts

pytestmark = pytest.mark.ros
EPOCH_NS = 1_800_000_000_000_000_000


def test_epoch_stamped_readouts_fix_like_the_core_and_bad_ones_are_counted():
    samples = readouts(31.0)
    params = [p for p in node_params(progress_every_steps=5) if p.name != "timing"]
    context = Context()
    rclpy.init(context=context)
    node = FreeGyroPositioningNode(context=context, parameter_overrides=params + [
        type(params[0])("spin_reference_time_s", value=EPOCH_NS * 1e-9)])
    out: dict[str, list] = {"fix": [], "heading": [], "progress": [], "diag": []}
    try:
        assert node.policy.timing == "free"
        # the node publishes serialized messages (gimbal_estimators.wire): decoded by rclpy's own deserializer
        node.edge.pubs["~/fix"].publish = lambda data: out["fix"].append(deserialize_message(data, NavSatFix))
        node.edge.pubs["~/heading"].publish = lambda data: out["heading"].append(deserialize_message(data, Vector3Stamped))
        node.edge.pubs["~/progress"].publish = lambda data: out["progress"].append(m.clock_from_cdr(data))
        node.edge.pubs["/diagnostics"].publish = out["diag"].append
        for k, s in enumerate(samples):
            a, b, imu = messages_of(s, EPOCH_NS + m.step_stamp_ns(k, RATE))
            if k == 57:
                a = m.vector3_msg(m.stamp_ns(a.header.stamp), "base_link_frd", (math.nan, 0.0, 1.0))
            node._on_input(SPIN_A, a)
            node._on_input(SPIN_B, b)
            node._on_input(IMU, imu)
            if k == 80:
                node._on_input(SPIN_B, b)  # the same read-out again: a duplicate stamp
    finally:
        node.destroy_node()
        rclpy.shutdown(context=context)

    # the core on the simulation's time axis: same spin axes, referred to t = 0
    values = {p.name: p.default for p in PARAMS}
    values.update({p.name: p.value for p in params})
    core = FreeGyroPositioning(FreeGyroPositioningParams.from_values(values))
    fixes = []
    for k, s in enumerate(samples):
        t = m.step_stamp_ns(k, RATE) * 1e-9
        roll, pitch, _ = euler321_from_quat(euler321_to_quat(s.roll, s.pitch, 0.0))
        core.on_level(t, roll, pitch)
        core.on_body_rates(t, s.omega_ib_b)
        fix = core.on_spin_axes(t, (math.nan, 0.0, 1.0) if k == 57 else s.spin_a_b, s.spin_b_b).output
        if fix is not None:
            fixes.append(fix)
    assert len(fixes) == len(out["fix"]) == 3
    for fix, nav, hd in zip(fixes, out["fix"], out["heading"]):
        # the window's mean time [s] near 1.8e9 s: float resolution 2.4e-7 s
        assert abs(m.stamp_ns(nav.header.stamp) - EPOCH_NS - round(fix.t * 1e9)) <= 500
        # same position to 1e-8 deg (1 mm; the fix's own σ is ~100 m): the earth angle at
        # 1.8e9 s differs only by float rounding (~2e-11 rad, measured 1.4e-9 deg in longitude)
        assert nav.latitude == pytest.approx(math.degrees(fix.lat), abs=1e-8)
        assert nav.longitude == pytest.approx(math.degrees(fix.lon), abs=1e-8)
        assert hd.vector.x == pytest.approx(fix.heading, abs=1e-9)
    d = {kv.key: kv.value for kv in out["diag"][-1].status[0].values}
    assert int(d["rejected_nonfinite"]) == 1 and int(d["rejected_stamps"]) == 1, d
    assert int(d["fixes"]) == 3 and int(d["incompatible_qos"]) == 0, d
    # progress: the newest read-out's absolute stamp every 5 read-outs, never a grid step
    stamps = out["progress"]
    assert stamps[0] == EPOCH_NS + m.step_stamp_ns(4, RATE) and len(stamps) == len(samples) // 5
