"""ament_python build script for gimbal_kinematics (ros2/demos layout)."""
from glob import glob

from setuptools import find_packages, setup

package_name = "gimbal_kinematics"

setup(
    name=package_name,
    version="0.1.0",
    packages=find_packages(exclude=["test"]),
    data_files=[
        ("share/ament_index/resource_index/packages", ["resource/" + package_name]),
        ("share/" + package_name, ["package.xml"]),
        ("share/" + package_name + "/config", glob("config/*.yaml")),
        ("share/" + package_name + "/urdf", glob("urdf/*.urdf")),
    ],
    install_requires=["setuptools"],
    zip_safe=True,
    maintainer="Gimbal toolkit maintainers",
    maintainer_email="maintainers@gimbal-ros.invalid",
    description=open("package.xml").read().split("<description>")[1].split("</description>")[0],
    license="Apache-2.0",
    entry_points={
        "console_scripts": [
            "gimbal-geometry = gimbal_kinematics.cli.geometry:main",
        ],
    },
)
