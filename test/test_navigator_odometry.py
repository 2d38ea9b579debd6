"""``platform_navigator``'s ``~/odom`` (nav_msgs/Odometry, REP 105) from a recorded run.

A short ``rotational_ins_navigation`` run through the node graph (container mode), with a
base heading and an accelerometer-bias estimate that make the navigator move off the start
fix and turn its child frame away from the ENU axes. The bag is read with ``rosbags``; each
Odometry is checked against the NavSatFix and NED velocity of the same stamp, converted with
``pymap3d`` (``geodetic2enu`` about the first fix; NED → ENU, then into the child frame
through the message's own quaternion): 1 mm and 1 mm/s. Frames and covariance as documented.
"""
from __future__ import annotations

import math
import subprocess

import numpy as np
import pymap3d
import pytest
from rosbags.highlevel import AnyReader

from conftest import VENV_BIN

pytestmark = pytest.mark.ros

NAV_S = 8.0
HEADING_DEG = 30.0
FIX = "/platform_navigator/fix"
VELOCITY = "/platform_navigator/velocity"
ODOM = "/platform_navigator/odom"


@pytest.fixture(scope="module")
def recorded(module_ros_domain_env, tmp_path_factory):
    out = tmp_path_factory.mktemp("odom") / "run"
    result = subprocess.run(
        [str(VENV_BIN / "gimbal-run"), "rotational_ins_navigation", "--variant", "rotation_on",
         "--duration", str(NAV_S), "--out", str(out), "--mode", "container", "--no-progress",
         "--set", "platform_navigator.fix_every_samples=5",
         "--set", f"platform_navigator.base_heading_deg={HEADING_DEG}",
         "--set", "platform_navigator.accel_bias_ug=[20000.0, -15000.0, 0.0]"],
        env=module_ros_domain_env, capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stdout + result.stderr
    bag = out / "rotation_on" if (out / "rotation_on").is_dir() else out
    got: dict[str, list] = {FIX: [], VELOCITY: [], ODOM: []}
    with AnyReader([bag]) as reader:
        conns = [c for c in reader.connections if c.topic in got]
        assert {c.topic for c in conns} == set(got)
        assert {c.msgtype for c in conns if c.topic == ODOM} == {"nav_msgs/msg/Odometry"}
        for conn, _, raw in reader.messages(connections=conns):
            got[conn.topic].append(reader.deserialize(raw, conn.msgtype))
    return got


def _ns(stamp) -> int:
    return stamp.sec * 1_000_000_000 + stamp.nanosec


def _rotate(q, v) -> np.ndarray:
    """v rotated by the unit quaternion q = (x, y, z, w): child axes -> parent axes."""
    x, y, z, w = q
    u = np.array([x, y, z])
    v = np.asarray(v, dtype=float)
    return v + 2.0 * np.cross(u, np.cross(u, v) + w * v)


def test_odometry_matches_the_fix_and_velocity_through_pymap3d(recorded):
    fixes, vels, odoms = recorded[FIX], recorded[VELOCITY], recorded[ODOM]
    assert len(odoms) == len(fixes) == len(vels) >= NAV_S * 50 / 5
    origin = fixes[0]
    worst_pos = worst_vel = 0.0
    moved = 0.0
    for fix, vel, odom in zip(fixes, vels, odoms):
        assert _ns(odom.header.stamp) == _ns(fix.header.stamp) == _ns(vel.header.stamp)
        e, n, u = pymap3d.geodetic2enu(fix.latitude, fix.longitude, fix.altitude,
                                       origin.latitude, origin.longitude, origin.altitude)
        p = odom.pose.pose.position
        worst_pos = max(worst_pos, abs(p.x - e), abs(p.y - n), abs(p.z - u))
        moved = max(moved, math.hypot(e, n))
        q = odom.pose.pose.orientation
        v_enu = np.array([vel.vector.y, vel.vector.x, -vel.vector.z])  # NED -> ENU
        lin = odom.twist.twist.linear
        worst_vel = max(worst_vel, float(np.max(np.abs(_rotate((q.x, q.y, q.z, q.w), (lin.x, lin.y, lin.z))
                                                       - v_enu))))
    assert moved > 1.0  # the bias estimate moved it metres off the start: a real conversion
    assert worst_pos < 1e-3 and worst_vel < 1e-3, (worst_pos, worst_vel)


def test_frames_orientation_and_covariance_follow_rep_105(recorded):
    odoms = recorded[ODOM]
    first, last = odoms[0], odoms[-1]
    assert first.header.frame_id == "odom" and first.child_frame_id == "base_link"
    p = first.pose.pose.position
    assert (p.x, p.y, p.z) == (0.0, 0.0, 0.0)  # the origin is the start fix
    q = first.pose.pose.orientation
    # a level base heading 30 deg east of north: its forward axis points there in ENU
    forward = _rotate((q.x, q.y, q.z, q.w), (1.0, 0.0, 0.0))
    h = math.radians(HEADING_DEG)
    assert np.allclose(forward, (math.sin(h), math.cos(h), 0.0), atol=1e-12)
    cov0, cov1 = np.reshape(first.pose.covariance, (6, 6)), np.reshape(last.pose.covariance, (6, 6))
    assert np.count_nonzero(cov1 - np.diag(np.diag(cov1))) == 0
    # horizontal sigma grows at the CEP rate: 0.38 n mile/h CEP50 = 1.1774 sigma per axis
    t = (_ns(last.header.stamp) - _ns(first.header.stamp)) * 1e-9
    sigma = 0.38 * 1852.0 / 3600.0 * t / math.sqrt(2.0 * math.log(2.0))
    assert cov0[0, 0] == 0.0 and cov1[0, 0] == pytest.approx(sigma**2, rel=1e-9) == cov1[1, 1]
    assert cov1[5, 5] == pytest.approx(math.radians(1.0 / 60.0) ** 2)
    twist = np.reshape(last.twist.covariance, (6, 6))
    assert np.allclose(np.diag(twist), [0.36, 0.36, 0.36, 1e6, 1e6, 1e6])
