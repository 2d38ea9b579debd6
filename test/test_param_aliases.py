"""Deprecated parameter names: a node given one logs one warning naming the new name and
behaves exactly as with the new name (gimbal_kinematics.ros.params.declare_and_read)."""
from __future__ import annotations

import pytest
import rclpy
from rclpy.context import Context
from rclpy.node import Node
from rclpy.parameter import Parameter

from gimbal_estimators.platform_alignment_node import PlatformAlignmentNode
from gimbal_estimators.platform_alignment_params import PARAMS as ALIGNMENT_PARAMS
from gimbal_kinematics.params.table import CLOCK_JUMP_ALIASES, ParameterError
from gimbal_kinematics.ros.params import declare_and_read
from gimbal_sim.graph.scenario import check_param
from gimbal_sim.nodes.vehicle_dynamics_params import PARAMS as VEHICLE_PARAMS


class _Log:
    def __init__(self) -> None:
        self.warnings: list[str] = []

    def warning(self, text: str, **_) -> None:
        self.warnings.append(text)


@pytest.fixture
def context(ros_domain_env):
    ctx = Context()
    rclpy.init(context=ctx, domain_id=int(ros_domain_env["ROS_DOMAIN_ID"]))
    yield ctx
    rclpy.shutdown(context=ctx)


def _read(context, params, overrides):
    node = Node("alias_probe", context=context,
                parameter_overrides=[Parameter(k, value=v) for k, v in overrides.items()])
    log = _Log()
    node.get_logger = lambda: log  # type: ignore[method-assign]
    try:
        return declare_and_read(node, params), log.warnings
    finally:
        node.destroy_node()


@pytest.mark.parametrize("alias", CLOCK_JUMP_ALIASES)
def test_deprecated_clock_jump_name_warns_once_and_sets_the_parameter(context, alias):
    values, warnings = _read(context, ALIGNMENT_PARAMS, {alias: 0.25})
    assert values["clock_jump_s"] == 0.25
    assert len(warnings) == 1 and alias in warnings[0] and "clock_jump_s" in warnings[0]
    values, warnings = _read(context, ALIGNMENT_PARAMS, {"clock_jump_s": 0.25})
    assert values["clock_jump_s"] == 0.25 and warnings == []
    values, warnings = _read(context, ALIGNMENT_PARAMS, {})
    assert values["clock_jump_s"] == 1.0 and warnings == []


def test_deprecated_name_keeps_the_range_check(context):
    with pytest.raises(ParameterError, match="reset_backjump_s"):
        _read(context, ALIGNMENT_PARAMS, {"reset_backjump_s": -1.0})


def test_vehicle_mode_is_the_deprecated_name_of_timing(context):
    values, warnings = _read(context, VEHICLE_PARAMS, {"mode": "realtime"})
    assert values["timing"] == "realtime" and len(warnings) == 1 and "'timing'" in warnings[0]
    assert check_param("vehicle", "vehicle_dynamics", "mode", "realtime") == "realtime"


def test_node_given_the_old_name_behaves_as_with_the_new_one(context):
    nodes = [PlatformAlignmentNode(context=context, parameter_overrides=[Parameter(name, value=0.25)])
             for name in ("reset_backjump_s", "clock_jump_s")]
    try:
        old, new = nodes
        assert old.core.params == new.core.params
        assert old.policy.stats["imu"].jump_ns == new.policy.stats["imu"].jump_ns == 250_000_000
    finally:
        for n in nodes:
            n.destroy_node()
