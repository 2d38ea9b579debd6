"""The live view's frames and scene, built without ROS from messages serialised by rosbags:
the four-gimbal chain against ``four_gimbal.dcm_bs`` (closed form) and scipy's composition, the
alignment's estimate against ``platform_misalignment_enu`` (what the alignment report uses),
the geo target against pymap3d's direction, the operator's target against ``sight_error``
round trip, the LOS drift against closed forms (a turned LOS; one held in inertial space while
the earth turns), the ±3σ bounds, and the shipped Foxglove layout's panels and JSON fields
(its ROS topics against a real run's: test_live_view.py).
"""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pymap3d as pm
import pytest
import yaml
from scipy.spatial.transform import Rotation

from foreign_bags import EPOCH_NS, TYPESTORE, T, header, imu_cdr, joint_state_cdr
from gimbal_kinematics.maths.four_gimbal import dcm_bs, platform_misalignment_enu
from gimbal_kinematics.maths.frames import PLATFORM_JOINTS
from gimbal_sim.bag.live_frames import LiveFrames
from gimbal_sim.bag.live_plots import SCHEMAS as PLOT_SCHEMAS, LivePlots
from gimbal_sim.bag.live_scene import LOS_LENGTH_M, LiveScene, SceneConfig, operator_target_direction
from gimbal_sim.graph.live_scene import write_scene
from gimbal_sim.graph.scenario import builtin_scenarios, load
from gimbal_sim.world.operator_model import sight_error

REPO = Path(__file__).resolve().parents[1]
LAYOUT = REPO / "docs" / "foxglove" / "gimbal_live.json"
CHAIN = [("base_link_frd", "platform_outer_roll_frd", "x", "platform_outer_roll"),
         ("platform_outer_roll_frd", "platform_pitch_frd", "y", "platform_pitch"),
         ("platform_pitch_frd", "platform_inner_roll_frd", "x", "platform_inner_roll"),
         ("platform_inner_roll_frd", "platform_frd", "z", "platform_azimuth")]


def _vector3_cdr(t_ns: int, v) -> bytes:
    msg = T["geometry_msgs/msg/Vector3Stamped"](header=header(t_ns, "map_ned"),
                                                 vector=T["geometry_msgs/msg/Vector3"](x=v[0], y=v[1], z=v[2]))
    return bytes(TYPESTORE.serialize_cdr(msg, "geometry_msgs/msg/Vector3Stamped"))


def _rotations(message: bytes) -> dict[tuple[str, str], Rotation]:
    out = {}
    for tf in json.loads(message)["transforms"]:
        assert tf["translation"] == {"x": 0.0, "y": 0.0, "z": 0.0}
        r = tf["rotation"]
        out[(tf["parent_frame_id"], tf["child_frame_id"])] = Rotation.from_quat([r["x"], r["y"], r["z"], r["w"]])
    return out


def test_four_gimbal_chain_composes_to_the_platform_attitude():
    rng = np.random.default_rng(26)
    frames = LiveFrames()
    for _ in range(5):
        angles = rng.uniform(-1.2, 1.2, 4)  # (a, q, p, r)
        joints = frames.transforms("/truth/platform/joint_states",
                                   joint_state_cdr(EPOCH_NS, list(PLATFORM_JOINTS), angles, np.zeros(4)), EPOCH_NS)
        tfs = _rotations(joints)
        assert len(tfs) == 4
        by_joint = dict(zip(PLATFORM_JOINTS, angles))
        for parent, child, axis, joint in CHAIN:
            assert (tfs[(parent, child)].inv() * Rotation.from_euler(axis, by_joint[joint])).magnitude() < 1e-12
        C_nb = Rotation.from_euler("ZYX", rng.uniform(-0.5, 0.5, 3))
        host = frames.transforms("/truth/host/imu", imu_cdr(EPOCH_NS, [0.0] * 3, tuple(C_nb.as_quat())), EPOCH_NS)
        composed = _rotations(host)[("map_ned", "base_link_frd")]
        for parent, child, _, _ in CHAIN:
            composed = composed * tfs[(parent, child)]
        assert np.allclose(composed.as_matrix(), C_nb.as_matrix() @ dcm_bs(angles), atol=1e-12)


def test_alignment_estimate_is_the_believed_frame_turned_by_the_misalignment():
    heading = math.radians(-0.3)
    frames = LiveFrames(platform_heading_rad=heading)
    phi = np.array([2e-5, -3e-5, 4e-3])  # NED, believed -> true
    assert frames.transforms("/platform_alignment/misalignment", _vector3_cdr(EPOCH_NS, phi), EPOCH_NS) is None
    theta_a, rate, dt = 0.7, math.radians(1.2), 0.015
    frames.transforms("/truth/platform/joint_states",
                      joint_state_cdr(EPOCH_NS, list(PLATFORM_JOINTS), [theta_a, 0.0, 0.0, 0.0], [rate, 0, 0, 0]),
                      EPOCH_NS)
    later = EPOCH_NS + int(dt * 1e9)
    (estimate,) = _rotations(frames.transforms("/platform_alignment/misalignment", _vector3_cdr(later, phi),
                                               later)).items()
    assert estimate[0] == ("map_ned", "alignment/platform_frd")
    psi = theta_a + rate * dt + heading
    enu = platform_misalignment_enu(estimate[1].as_matrix(), psi)
    assert np.allclose(enu, [phi[1], phi[0], -phi[2]], atol=1e-12)


def test_geo_target_drawn_on_its_direction_with_its_range(tmp_path):
    spec = yaml.safe_load(builtin_scenarios()["sighting_geo_pointing"].read_text())
    (tmp_path / "scenario.yaml").write_text(yaml.safe_dump(spec))
    write_scene(load(str(tmp_path / "scenario.yaml")), tmp_path)  # as a run writes it beside its bag
    config, _ = SceneConfig.beside(tmp_path)
    geo = spec["nodes"]["geo_pointer"]["params"]
    (lat, lon, h), (tlat, tlon, th) = geo["vehicle_llh_deg"], geo["target_llh_deg"]
    n, e, d = pm.geodetic2ned(tlat, tlon, th, lat, lon, h)
    assert np.allclose(config.target_n, [n, e, d], atol=1e-6)
    update = json.loads(LiveScene(config).update("/truth/gimbal/joint_states", b"", EPOCH_NS))
    los, target = update["entities"]
    assert los["frame_id"] == "gimbal_inner_frd" and los["frame_locked"] and los["arrows"]
    assert target["frame_id"] == "map_ned" and not target["frame_locked"]
    (sphere,) = target["spheres"]
    p = sphere["pose"]["position"]
    rng = math.sqrt(n * n + e * e + d * d)
    assert np.allclose([p["x"], p["y"], p["z"]], LOS_LENGTH_M * np.array([n, e, d]) / rng, atol=1e-9)
    assert target["lines"][0]["points"][1] == pytest.approx({"x": n, "y": e, "z": d}, abs=1e-6)
    assert f"{rng / 1000:.2f} km" in target["texts"][0]["text"]
    # no target in the scenario: the LOS alone; no scene description: the defaults
    assert len(json.loads(LiveScene().update("/truth/gimbal/joint_states", b"", EPOCH_NS))["entities"]) == 1
    assert SceneConfig.beside(tmp_path / "missing")[0] == SceneConfig()


def test_operator_target_is_where_the_pointing_error_says():
    rng = np.random.default_rng(7)
    for _ in range(20):
        u = np.array([1.0, *rng.normal(0.0, 0.05, 2)])
        eps, e_q, e_r = sight_error(np.eye(3), u)
        assert np.allclose(operator_target_direction(eps, e_q, e_r), u / np.linalg.norm(u), atol=1e-12)
    assert operator_target_direction(float("nan"), float("nan"), float("nan")) is None
    update = json.loads(LiveScene().update("/operator/pointing_error", _vector3_cdr(EPOCH_NS, [0.01, 0.006, -0.008]),
                                           EPOCH_NS))
    (target,) = update["entities"]
    assert target["frame_id"] == "gimbal_inner_frd" and target["frame_locked"]
    p = target["spheres"][0]["pose"]["position"]
    assert sight_error(np.eye(3), [p["x"], p["y"], p["z"]]) == pytest.approx((0.01, 0.006, -0.008), abs=1e-12)


def _imu_at(t_ns: int, az: float, el: float) -> bytes:
    """A true gimbal attitude whose LOS (m-x) has azimuth ``az`` and elevation ``el`` in NED."""
    return imu_cdr(t_ns, [0.0] * 3, tuple(Rotation.from_euler("ZYX", [az, el, 0.2]).as_quat()))


def test_los_drift_is_the_change_of_the_inertial_los():
    plots = LivePlots()  # NED taken as inertial
    az0, el0 = 0.6, 0.3
    plots.update("/truth/gimbal/imu", _imu_at(EPOCH_NS, az0, el0), EPOCH_NS)
    _, message = plots.update("/truth/gimbal/imu", _imu_at(EPOCH_NS + 10**9, az0 + 0.01, el0 - 0.02), EPOCH_NS + 10**9)
    drift = json.loads(message)
    assert drift["header"]["stamp"] == {"sec": (EPOCH_NS + 10**9) // 10**9, "nsec": EPOCH_NS % 10**9}
    assert drift["azimuth_deg"] == pytest.approx(math.degrees(0.01 * math.cos(el0)), rel=1e-9)
    assert drift["elevation_deg"] == pytest.approx(math.degrees(-0.02), rel=1e-9)
    # with the earth turning, a LOS held fixed in inertial space turns in NED and does not drift
    lat = math.radians(39.9)
    w_ie = 7.292115e-5 * np.array([math.cos(lat), 0.0, -math.sin(lat)])
    plots = LivePlots.at_site(lat, True)
    u0 = Rotation.from_euler("ZYX", [az0, el0, 0.0]).apply([1.0, 0.0, 0.0])
    for t in (0.0, 60.0, 120.0):
        u = Rotation.from_rotvec(-w_ie * t).apply(u0)  # the same inertial direction seen in n(t)
        t_ns = EPOCH_NS + int(t * 1e9)
        out = plots.update("/truth/gimbal/imu", _imu_at(t_ns, math.atan2(u[1], u[0]), math.asin(-u[2])), t_ns)
        drift = json.loads(out[1])
        assert abs(drift["azimuth_deg"]) < 1e-4 / 3600 and abs(drift["elevation_deg"]) < 1e-4 / 3600


def test_bias_bounds_are_the_estimate_plus_minus_three_sigma_of_one_stamp():
    plots = LivePlots()
    bias, sigma = [0.0, 1e-5, -2e-5], [0.0, 3e-6, 4e-6]
    assert plots.update("/gyro_bias_ekf/bias", _vector3_cdr(EPOCH_NS, bias), EPOCH_NS) is None
    assert plots.update("/gyro_bias_ekf/bias_sigma", _vector3_cdr(EPOCH_NS + 1, sigma), EPOCH_NS + 1) is None
    topic, message = plots.update("/gyro_bias_ekf/bias_sigma", _vector3_cdr(EPOCH_NS, sigma), EPOCH_NS)
    bounds = json.loads(message)
    assert topic == "/live/bias_bounds"
    for i, k in enumerate("xyz"):
        assert bounds["upper"][k] == pytest.approx(bias[i] + 3 * sigma[i], abs=1e-18)
        assert bounds["lower"][k] == pytest.approx(bias[i] - 3 * sigma[i], abs=1e-18)


def _panels(node) -> list[str]:
    return [node] if isinstance(node, str) else _panels(node["first"]) + _panels(node["second"])


def test_layout_opens_on_the_3d_view_the_drift_the_bounded_biases_and_the_diagnostics():
    layout = json.loads(LAYOUT.read_text())
    panels = _panels(layout["layout"])
    assert sorted(panels) == sorted(layout["configById"])  # every panel placed, every placed one configured
    assert {p.split("!")[0] for p in panels} == {"3D", "Plot", "DiagnosticSummary"}
    assert layout["configById"]["3D!chain"]["topics"]["/live/los"]["visible"]
    paths = {p["value"] for c in layout["configById"].values() for p in c.get("paths", [])}
    assert {"/live/los_drift.azimuth_deg", "/live/los_drift.elevation_deg"} <= paths
    for axis in "yz":
        assert {f"/gyro_bias_ekf/bias.vector.{axis}", f"/truth/gimbal/gyro_bias.vector.{axis}",
                f"/live/bias_bounds.upper.{axis}", f"/live/bias_bounds.lower.{axis}"} <= paths
    # the JSON channels' fields exist in their schemas
    for path in paths:
        topic, *fields = path.split(".")
        if topic in PLOT_SCHEMAS:
            node = json.loads(PLOT_SCHEMAS[topic][1])
            for field in fields:
                node = node["properties"][field]
            assert node["type"] == "number", path
