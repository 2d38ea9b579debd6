"""The maths every layer shares (pure numpy/scipy, no rclpy): rotations, the WGS-84 earth,
the paper 1 sighting chain and line of sight, the paper 3 four-gimbal platform, the paper 4
free-gyro geometry, geo-pointing, the Kalman steps (Joseph form), frame ids, the checks of
numbers, and the compiled kernels behind them. The floor of the package: it imports no
other room. Import its modules explicitly (``from gimbal_kinematics.maths.rotations import
...``); this ``__init__`` imports nothing."""
