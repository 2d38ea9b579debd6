"""Estimators for sighting platforms: gyro-bias EKF, ship-flexure KF, rotation-modulated alignment, free-gyro positioning."""

import gimbal_kinematics  # noqa: F401  (numba's kernel cache keyed first: gimbal_kinematics.maths.kernel_cache)
