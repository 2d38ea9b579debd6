"""ament_python build script for gimbal_kinematics: its metadata, files and executables are in setup.cfg."""
from setuptools import setup

setup()
