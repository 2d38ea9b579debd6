"""ament_python build script for gimbal_estimators (ros2/demos layout)."""
from glob import glob

from setuptools import find_packages, setup

package_name = "gimbal_estimators"

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
            "gyro_bias_ekf = gimbal_estimators.gyro_bias_ekf_node:main",
            "free_gyro_positioning = gimbal_estimators.free_gyro_positioning_node:main",
            "flexure_estimator = gimbal_estimators.flexure_estimator_node:main",
            "platform_alignment = gimbal_estimators.platform_alignment_node:main",
            "platform_navigator = gimbal_estimators.platform_navigator_node:main",
        ],
    },
)
