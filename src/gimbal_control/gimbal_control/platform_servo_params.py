"""The ``platform_servo`` node's parameter table and --help text, readable without ROS (the
node declares them; the config generator and the scenario checks read them). The mapping to
the core's parameters is :meth:`.platform_servo.PlatformServoParams.from_values`.
"""
from __future__ import annotations

from gimbal_kinematics.params import (
    CLOCK_JUMP_ALIASES, COMMAND_INTERFACE_PARAM, ROS2_CONTROL_TOPIC_PARAM, TIMING_PARAM, Param,
)

DESCRIPTION = (
    "Paper 3 four-gimbal platform servo: four PID loops (azimuth, inner roll, pitch, outer roll) on the "
    "emulated gyro pickoffs resolved through the gimbal angles (eq. 1), outer roll holding the inner roll "
    "at null, bidirectional azimuth modulation at +-1.2 deg/s with the integrator preset at reversals. "
    "Publishes /platform/voltage_cmd for each step."
)
INF = float("inf")

PARAMS = (
    TIMING_PARAM,
    COMMAND_INTERFACE_PARAM,
    ROS2_CONTROL_TOPIC_PARAM,
    Param("sim_rate_hz", 1000.0, "lockstep rate [Hz]; one command per step. In free timing: the platform gyro's "
          "nominal rate (the drop count)", 1.0, 100000.0),
    Param("max_input_age_s", 0.1, "free timing: the newest resolver sample may be this much older than the gyro "
          "sample [s]; older (or none): the command is zeroed, counted", 1e-4, 100.0),
    Param("diagnostics_period_s", 1.0, "free timing: /diagnostics with the counters every this much stamp time [s]",
          1e-3, 3600.0),
    Param("imu_rate_hz", 1000.0, "platform gyro rate [Hz] = the control rate (paper 3: 1 kHz); divides sim_rate_hz",
          1e-3, 100000.0),
    Param("resolver_rate_hz", 1000.0, "gimbal resolver rate [Hz]; divides sim_rate_hz", 1e-3, 100000.0),
    Param("lat_deg", 45.0, "site latitude for the earth-rate part of the command [deg]", -89.999, 89.999),
    Param("rotation", "bidirectional", "azimuth modulation: bidirectional (out through sweep_deg and back) "
          "or off (hold phi_z = 0)", choices=("bidirectional", "off")),
    Param("rate_deg_s", 1.2, "modulation rate [deg/s] (paper 3: 1.2)", 1e-6, 1000.0),
    Param("sweep_deg", 360.0, "sweep of one leg between reversals [deg]", 1e-6, 1e6),
    Param("reversal_time_s", 0.0, "duration of a reversal ramp [s] (0: instantaneous)", 0.0, 1e6),
    Param("azimuth_bandwidth_hz", 12.0, "azimuth loop pole-placement bandwidth (triple pole) [Hz]", 1e-3, 10000.0),
    Param("level_bandwidth_hz", 12.0, "inner-roll and pitch loop bandwidth (triple pole) [Hz]", 1e-3, 10000.0),
    Param("outer_roll_bandwidth_hz", 4.0, "outer-roll null loop bandwidth (triple pole) [Hz]", 1e-3, 10000.0),
    Param("outer_roll_derivative_tau_s", 0.005, "low-pass time constant of the outer-roll D term [s]", 0.0, 10.0),
    Param("preset_integrator", True, "preset the azimuth integrator at each reversal (paper 3)"),
    Param("friction_coulomb_nm", 0.01, "azimuth bearing Coulomb friction for the preset [N*m]", 0.0, INF),
    Param("friction_viscous_nm_s_rad", 5e-4, "azimuth bearing viscous friction for the preset [N*m*s/rad]", 0.0, INF),
    Param("friction_smoothing_rad_s", 0.01, "rate scale of the Coulomb tanh for the preset [rad/s]", 1e-9, INF),
    Param("drift_deg_h", [0.0, 0.0, 0.0], "platform drift estimate (the negative of the gyro rate bias, as "
          "platform_alignment's ~/gyro_drift) subtracted from the command, platform x, y, z [deg/h]"),
    Param("command_source", "internal", "level command rate: internal (earth rate at lat_deg minus drift_deg_h) "
          "or navigator (the platform_navigator's ~/command_rate, NED; lat_deg and drift_deg_h then serve "
          "only before its first command and when it is stale)", choices=("internal", "navigator")),
    Param("command_max_age_s", 0.5, "navigator: a command older than this at a tick gives way to the internal "
          "one, counted [s]", 1e-6, INF),
    Param("max_gap_s", 0.05, "a longer gap between gyro samples restarts the pickoff integration [s]", 1e-6, INF),
    Param("clock_jump_s", 1.0, "a stamp this far before the last one restarts the servo (bag loop) [s]", 1e-6, INF,
          aliases=CLOCK_JUMP_ALIASES),
    Param("diagnostics_every_steps", 1, "publish ~/control_error and ~/modulation every N control ticks", 1, 10**6),
)
