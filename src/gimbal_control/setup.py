"""ament_python build script for gimbal_control (ros2/demos layout)."""
from glob import glob

from setuptools import find_packages, setup

package_name = "gimbal_control"

setup(
    name=package_name,
    version="0.1.0",
    packages=find_packages(exclude=["test"]),
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
            "los_rate_controller = gimbal_control.los_rate_controller_node:main",
            "encoder_fusion_controller = gimbal_control.encoder_fusion_controller_node:main",
            "platform_servo = gimbal_control.platform_servo_node:main",
            "geo_pointer = gimbal_control.geo_pointer_node:main",
        ],
    },
)
