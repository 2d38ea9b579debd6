"""ament_python build script for gimbal_sim: its metadata, files and executables are in setup.cfg."""
from setuptools import setup

setup()
