"""Geometry of stabilized sighting platforms (docs/spec.md section 2). Pure numpy/scipy; no
rclpy (the ROS edge is the import-isolated :mod:`gimbal_kinematics.ros`).

Rooms
-----
Each subpackage is one room; a module imports its own room and the rooms below it
(``test/test_architecture.py``, ``KINEMATICS_ROOM``), bottom-up:

    - ``maths/``: the floor: rotations, the WGS-84 earth, the sighting chain and LOS, the
      four-gimbal platform, free-gyro and geo-pointing geometry, the Kalman steps, frame
      ids, checks of numbers, and the compiled kernels behind them
    - ``gimbal/``: rigid-body models: the two-axis gimbal, the host state, the turret base
    - ``timing/``: the one timing edge: the stamp vocabulary, orderings, stream statistics,
      and the input and control policies a node picks once
    - ``params/``: a node's parameters without ROS: the Param table and ROS 2 parameter
      files
    - ``cli/``: the command-line edge: the one error boundary of every command, gimbal-
      geometry
    - ``ros/``: the import-isolated ROS edge every node shares

Conventions
-----------
Frames (ids in :mod:`gimbal_kinematics.maths.frames`):

    - n: the local navigation frame, north-east-down (NED, ``map_ned``)
    - b: the host vehicle body (INS case), forward-right-down (FRD)
    - m: paper 1's inner (elevation) gimbal, FRD; its x axis is the line of sight
    - p: paper 3's stabilized platform, FRD
    - i: the inertial frame that coincides with n at the start of a run

Vectors and rotations:

    - ``vec_a``: a vector resolved in frame a (``omega_in_n``: the rate of n relative to i,
      resolved in n)
    - ``C_ab``: the direction-cosine matrix that maps a vector resolved in b to a:
      ``vec_a = C_ab @ vec_b``; ``quat_ab`` is the same rotation as a quaternion
      (x, y, z, w), scalar last as on the wire
    - Euler angles are 3-2-1 (yaw, pitch, roll applied in that order), roll/pitch/yaw
      returned in that order

Units:

    - SI inside (rad, rad/s, m, m/s², s); degrees, deg/h and arcsec only at the YAML/CLI
      edge, with the unit in the parameter name (``bias_deg_h``, ``rate_hz``, ``tau_s``)
    - states are arrays of shape (n,), covariances (n, n)

Stamps:

    - a message stamp is an integer number of nanoseconds (``stamp_ns``); a core's time is
      float seconds relative to its run's origin (0 in lockstep, the first stamp in free
      timing: a float64 near 1.8e9 s resolves only 2.4e-7 s)
    - lockstep step k is stamped ``k * 1e9 / sim_rate_hz`` ns
      (:func:`gimbal_kinematics.ros.messages.step_stamp_ns`)
    - every stamp check uses one verdict vocabulary (:mod:`gimbal_kinematics.timing.stamps`)
"""

from .maths.kernel_cache import configure as _configure_kernel_cache

_configure_kernel_cache()  # before any kernel compiles (kernel_cache's docstring)
