"""ROS 2 parameter files as gimbal-run reads them: node blocks matched as rclpy itself matches
them (the oracle: an rclpy node started with the file), a misspelt block refused naming the
nodes, and every value (params file or --set) checked against its range before anything starts."""
from __future__ import annotations

import pytest
import rclpy
import yaml
from rclpy.context import Context
from rclpy.node import Node

from gimbal_kinematics.params.file import blocks
from gimbal_sim.graph.scenario import ScenarioError, apply_params_file, apply_set, load

PATTERNS = ["/**", "/gyro_bias_ekf", "gyro_bias_ekf", "/ns/gyro_bias_ekf", "/**/gyro_bias_ekf", "/*", "/ns/*",
            "/*/gyro_bias_ekf", "/**/deep/*", "/ns/**"]
NODES = [("gyro_bias_ekf", "/"), ("gyro_bias_ekf", "/ns"), ("gyro_bias_ekf", "/ns/deep"), ("other", "/ns/deep")]


def _rclpy_takes(path, name: str, namespace: str) -> tuple[bool, str]:
    """Whether an rclpy node (name, namespace) started with the file gets its parameter p."""
    ctx = Context()
    rclpy.init(args=["--ros-args", "--params-file", str(path)], context=ctx)
    try:
        node = Node(name, namespace=namespace, context=ctx, automatically_declare_parameters_from_overrides=True)
        taken, fqn = node.has_parameter("p"), node.get_fully_qualified_name()
        node.destroy_node()
    finally:
        rclpy.shutdown(context=ctx)
    return taken, fqn


@pytest.mark.parametrize("nested", [False, True])
def test_blocks_match_the_nodes_rclpy_gives_them_to(tmp_path, nested):
    for k, pattern in enumerate(PATTERNS):
        tokens = pattern.strip("/").split("/")
        doc: dict = {"ros__parameters": {"p": 1}}
        if nested and len(tokens) > 1:  # the namespace-map form: /ns: {node: {ros__parameters: ...}}
            for token in reversed(tokens):
                doc = {token: doc}
        else:
            doc = {pattern: doc}
        path = tmp_path / f"{k}.yaml"
        path.write_text(yaml.safe_dump(doc))
        (block,) = blocks(yaml.safe_load(path.read_text()), "test")
        for name, namespace in NODES:
            taken, fqn = _rclpy_takes(path, name, namespace)
            assert block.matches(fqn) == taken, (pattern, nested, fqn)


def _file(tmp_path, doc) -> object:
    path = tmp_path / "p.yaml"
    path.write_text(yaml.safe_dump(doc))
    return path


def test_a_wildcard_block_applies_to_every_node_that_declares_the_parameter(tmp_path):
    scenario = load("sighting_land_vehicle")
    out = apply_params_file(scenario, _file(tmp_path, {"/**": {"ros__parameters": {"diagnostics_period_s": 2.5}},
                                                       "gyro_bias_ekf": {"ros__parameters": {"clock_jump_s": 0.25}}}))
    for name, spec in out.nodes.items():
        declares = name in ("los_rate_controller", "gyro_bias_ekf")  # the two that have the parameter
        assert (spec["params"].get("diagnostics_period_s") == 2.5) == declares, name
    assert out.nodes["gyro_bias_ekf"]["params"]["clock_jump_s"] == 0.25
    # in file order, a later block wins
    later = apply_params_file(scenario, _file(tmp_path, {"/**": {"ros__parameters": {"diagnostics_period_s": 2.5}},
                                                         "/gyro_bias_ekf": {"ros__parameters":
                                                                            {"diagnostics_period_s": 4.0}}}))
    assert later.nodes["gyro_bias_ekf"]["params"]["diagnostics_period_s"] == 4.0
    assert later.nodes["los_rate_controller"]["params"]["diagnostics_period_s"] == 2.5


@pytest.mark.parametrize("doc, words", [
    ({"gyro_bias_ekff": {"ros__parameters": {"clock_jump_s": 0.2}}}, "'/gyro_bias_ekff' matches no node"),
    ({"/ns/gyro_bias_ekf": {"ros__parameters": {"clock_jump_s": 0.2}}}, "'/ns/gyro_bias_ekf' matches no node"),
    ({"gyro_bias_ekf": {"ros__parameters": {"clock_jump_s": 0.2}},
      "/**": {"ros__parameters": {"clock_jump_sec": 1.0}}}, "'clock_jump_sec' of a wildcard block"),
    ({"gyro_bias_ekf": {"ros__parameters": {"clock_jump_s": -1.0}}}, "'clock_jump_s' = -1.0 is outside"),
    ({"/**": {"ros__parameters": {"timing": "fast"}}}, "'fast' is not one of"),
    ({"/gyro_*": {"ros__parameters": {"clock_jump_s": 0.2}}}, "not 'gyro_*'"),
])
def test_misspelt_blocks_and_bad_values_are_refused_naming_them(tmp_path, doc, words):
    with pytest.raises(ScenarioError) as exc:
        apply_params_file(load("sighting_land_vehicle"), _file(tmp_path, doc))
    assert words in str(exc.value), exc.value
    if "matches no node" in words:  # the message names the scenario's nodes
        assert "/gyro_bias_ekf" in str(exc.value) and "/vehicle_dynamics" in str(exc.value)


def test_blocks_of_toolkit_nodes_the_scenario_does_not_run_are_left_alone(tmp_path):
    doc = {"flexure_estimator": {"ros__parameters": {"lgu_arw_deg_rt_h": 0.01}},
           "gyro_bias_ekf": {"ros__parameters": {"clock_jump_s": 0.2}}}
    out = apply_params_file(load("sighting_land_vehicle"), _file(tmp_path, doc))
    assert out.nodes["gyro_bias_ekf"]["params"]["clock_jump_s"] == 0.2


@pytest.mark.parametrize("assignment, words", [
    ("gyro_bias_ekf.diagnostics_period_s=-1", "outside [0.001"),
    ("gyro_bias_ekf.diagnostics_period_s=.nan", "nan is outside"),
    ("gyro_bias_ekf.timing=sometimes", "not one of ['free', 'lockstep']"),
])
def test_every_set_value_is_range_checked_before_anything_starts(assignment, words):
    with pytest.raises(ScenarioError) as exc:
        apply_set(load("sighting_land_vehicle"), assignment)
    assert words in str(exc.value) and assignment.split("=")[0].split(".")[1] in str(exc.value), exc.value
