"""Stabilization controllers for gimbaled sighting systems: inverse-dynamics PI (paper 1), PID with encoder/gyro fusion (paper 2), four-gimbal platform servo (paper 3)."""

import gimbal_kinematics  # noqa: F401  (numba's kernel cache keyed first: gimbal_kinematics.maths.kernel_cache)
