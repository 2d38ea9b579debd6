"""The ``los_rate_controller`` node's parameter table and --help text, readable without ROS
(the node declares them; the config generator and the scenario checks read them). The
mappings to the cores' parameters are
:meth:`.los_rate_controller.LosRateControllerParams.from_values` and
:meth:`.los_hold.LosHoldParams.from_values`.
"""
from __future__ import annotations

from gimbal_kinematics.params import COMMAND_INTERFACE_PARAM, ROS2_CONTROL_TOPIC_PARAM, TIMING_PARAM, Param

DESCRIPTION = (
    "Paper 1 LOS rate stabilization controller: dynamic inversion of the linearized gimbal and a PI "
    "on the inertial LOS rate error (k_p = 2 zeta omega_n, k_i = omega_n^2), torque saturation with "
    "anti-windup, optional gyro-bias feedback. Publishes /gimbal/torque_cmd for each step."
)
PARAMS = (
    TIMING_PARAM,
    COMMAND_INTERFACE_PARAM,
    ROS2_CONTROL_TOPIC_PARAM,
    Param("sim_rate_hz", 1000.0, "lockstep rate [Hz]; the controller runs once per step. In free timing: the gyro's "
          "nominal rate (the integrator's nominal step, the drop count)", 1.0, 100000.0),
    Param("max_input_age_s", 0.1, "free timing: the newest encoder and INS samples may be this much older than the "
          "gyro sample [s]; older (or none): the command is zeroed, counted", 1e-4, 100.0),
    Param("max_estimate_age_s", 0.5, "free timing: the same for the EKF's bias and attitude estimates [s]",
          1e-4, 100.0),
    Param("diagnostics_period_s", 1.0, "free timing: /diagnostics with the counters every this much stamp time [s]",
          1e-3, 3600.0),
    Param("ins_rate_hz", 100.0, "INS output rate [Hz] (the controller waits for it at its steps)", 1e-3, 100000.0),
    Param("omega_n_hz", 25.0, "closed-loop natural frequency omega_n [Hz] (< sim_rate_hz / 4)", 1e-3, 25000.0),
    Param("zeta", 0.8, "damping ratio zeta [-]", 1e-3, 10.0),
    Param("feedback", False, "subtract the gyro-bias estimate from the gyro rates (waits for it at INS steps)"),
    Param("bias_topic", "/gyro_bias_ekf/bias", "gyro-bias estimate topic (geometry_msgs/Vector3Stamped) [rad/s]"),
    Param("mode", "rate", "rate: paper 1's LOS rate loop; los_hold: plus an outer loop holding the LOS at its "
          "initial inertial direction on the EKF attitude estimate (implies feedback)", choices=("rate", "los_hold")),
    Param("attitude_topic", "/gyro_bias_ekf/attitude", "EKF attitude estimate C(n,m) (sensor_msgs/Imu) for los_hold"),
    Param("hold_gain_1_s", 0.5, "los_hold outer-loop gain (bandwidth) [1/s]", 1e-6, 1e3),
    Param("hold_max_rate_deg_s", 1.0, "los_hold rate command limit [deg/s]", 1e-6, 1e3),
    Param("hold_capture_s", 5.0, "los_hold: capture the initial LOS this long after the first estimate [s]", 0.0, 1e4),
    Param("lat_deg", 0.0, "site latitude [deg] (earth rate of the los_hold inertial target)", -89.999, 89.999),
    Param("earth_rate", True, "los_hold: the inertial target turns with the earth as seen from NED"),
    Param("anti_windup", "clamp", "integrator anti-windup", choices=("clamp", "conditional", "none")),
    Param("integrator_limit_factor", 4.0, "clamp bound of the integral term, in torque limits [-]", 1e-3, 1e3),
    Param("trim", True, "feed forward the gravity trim torque of the linearisation point"),
    Param("operator_topic", "/operator/los_rate", "operator LOS rate command (geometry_msgs/Vector3Stamped, sight "
          "frame, rad/s: y = elevation q, z = azimuth r), shaped and added to the stabilisation reference; "
          "'' = off"),
    Param("operator_rate_hz", 0.0, "lockstep: the operator's publish rate [Hz]; each of its steps waits for its "
          "command (a deterministic run). 0: not waited for, used as it arrives (free timing: always)",
          0.0, 100000.0),
    Param("operator_max_rate_deg_s", 10.0, "operator command: largest rate per axis [deg/s]; above: rejected, "
          "counted", 1e-6, 1e3),
    Param("operator_max_accel_deg_s2", 100.0, "operator command: acceleration limit per axis [deg/s^2]",
          1e-6, 1e6),
    Param("operator_timeout_s", 0.5, "operator dead-man: a command older than this stops the slew, counted [s]",
          1e-3, 100.0),
    Param("joy_topic", "", "sensor_msgs/Joy input (joy_node's /joy), mapped like teleop_twist_joy; '' = off"),
    Param("joy_scale_rad_s", 0.0, "LOS rate at full stick deflection [rad/s] (<= the operator rate limit); "
          "0: the rate limit", 0.0, 100.0),
    Param("joy_azimuth_axis", 0, "Joy axes index of the azimuth stick", 0, 63),
    Param("joy_elevation_axis", 1, "Joy axes index of the elevation stick", 0, 63),
    Param("joy_invert_azimuth", True, "flip the azimuth axis (joy_node: stick left = +1; FRD: left is -r)"),
    Param("joy_invert_elevation", False, "flip the elevation axis (joy_node: stick up = +1 raises the LOS)"),
)
