"""Frame ids and joint names on the topics, as named constants (REP 103 / REP 105 style ids).

The navigation frame is NED (``map_ned``) and body frames are FRD (x forward, y right, z
down), as in the papers; each ``*_frd`` id names the body whose axes a vector is resolved
in. Every ``frame_id`` and joint name a node writes or expects comes from here, so a driver
author has one list to match (docs/interfaces.md).
"""
from __future__ import annotations

#: The local navigation frame n: north, east, down.
NAV_FRAME = "map_ned"
#: The host vehicle body b (the INS case), FRD.
BASE_FRAME = "base_link_frd"
#: The inner (elevation) gimbal m of paper 1, FRD: the two-axis gimbal gyro and its biases.
GIMBAL_FRAME = "gimbal_inner_frd"
#: The stabilized platform of paper 3's four-gimbal INS, FRD.
PLATFORM_FRAME = "platform_frd"
#: The two laser-gyro units of paper 5 (ship flexure), FRD.
LGU1_FRAME = "lgu1_frd"
LGU2_FRAME = "lgu2_frd"

#: Paper 1's sighting chain: the encoders read these joints (turret, gimbal azimuth, elevation).
GIMBAL_ENCODER_JOINTS = ("turret_azimuth", "gimbal_azimuth", "gimbal_elevation")
#: The torque-commanded gimbal joints (azimuth, elevation).
GIMBAL_COMMAND_JOINTS = ("gimbal_azimuth", "gimbal_elevation")
#: Paper 3's four-gimbal platform joints (a, q, p, r).
PLATFORM_JOINTS = ("platform_azimuth", "platform_inner_roll", "platform_pitch", "platform_outer_roll")
#: The single joint of the platform servo's commanded modulation angle φz.
MODULATION_JOINT = "modulation_angle"
#: Paper 3's DTG pickoff angles, as joints: lower gyro (θ_x, θ_y), upper gyro (θ_x, θ_y).
DTG_PICKOFF_JOINTS = ("dtg_lower_x", "dtg_lower_y", "dtg_upper_x", "dtg_upper_y")
#: Paper 3's DTG torquer currents, as joints: the platform axes x_s, y_s, z_s they precess.
DTG_TORQUER_JOINTS = ("dtg_torquer_x", "dtg_torquer_y", "dtg_torquer_z")
