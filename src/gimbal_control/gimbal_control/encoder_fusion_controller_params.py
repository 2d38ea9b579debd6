"""The ``encoder_fusion_controller`` node's parameter table and --help text, readable
without ROS (the node declares them; the config generator and the scenario checks read
them). The mapping to the core's parameters is
:meth:`.encoder_fusion.EncoderFusionParams.from_values`.
"""
from __future__ import annotations

from gimbal_kinematics.params import (
    CLOCK_JUMP_ALIASES, COMMAND_INTERFACE_PARAM, ROS2_CONTROL_TOPIC_PARAM, TIMING_PARAM, Param,
)

from .encoder_fusion import (
    ENCODER_LOOP_BANDWIDTH_HZ, LOOP_BANDWIDTH_HZ, MODES, TORQUE_LIMIT_NM, UAV_AZIMUTH_INERTIA_KG_M2,
    UAV_ELEVATION_INERTIA_KG_M2, EncoderFusionParams,
)
from .fusion_kf import FusionKfParams

DESCRIPTION = (
    "Paper 2 two-axis gimbal stabilization: a PID per axis whose feedback velocity is the encoder "
    "pulse-count rate (mode encoder), the raw MEMS gyro (gyro) or the gyro corrected by the "
    "closed-loop complementary Kalman filter on encoder-minus-gyro (fused). Publishes "
    "/gimbal/torque_cmd for each step, plus ~/feedback_velocity and ~/drift_correction."
)
INF = float("inf")
_KF = FusionKfParams()
_CORE = EncoderFusionParams()

PARAMS = (
    Param("mode", "fused", "feedback velocity: encoder (pulse-count rate), gyro (raw MEMS gyro) or fused "
          "(gyro corrected by the complementary KF)", choices=MODES),
    TIMING_PARAM,
    COMMAND_INTERFACE_PARAM,
    ROS2_CONTROL_TOPIC_PARAM,
    Param("sim_rate_hz", 1000.0, "lockstep rate [Hz]; the controller runs once per step on the gyro sample. In "
          "free timing: the gyro's nominal rate (the drop count)", 1.0, 100000.0),
    Param("max_input_age_s", 0.1, "free timing: the newest encoder and base-rate samples may be this much older than the gyro "
          "sample [s]; older (or none): the command is zeroed, counted", 1e-4, 100.0),
    Param("diagnostics_period_s", 1.0, "free timing: /diagnostics with the counters every this much stamp time [s]",
          1e-3, 3600.0),
    Param("encoder_rate_hz", 1000.0, "encoder output rate [Hz] (must divide sim_rate_hz)", 1e-3, 100000.0),
    Param("base_rate_hz", 1000.0, "UAV autopilot body-rate output rate [Hz] (must divide sim_rate_hz)",
          1e-3, 100000.0),
    Param("encoder_gate_s", _CORE.encoder_gate_s, "pulse-count gate T_g of the encoder velocity and of the "
          "filter updates [s] (paper 2 eq. 1: 1024 lines and 0.2 s give ~2 deg/s resolution)", 1e-4, 100.0),
    Param("loop_bandwidth_hz", LOOP_BANDWIDTH_HZ, "triple-pole bandwidth of the gyro/fused PID loops [Hz] "
          "(at most sim_rate_hz / 25)", 1e-3, 4000.0),
    Param("encoder_loop_bandwidth_hz", ENCODER_LOOP_BANDWIDTH_HZ, "triple-pole bandwidth of the encoder-mode "
          "PID loops [Hz] (the pulse-count velocity lags ~encoder_gate_s: keep it slow)", 1e-3, 4000.0),
    Param("azimuth_inertia_kg_m2", UAV_AZIMUTH_INERTIA_KG_M2, "azimuth-loop inertia the gains are placed for "
          "[kg m^2]", 1e-9, 1e4),
    Param("elevation_inertia_kg_m2", UAV_ELEVATION_INERTIA_KG_M2, "elevation-loop inertia the gains are "
          "placed for [kg m^2]", 1e-9, 1e4),
    Param("torque_limit_nm", TORQUE_LIMIT_NM, "PID output clip (anti-windup by conditional integration) "
          "[N m]", 1e-9, 1e6),
    Param("derivative_tau_s", 0.0, "low-pass time constant of the PID's measured-rate D term [s] (0: none)",
          0.0, 10.0),
    Param("min_cos_elevation", _CORE.min_cos_elevation, "floor of cos(theta_m) in tau_a = u_r / cos(theta_m) [-]",
          1e-3, 1.0),
    Param("max_gap_s", _CORE.max_gap_s, "a longer gap between gyro samples restarts the gate and D term [s]",
          1e-6, 1e3),
    Param("clock_jump_s", _CORE.clock_jump_s, "a stamp this far behind the last resets the controller "
          "(bag loop) [s]", 1e-6, 1e6, aliases=CLOCK_JUMP_ALIASES),
    Param("kf_q_angle_deg_rt_s", _KF.q_angle_deg_rt_s, "KF Q: gyro angle-random-walk density [deg/sqrt(s)]",
          0.0, 1e3),
    Param("kf_q_scale_rt_s", _KF.q_scale_rt_s, "KF Q: scale-factor random-walk density [1/sqrt(s)]", 0.0, 1e3),
    Param("kf_q_drift_deg_s_rt_s", _KF.q_drift_deg_s_rt_s, "KF Q: gyro drift random-walk density "
          "[deg/s/sqrt(s)]", 0.0, 1e3),
    Param("kf_r_deg", _KF.r_deg, "KF R: sigma of z, the encoder-minus-gyro angle over a gate [deg]", 1e-9, 1e3),
    Param("kf_p0_angle_deg", _KF.p0_angle_deg, "KF initial sigma of the angle error [deg]", 1e-9, 1e3),
    Param("kf_p0_scale", _KF.p0_scale, "KF initial sigma of the scale-factor error [-]", 1e-9, 10.0),
    Param("kf_p0_drift_deg_s", _KF.p0_drift_deg_s, "KF initial sigma of the gyro drift [deg/s]", 1e-9, 1e3),
    Param("kf_gate_sigma", 0.0, "KF innovation gate [sigma] (0: no gate)", 0.0, 1e3),
)
