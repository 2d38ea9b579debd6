"""ament_python build script for gimbal_sim (ros2/demos layout)."""
from glob import glob

from setuptools import find_packages, setup

package_name = "gimbal_sim"

setup(
    name=package_name,
    version="0.1.0",
    packages=find_packages(exclude=["test"]),
    package_data={package_name + ".graph": ["scenarios/*.yaml"]},
    data_files=[
        ("share/ament_index/resource_index/packages", ["resource/" + package_name]),
        ("share/" + package_name, ["package.xml"]),
        ("share/" + package_name + "/config", glob("config/*.yaml")),
    ],
    install_requires=["setuptools"],
    zip_safe=True,
    maintainer="Gimbal toolkit maintainers",
    maintainer_email="maintainers@gimbal-ros.invalid",
    description=open("package.xml").read().split("<description>")[1].split("</description>")[0],
    license="Apache-2.0",
    entry_points={
        "console_scripts": [
            "gimbal-run = gimbal_sim.run_cli:main",
            "vehicle_dynamics = gimbal_sim.nodes.vehicle_dynamics_node:main",
            "sensor_models = gimbal_sim.nodes.sensor_models_node:main",
            "bag_recorder = gimbal_sim.nodes.bag_recorder_node:main",
            "operator = gimbal_sim.nodes.operator_node:main",
            "mavlink_gimbal_device = gimbal_sim.mavlink.mavlink_gimbal_device_node:main",
            "mavlink_gimbal_manager = gimbal_sim.mavlink.mavlink_gimbal_manager_node:main",
            "gimbal-report = gimbal_sim.reports.dispatch:main",
            "gimbal-bag = gimbal_sim.bag.cli:main",
            "gimbal-bench = gimbal_sim.tools.bench:main",
            "gimbal-allan = gimbal_sim.allan.cli:main",
            "gimbal-campaign = gimbal_sim.campaign_cli:main",
        ],
    },
)
