"""Experiment runners: Monte Carlo campaigns and one-process closed loops that drive the cores
of gimbal_estimators and gimbal_control with gimbal_sim's vehicle and sensor models (no ROS).

Each module is one experiment with its own command line, ``python -m
gimbal_sim.experiments.<name> --help``. They live here, above the estimator and controller
packages, so that those packages never import the simulator.
"""
