"""Write each node's ``config/<node>.yaml`` from its parameter table (a maintainer tool).

The tests fail when a config file and its node's declared defaults disagree; regenerate
with ``python -m gimbal_sim.config_files``.
"""
from __future__ import annotations

import importlib
from pathlib import Path

from gimbal_kinematics.params import params_yaml

#: node name -> (package, module holding PARAMS)
NODE_MODULES = {
    "vehicle_dynamics": ("gimbal_sim", "gimbal_sim.vehicle_dynamics_node"),
    "sensor_models": ("gimbal_sim", "gimbal_sim.sensor_models_node"),
    "bag_recorder": ("gimbal_sim", "gimbal_sim.bag.recorder_node"),
    "los_rate_controller": ("gimbal_control", "gimbal_control.los_rate_controller_node"),
    "gyro_bias_ekf": ("gimbal_estimators", "gimbal_estimators.gyro_bias_ekf_node"),
    "free_gyro_positioning": ("gimbal_estimators", "gimbal_estimators.free_gyro_positioning_node"),
    "encoder_fusion_controller": ("gimbal_control", "gimbal_control.encoder_fusion_controller_node"),
    "flexure_estimator": ("gimbal_estimators", "gimbal_estimators.flexure_estimator_node"),
    "platform_servo": ("gimbal_control", "gimbal_control.platform_servo_node"),
    "platform_alignment": ("gimbal_estimators", "gimbal_estimators.platform_alignment_node"),
}


def config_path(package: str, node_name: str) -> Path:
    """The source-tree config file (``src/<package>/config/<node>.yaml``)."""
    module = importlib.import_module(package)
    return Path(module.__file__).resolve().parents[1] / "config" / f"{node_name}.yaml"


def expected_text(node_name: str) -> str:
    package, module_name = NODE_MODULES[node_name]
    return params_yaml(node_name, importlib.import_module(module_name).PARAMS)


def main() -> None:
    for node_name, (package, _) in NODE_MODULES.items():
        path = config_path(package, node_name)
        path.write_text(expected_text(node_name))
        print(f"wrote {path}")


if __name__ == "__main__":
    main()
