"""The one registry of the graph's node executables: for each, its package, its parameter
table and ``--help`` text, and its node class.

Everything that lists nodes derives from it: scenario validation (:mod:`.scenario`), the
orchestrator, the config generator (:mod:`.config_files`), the core loop and the bench.
gimbal_sim is the composition root, so it reaches the packages below it through plain
static imports. The parameter tables come from each node's rclpy-free ``<node>_params``
module, so validating a scenario or writing the configs does not load rclpy; a node class
is imported (with rclpy) only when :meth:`NodeType.node_class` is called, to run it.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

from gimbal_control import (
    encoder_fusion_controller_params, geo_pointer_params, los_rate_controller_params, platform_servo_params,
)
from gimbal_control.encoder_fusion import EncoderFusionParams
from gimbal_control.geo_pointer import GeoPointerParams
from gimbal_control.los_hold import LosHoldParams
from gimbal_control.los_rate_controller import LosRateControllerParams
from gimbal_control.operator_command import OperatorCommandParams
from gimbal_control.dtg_servo import platform_servo_core
from gimbal_estimators import (
    flexure_estimator_params, free_gyro_positioning_params, gyro_bias_ekf_params, platform_alignment_params,
    platform_navigator_params,
)
from gimbal_estimators.flexure_attitude_matching import AttitudeMatchingParams
from gimbal_estimators.flexure_kf import FlexureKfParams
from gimbal_estimators.free_gyro_positioning import FreeGyroPositioningParams
from gimbal_estimators.gyro_bias_ekf_params import GyroBiasEkfParams
from gimbal_estimators.platform_navigator_params import PlatformNavigatorParams
from gimbal_estimators.rotation_alignment import RotationAlignmentParams
from gimbal_kinematics.params.table import Param

from ..mavlink import mavlink_gimbal_device_params, mavlink_gimbal_manager_params
from ..mavlink.device_core import DeviceParams
from ..mavlink.link import endpoint_values
from ..mavlink.manager_core import ManagerParams
from ..nodes import bag_recorder_params, operator_params, sensor_models_params, vehicle_dynamics_params
from ..world.operator_model import operator_core
from ..world.sensor_suite import SensorSuiteConfig
from ..world.vehicle import VehicleConfig


@dataclass(frozen=True)
class NodeType:
    """A node executable the orchestrator can run: its ``package``, parameter table
    ``params`` and ``--help`` text ``description``, and ``load_class``, which imports its
    rclpy node class."""

    package: str
    params: tuple[Param, ...]
    description: str
    load_class: Callable[[], type]
    #: the node's own parameter checks, rclpy-free: the ``from_values`` of the cores its
    #: ``__init__`` builds from its values (cross-parameter rules, list lengths, NaN in a
    #: list); raises ValueError naming the parameter. Lets gimbal-run refuse what a node
    #: would refuse before anything starts.
    check: Callable[[dict], object] = lambda values: None

    def node_class(self) -> type:
        return self.load_class()


# Each loader imports one node module: rclpy loads only for a node that is run.
def _vehicle_dynamics() -> type:
    from ..nodes.vehicle_dynamics_node import VehicleDynamicsNode
    return VehicleDynamicsNode


def _sensor_models() -> type:
    from ..nodes.sensor_models_node import SensorModelsNode
    return SensorModelsNode


def _bag_recorder() -> type:
    from ..nodes.bag_recorder_node import BagRecorderNode
    return BagRecorderNode


def _operator() -> type:
    from ..nodes.operator_node import OperatorNode
    return OperatorNode


def _los_rate_controller() -> type:
    from gimbal_control.los_rate_controller_node import LosRateControllerNode
    return LosRateControllerNode


def _gyro_bias_ekf() -> type:
    from gimbal_estimators.gyro_bias_ekf_node import GyroBiasEkfNode
    return GyroBiasEkfNode


def _free_gyro_positioning() -> type:
    from gimbal_estimators.free_gyro_positioning_node import FreeGyroPositioningNode
    return FreeGyroPositioningNode


def _encoder_fusion_controller() -> type:
    from gimbal_control.encoder_fusion_controller_node import EncoderFusionControllerNode
    return EncoderFusionControllerNode


def _flexure_estimator() -> type:
    from gimbal_estimators.flexure_estimator_node import FlexureEstimatorNode
    return FlexureEstimatorNode


def _platform_servo() -> type:
    from gimbal_control.platform_servo_node import PlatformServoNode
    return PlatformServoNode


def _platform_alignment() -> type:
    from gimbal_estimators.platform_alignment_node import PlatformAlignmentNode
    return PlatformAlignmentNode


def _geo_pointer() -> type:
    from gimbal_control.geo_pointer_node import GeoPointerNode
    return GeoPointerNode


def _platform_navigator() -> type:
    from gimbal_estimators.platform_navigator_node import PlatformNavigatorNode
    return PlatformNavigatorNode


def _mavlink_gimbal_device() -> type:
    from ..mavlink.mavlink_gimbal_device_node import MavlinkGimbalDeviceNode
    return MavlinkGimbalDeviceNode


def _mavlink_gimbal_manager() -> type:
    from ..mavlink.mavlink_gimbal_manager_node import MavlinkGimbalManagerNode
    return MavlinkGimbalManagerNode


def _node_type(package: str, params_module, load_class: Callable[[], type],
               *checks: Callable[[dict], object]) -> NodeType:
    def check(values: dict) -> None:
        for one in checks:
            one(values)
    return NodeType(package, params_module.PARAMS, params_module.DESCRIPTION, load_class, check)


def _flexure_params(v: dict) -> object:
    return (AttitudeMatchingParams if v["model"] == "original" else FlexureKfParams).from_values(v)


def _los_hold_params(v: dict) -> object:
    return LosHoldParams.from_values(v) if v["mode"] == "los_hold" else None


#: executable -> NodeType; scenario nodes must use one of these.
NODE_TYPES: dict[str, NodeType] = {
    "vehicle_dynamics": _node_type("gimbal_sim", vehicle_dynamics_params, _vehicle_dynamics, VehicleConfig.from_values),
    "sensor_models": _node_type("gimbal_sim", sensor_models_params, _sensor_models, SensorSuiteConfig.from_values),
    "bag_recorder": _node_type("gimbal_sim", bag_recorder_params, _bag_recorder),
    "operator": _node_type("gimbal_sim", operator_params, _operator, operator_core),
    "los_rate_controller": _node_type("gimbal_control", los_rate_controller_params, _los_rate_controller,
                                      LosRateControllerParams.from_values, OperatorCommandParams.from_values,
                                      _los_hold_params),
    "gyro_bias_ekf": _node_type("gimbal_estimators", gyro_bias_ekf_params, _gyro_bias_ekf,
                                GyroBiasEkfParams.from_values),
    "free_gyro_positioning": _node_type("gimbal_estimators", free_gyro_positioning_params, _free_gyro_positioning,
                                        FreeGyroPositioningParams.from_values),
    "encoder_fusion_controller": _node_type("gimbal_control", encoder_fusion_controller_params,
                                            _encoder_fusion_controller, EncoderFusionParams.from_values),
    "flexure_estimator": _node_type("gimbal_estimators", flexure_estimator_params, _flexure_estimator, _flexure_params),
    "platform_servo": _node_type("gimbal_control", platform_servo_params, _platform_servo,
                                 platform_servo_core),
    "platform_alignment": _node_type("gimbal_estimators", platform_alignment_params, _platform_alignment,
                                     RotationAlignmentParams.from_values),
    "geo_pointer": _node_type("gimbal_control", geo_pointer_params, _geo_pointer, GeoPointerParams.from_values),
    "platform_navigator": _node_type("gimbal_estimators", platform_navigator_params, _platform_navigator,
                                     PlatformNavigatorParams.from_values),
    "mavlink_gimbal_device": _node_type("gimbal_sim", mavlink_gimbal_device_params, _mavlink_gimbal_device,
                                        DeviceParams.from_values, endpoint_values),
    "mavlink_gimbal_manager": _node_type("gimbal_sim", mavlink_gimbal_manager_params, _mavlink_gimbal_manager,
                                         ManagerParams.from_values, endpoint_values),
}
