"""Geometry of stabilized sighting platforms (docs/spec.md section 2). Pure numpy/scipy; no
rclpy (the ROS edge is the import-isolated :mod:`gimbal_kinematics.ros`).

Conventions
-----------
Frames (ids in :mod:`gimbal_kinematics.frames`):

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
    - every stamp check uses one verdict vocabulary (:mod:`gimbal_kinematics.stamps`)
"""

from .kernel_cache import configure as _configure_kernel_cache

_configure_kernel_cache()  # before any kernel compiles (kernel_cache's docstring)
