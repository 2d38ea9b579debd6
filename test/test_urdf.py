"""The URDFs of the two-axis gimbal and of paper 3's four-gimbal platform against the models.

Parsed with ``xml.etree`` (URDF's own schema: links, joints, inertials, limits, and the
``ros2_control`` tag topic_based_ros2_control reads). The kinematics are checked by forward
kinematics written here with ``scipy.spatial.transform.Rotation`` (each joint turns its child
by +angle about its axis, URDF's rule), against the models' own direction cosine matrices
(``sighting_chain.dcm_bt/ta/am``, ``four_gimbal.dcm_bs``) at random angles; the names against
``frames``; the mass properties and limits against ``GimbalParams`` (preset paper1) and the
platform's DC-motor loops (paper 3 Table 1).
"""
from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from gimbal_kinematics.maths import four_gimbal, sighting_chain
from gimbal_kinematics.maths.frames import (
    BASE_FRAME, GIMBAL_COMMAND_JOINTS, GIMBAL_ENCODER_JOINTS, GIMBAL_FRAME, PLATFORM_FRAME, PLATFORM_JOINTS,
)
from gimbal_kinematics.gimbal.gimbal_params import GIMBAL_MODELS
from gimbal_sim.world.plant.platform_loops import paper3_axis_params

URDF = Path(__file__).resolve().parents[1] / "src" / "gimbal_kinematics" / "urdf"
PLATFORM_AXES = dict(zip(PLATFORM_JOINTS, "aqpr"))


def _load(name: str) -> ET.Element:
    return ET.parse(URDF / name).getroot()


def _floats(text: str) -> np.ndarray:
    return np.array([float(v) for v in text.split()])


def _chain(robot: ET.Element) -> list[ET.Element]:
    """The joints from the root link outwards (a serial chain)."""
    joints = {j.find("parent").get("link"): j for j in robot.findall("joint")}
    children = {j.find("child").get("link") for j in robot.findall("joint")}
    (root,) = [lk.get("name") for lk in robot.findall("link") if lk.get("name") not in children]
    out, link = [], root
    while link in joints:
        out.append(joints[link])
        link = out[-1].find("child").get("link")
    return out


def _fk(chain: list[ET.Element], angles: dict[str, float]) -> np.ndarray:
    """Rotation matrix of the last link in the root link (columns: the child's axes)."""
    R = np.eye(3)
    for j in chain:
        origin = j.find("origin")
        R = R @ Rotation.from_euler("xyz", _floats(origin.get("rpy"))).as_matrix()
        assert np.allclose(_floats(origin.get("xyz")), 0.0)  # every axis passes through the pivot
        axis = _floats(j.find("axis").get("xyz"))
        R = R @ Rotation.from_rotvec(axis * angles.get(j.get("name"), 0.0)).as_matrix()
    return R


def _ros2_control(robot: ET.Element) -> tuple[dict[str, str], dict[str, ET.Element]]:
    tag = robot.find("ros2_control")
    hw = tag.find("hardware")
    params = {p.get("name"): p.text for p in hw.findall("param")}
    params["plugin"] = hw.find("plugin").text
    return params, {j.get("name"): j for j in tag.findall("joint")}


def test_two_axis_gimbal_urdf_is_the_sighting_chain_and_its_parameters():
    robot = _load("two_axis_gimbal.urdf")
    chain = _chain(robot)
    assert [j.get("name") for j in chain] == list(GIMBAL_ENCODER_JOINTS)
    assert chain[0].find("parent").get("link") == BASE_FRAME and chain[-1].find("child").get("link") == GIMBAL_FRAME
    rng = np.random.default_rng(7)
    for _ in range(20):
        psi_t, psi_m, theta_m = rng.uniform(-math.pi, math.pi, 3)
        C_bm = sighting_chain.dcm_bt(psi_t) @ sighting_chain.dcm_ta(psi_m) @ sighting_chain.dcm_am(theta_m)
        got = _fk(chain, dict(zip(GIMBAL_ENCODER_JOINTS, (psi_t, psi_m, theta_m))))
        assert np.allclose(got, C_bm, atol=1e-12)
    p = GIMBAL_MODELS["paper1"]
    links = {lk.get("name"): lk for lk in robot.findall("link")}
    for joint, member, torque, friction in (
            ("gimbal_azimuth", "outer", p.azimuth_torque_limit_nm, p.azimuth_friction_nm_s_rad),
            ("gimbal_elevation", "inner", p.elevation_torque_limit_nm, p.elevation_friction_nm_s_rad)):
        j = robot.find(f"joint[@name='{joint}']")
        inertial = links[j.find("child").get("link")].find("inertial")
        assert float(inertial.find("mass").get("value")) == getattr(p, f"{member}_mass_kg")
        assert tuple(_floats(inertial.find("origin").get("xyz"))) == getattr(p, f"{member}_cg_m")
        assert _floats(inertial.find("origin").get("rpy")).tolist() == [0.0, 0.0, 0.0]
        i = inertial.find("inertia")
        urdf = tuple(float(i.get(k)) for k in ("ixx", "iyy", "izz", "ixy", "ixz", "iyz"))
        assert urdf == getattr(p, f"{member}_inertia_kg_m2")
        assert float(j.find("limit").get("effort")) == torque
        assert float(j.find("limit").get("velocity")) == pytest.approx(torque / friction, rel=1e-12)
        assert float(j.find("dynamics").get("damping")) == friction
    params, joints = _ros2_control(robot)
    assert params["plugin"] == "topic_based_ros2_control/TopicBasedSystem"
    assert params["joint_states_topic"] == "/truth/gimbal/joint_states"
    assert params["joint_commands_topic"] == "/robot_joint_commands"
    assert tuple(joints) == GIMBAL_COMMAND_JOINTS  # the turret is the host's, not this hardware's
    for name, j in joints.items():
        (cmd,) = j.findall("command_interface")
        limit = float(robot.find(f"joint[@name='{name}']/limit").get("effort"))
        bounds = {q.get("name"): float(q.text) for q in cmd.findall("param")}
        assert cmd.get("name") == "effort" and bounds == {"min": -limit, "max": limit}


def test_four_gimbal_urdf_is_the_platform_geometry_and_table_1():
    robot = _load("four_gimbal_platform.urdf")
    chain = _chain(robot)
    assert [j.get("name") for j in chain] == list(reversed(PLATFORM_JOINTS))  # outer roll first
    assert chain[0].find("parent").get("link") == BASE_FRAME and chain[-1].find("child").get("link") == PLATFORM_FRAME
    rng = np.random.default_rng(8)
    for _ in range(20):
        angles = rng.uniform(-1.2, 1.2, 4)  # (a, q, p, r), away from gimbal lock
        got = _fk(chain, dict(zip(PLATFORM_JOINTS, angles)))
        assert np.allclose(got, four_gimbal.dcm_bs(angles), atol=1e-12)
    links = {lk.get("name"): lk for lk in robot.findall("link")}
    for j in chain:
        axis = paper3_axis_params(PLATFORM_AXES[j.get("name")])
        inertia = links[j.find("child").get("link")].find("inertial/inertia")
        direction = _floats(j.find("axis").get("xyz"))
        e = {k: float(inertia.get(k)) for k in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")}
        tensor = np.array([[e["ixx"], e["ixy"], e["ixz"]], [e["ixy"], e["iyy"], e["iyz"]],
                           [e["ixz"], e["iyz"], e["izz"]]])
        assert direction @ tensor @ direction == axis.inertia_kg_m2  # J about the joint axis
        limit, dyn = j.find("limit"), j.find("dynamics")
        stall = axis.torque_constant_nm_a * axis.voltage_limit_v / axis.resistance_ohm
        assert float(limit.get("effort")) == pytest.approx(stall, rel=1e-5)
        assert float(limit.get("velocity")) == pytest.approx(axis.voltage_limit_v / axis.back_emf, rel=1e-5)
        assert float(dyn.get("damping")) == axis.viscous_friction_nm_s_rad
        assert float(dyn.get("friction")) == axis.coulomb_friction_nm
    params, joints = _ros2_control(robot)
    assert params["joint_states_topic"] == "/truth/platform/joint_states"
    assert tuple(joints) == PLATFORM_JOINTS
    for name, j in joints.items():
        bounds = {q.get("name"): float(q.text) for q in j.find("command_interface").findall("param")}
        v_max = paper3_axis_params(PLATFORM_AXES[name]).voltage_limit_v  # the command is the motor voltage
        assert bounds == {"min": -v_max, "max": v_max}
