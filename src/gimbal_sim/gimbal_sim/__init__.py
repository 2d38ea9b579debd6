"""Simulation of host vehicles, gimbal dynamics and sensors in deterministic lockstep; MCAP recording, bag tools and the scenario orchestrator."""

import gimbal_kinematics  # noqa: F401  (numba's kernel cache keyed first: gimbal_kinematics.maths.kernel_cache)
