"""ament_python build script for gimbal_control: its metadata, files and executables are in setup.cfg."""
from setuptools import setup

setup()
