"""Estimators for sighting platforms: gyro-bias EKF, ship-flexure KF, rotation-modulated alignment, free-gyro positioning."""
