"""The ``platform_alignment`` node's parameter table and --help text, readable without ROS
(the node declares them; the config generator and the scenario checks read them). The
mapping to the core's parameters is
:meth:`.rotation_alignment.RotationAlignmentParams.from_values`.
"""
from __future__ import annotations

import math

from gimbal_kinematics.params import CLOCK_JUMP_ALIASES, TIMING_PARAM, Param

DESCRIPTION = (
    "Paper 3 rotation-modulated fine alignment: 8-state recursive least squares on the platform's level "
    "accelerometers and azimuth joint angle, estimating the initial misalignment, the north gyro drift and "
    "the level gyro drifts and accelerometer biases. Publishes the estimates with their sigma once per block."
)
INF = math.inf

PARAMS = (
    TIMING_PARAM,
    Param("sim_rate_hz", 1000.0, "lockstep rate [Hz], to turn stamps into steps", 1.0, 100000.0),
    Param("imu_rate_hz", 1000.0, "platform IMU rate [Hz]; divides sim_rate_hz", 1e-3, 100000.0),
    Param("joint_rate_hz", 1000.0, "rate of the azimuth joint topic [Hz]; divides sim_rate_hz", 1e-3, 100000.0),
    Param("joint_topic", "/platform/resolvers", "sensor_msgs/JointState topic carrying the azimuth joint"),
    Param("azimuth_joint", "platform_azimuth", "name of the azimuth gimbal joint in joint_topic"),
    Param("base_heading_deg", 0.0, "heading the base is taken to have (added to the azimuth joint) [deg]",
          -360.0, 360.0),
    Param("lat_deg", 40.0, "latitude of the static base [deg] (azimuth is unobservable at the poles)",
          -89.999, 89.999),
    Param("gravity_m_s2", 0.0, "local gravity [m/s^2] (0: WGS-84 normal gravity at lat_deg)", 0.0, 100.0),
    Param("accel_noise_ug_rt_hz", 50.0, "accelerometer white-noise density, sets R [micro-g/sqrt(Hz)]", 1e-6, INF),
    Param("block_s", 1.0, "accelerometer averaging block per RLS update [s]", 1e-6, 1e6),
    Param("tilt_scale_arcsec", 600.0, "a-priori size of the initial tilts (P0 = I in these units) [arcsec]",
          1e-6, INF),
    Param("azimuth_scale_deg", 2.0, "a-priori size of the initial azimuth error [deg]", 1e-9, INF),
    Param("north_drift_scale_deg_h", 0.1, "a-priori size of the north drift [deg/h]", 1e-9, INF),
    Param("accel_bias_scale_ug", 1000.0, "a-priori size of the level accelerometer biases [micro-g]", 1e-9, INF),
    Param("gyro_drift_scale_deg_h", 0.1, "a-priori size of the level gyro drifts [deg/h]", 1e-9, INF),
    Param("max_joint_age_s", 0.1, "largest gap [s] between an accelerometer sample and the joint sample "
          "extrapolated to it", 1e-9, INF),
    Param("converged_tilt_arcsec", 5.0, "tilt sigma below which the estimate counts as converged [arcsec]",
          1e-9, INF),
    Param("converged_azimuth_arcmin", 2.0, "azimuth sigma below which it counts as converged [arcmin]", 1e-9, INF),
    Param("clock_jump_s", 1.0, "a stamp this far before the last one restarts the alignment [s]", 1e-9, INF,
          aliases=CLOCK_JUMP_ALIASES),
    Param("max_sync_wait_s", 0.05, "free timing: longest a sample waits for the other stream's stamp to pass "
          "it (stamp order) [s]", 0.0, 10.0),
    Param("diagnostics_period_s", 1.0, "free timing: counters and NIS on /diagnostics every this much stamp "
          "time [s]", 1e-3, 1e6),
    Param("nis_window", 50, "free timing: block updates in the NIS window on /diagnostics", 1, 10**6),
    Param("progress_every_steps", 10, "report on ~/progress (time of the next step needed) every N steps; "
          "vehicle_dynamics waits for and paces on it", 1, 10**6),
    Param("wait_for_subscribers", 0, "matched subscriptions each output needs before ~/progress reports ready",
          0, 1000),
)
