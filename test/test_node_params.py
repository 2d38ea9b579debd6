"""Node parameters: YAML configs agree with the declared defaults and load through rcl;
bad values are refused at startup with exit code 2 and a message naming the parameter."""
from __future__ import annotations

import subprocess

import pytest
import rclpy
import yaml
from rclpy.context import Context
from rclpy.node import Node

from conftest import VENV_BIN
from gimbal_sim.graph.config_files import config_path, expected_text
from gimbal_sim.graph.registry import NODE_TYPES
from gimbal_kinematics.ros.params import declare_and_read
from ros_harness import ros_args

NODES = ("vehicle_dynamics", "sensor_models")


@pytest.mark.parametrize("node_name", NODES)
def test_config_yaml_matches_declared_defaults_and_loads_in_rcl(node_name, ros_domain_env):
    path = config_path("gimbal_sim", node_name)
    assert path.read_text() == expected_text(node_name), "regenerate: python -m gimbal_sim.graph.config_files"
    params = NODE_TYPES[node_name].params
    in_file = yaml.safe_load(path.read_text())[node_name]["ros__parameters"]
    declared = {p.name: p.default for p in params if p.default != []}
    assert in_file == declared
    for p in params:
        is_real = isinstance(p.default, float) or (isinstance(p.default, list) and p.default
                                                   and isinstance(p.default[0], float))
        assert p.description and (not is_real or "[" in p.description), f"{p.name}: give the unit"
    # rcl parses the file as ros2 run would (--params-file), and every value arrives
    context = Context()
    rclpy.init(args=["--ros-args", "--params-file", str(path)], context=context,
               domain_id=int(ros_domain_env["ROS_DOMAIN_ID"]))
    try:
        node = Node(node_name, context=context)
        assert {k: v for k, v in declare_and_read(node, params).items() if k in declared} == declared
        node.destroy_node()
    finally:
        rclpy.shutdown(context=context)


BAD = [
    ("vehicle_dynamics", {"profile": "banana"}, "profile"),
    ("vehicle_dynamics", {"sim_rate_hz": -100.0}, "sim_rate_hz"),
    ("vehicle_dynamics", {"duration_s": 0.0}, "duration_s"),
    ("vehicle_dynamics", {"profile_params": "{lat_deg: 123.0}"}, "lat_deg"),
    ("vehicle_dynamics", {"profile_params": "'{site: [1'"}, "profile_params"),
    ("vehicle_dynamics", {"profile_params": "'[1, 2]'"}, "profile_params"),
    ("vehicle_dynamics", {"duration_s": "[1, 2"}, "--ros-args"),
    ("vehicle_dynamics", {"subscriber_counts": ["/clock=x"]}, "subscriber_counts"),
    ("sensor_models", {"gimbal_gyro_arw_deg_rt_h": -0.1}, "gimbal_gyro_arw_deg_rt_h"),
    ("sensor_models", {"gimbal_gyro_bi_tau_s": 0.0}, "gimbal_gyro_bi_tau_s"),
    ("sensor_models", {"ins_rate_hz": 300.0}, "ins_rate_hz"),
    ("sensor_models", {"sensors": ["ins", "sonar"]}, "sonar"),
    ("sensor_models", {"encoder_quadrature": 3}, "quadrature"),
]


@pytest.mark.parametrize("exe,params,named", BAD, ids=[f"{e}-{n}" for e, _, n in BAD])
def test_bad_parameter_is_refused_naming_it(exe, params, named, ros_domain_env):
    result = subprocess.run([str(VENV_BIN / exe), *ros_args(params)], env=ros_domain_env,
                            capture_output=True, text=True, timeout=60)
    assert result.returncode == 2, result.stderr
    assert "refused to start" in result.stderr and named in result.stderr, result.stderr
