"""The ``los_rate_controller`` node's parameters and --help text, declared once in
:class:`LosRateControllerNodeParams`.
"""
from __future__ import annotations

from dataclasses import dataclass

from gimbal_kinematics.params.table import SHARED, CommandingParams, declaration, param, same_as

#: The node's input policy: a stamp more than this [s] before the last one (a bag loop)
#: restarts the controller; a smaller step back is dropped. Not a parameter: no run sets it.
CLOCK_JUMP_S = 0.5


@dataclass(frozen=True)
class LosRateControllerNodeParams(CommandingParams):
    """Paper 1 LOS rate stabilization controller: dynamic inversion of the linearized gimbal and a PI on the
    inertial LOS rate error (k_p = 2 zeta omega_n, k_i = omega_n^2), torque saturation with anti-windup,
    optional gyro-bias feedback. Publishes /gimbal/torque_cmd for each step.
    """

    sim_rate_hz: float = param(1000.0, "lockstep rate; the controller runs once per step. In free timing: the gyro's "
        "nominal rate (the integrator's nominal step, the drop count)", 1.0, 100000.0, unit="Hz")
    max_input_age_s: float = param(0.1, "free timing: the newest encoder and INS samples may be this much older than "
        "the gyro sample; older (or none): the command is zeroed, counted", 1e-4, 100.0, unit="s")
    max_estimate_age_s: float = param(0.5, "free timing: the same for the EKF's bias and attitude estimates",
        1e-4, 100.0, unit="s")
    diagnostics_period_s: float = same_as(SHARED["diagnostics_period_s"])
    ins_rate_hz: float = param(100.0, "INS output rate (the controller waits for it at its steps)",
        1e-3, 100000.0, unit="Hz")
    omega_n_hz: float = param(25.0, "closed-loop natural frequency omega_n (< sim_rate_hz / 4)",
        1e-3, 25000.0, unit="Hz")
    zeta: float = param(0.8, "damping ratio zeta", 1e-3, 10.0, unit="-")
    feedback: bool = param(False, "subtract the gyro-bias estimate from the gyro rates (waits for it at INS steps)")
    bias_topic: str = param("/gyro_bias_ekf/bias", "gyro-bias estimate topic (geometry_msgs/Vector3Stamped) [rad/s]")
    mode: str = param("rate", "rate: paper 1's LOS rate loop; los_hold: plus an outer loop holding the LOS at its "
        "initial inertial direction on the EKF attitude estimate (implies feedback)", choices=("rate", "los_hold"))
    attitude_topic: str = param("/gyro_bias_ekf/attitude", "EKF attitude estimate C(n,m) (sensor_msgs/Imu) for "
        "los_hold")
    hold_gain_1_s: float = param(0.5, "los_hold outer-loop gain (bandwidth)", 1e-6, 1e3, unit="1/s")
    hold_max_rate_deg_s: float = param(1.0, "los_hold rate command limit", 1e-6, 1e3, unit="deg/s")
    hold_capture_s: float = param(5.0, "los_hold: capture the initial LOS this long after the first estimate",
        0.0, 1e4, unit="s")
    lat_deg: float = param(0.0, "site latitude (earth rate of the los_hold inertial target)",
        -89.999, 89.999, unit="deg")
    earth_rate: bool = param(True, "los_hold: the inertial target turns with the earth as seen from NED")
    anti_windup: str = param("clamp", "integrator anti-windup", choices=("clamp", "conditional", "none"))
    integrator_limit_factor: float = param(4.0, "clamp bound of the integral term, in torque limits",
        1e-3, 1e3, unit="-")
    trim: bool = param(True, "feed forward the gravity trim torque of the linearisation point")
    operator_topic: str = param("/operator/los_rate", "operator LOS rate command (geometry_msgs/Vector3Stamped, "
        "sight frame, rad/s: y = elevation q, z = azimuth r), shaped and added to the stabilisation reference; '' = "
        "off")
    operator_rate_hz: float = param(0.0, "lockstep: the operator's publish rate; each of its steps waits for its "
        "command (a deterministic run). 0: not waited for, used as it arrives (free timing: always)",
        0.0, 100000.0, unit="Hz")
    operator_max_rate_deg_s: float = param(10.0, "operator command: largest rate per axis; above: rejected, counted",
        1e-6, 1e3, unit="deg/s")
    operator_max_accel_deg_s2: float = param(100.0, "operator command: acceleration limit per axis",
        1e-6, 1e6, unit="deg/s^2")
    operator_timeout_s: float = param(0.5, "operator dead-man: a command older than this stops the slew, counted",
        1e-3, 100.0, unit="s")
    joy_topic: str = param("", "sensor_msgs/Joy input (joy_node's /joy), mapped like teleop_twist_joy; '' = off")
    joy_scale_rad_s: float = param(0.0, "LOS rate at full stick deflection (<= the operator rate limit); 0: the rate "
        "limit", 0.0, 100.0, unit="rad/s")
    joy_azimuth_axis: int = param(0, "Joy axes index of the azimuth stick", 0, 63)
    joy_elevation_axis: int = param(1, "Joy axes index of the elevation stick", 0, 63)
    joy_invert_azimuth: bool = param(True, "flip the azimuth axis (joy_node: stick left = +1; FRD: left is -r)")
    joy_invert_elevation: bool = param(False, "flip the elevation axis (joy_node: stick up = +1 raises the LOS)")


PARAMS, DESCRIPTION = declaration(LosRateControllerNodeParams)
