"""The ``encoder_fusion_controller`` node's parameters and --help text, declared once in
:class:`EncoderFusionControllerNodeParams`. The mapping to the core's parameters is
:meth:`.encoder_fusion.EncoderFusionParams.from_values`.
"""
from __future__ import annotations

from dataclasses import dataclass

from gimbal_kinematics.params.table import CLOCK_JUMP_ALIASES, SHARED, CommandingParams, declaration, param, same_as

from .encoder_fusion import (
    ENCODER_LOOP_BANDWIDTH_HZ, LOOP_BANDWIDTH_HZ, MODES, TORQUE_LIMIT_NM, UAV_AZIMUTH_INERTIA_KG_M2,
    UAV_ELEVATION_INERTIA_KG_M2, EncoderFusionParams,
)
from .fusion_kf import FusionKfParams

INF = float("inf")
_KF = FusionKfParams()
_CORE = EncoderFusionParams()


@dataclass(frozen=True)
class EncoderFusionControllerNodeParams(CommandingParams):
    """Paper 2 two-axis gimbal stabilization: a PID per axis whose feedback velocity is the encoder pulse-count
    rate (mode encoder), the raw MEMS gyro (gyro) or the gyro corrected by the closed-loop complementary Kalman
    filter on encoder-minus-gyro (fused). Publishes /gimbal/torque_cmd for each step, plus ~/feedback_velocity
    and ~/drift_correction.
    """

    mode: str = param("fused", "feedback velocity: encoder (pulse-count rate), gyro (raw MEMS gyro) or fused (gyro "
        "corrected by the complementary KF)", choices=MODES)
    sim_rate_hz: float = param(1000.0, "lockstep rate; the controller runs once per step on the gyro sample. In free "
        "timing: the gyro's nominal rate (the drop count)", 1.0, 100000.0, unit="Hz")
    max_input_age_s: float = param(0.1, "free timing: the newest encoder and base-rate samples may be this much "
        "older than the gyro sample; older (or none): the command is zeroed, counted", 1e-4, 100.0, unit="s")
    diagnostics_period_s: float = same_as(SHARED["diagnostics_period_s"])
    encoder_rate_hz: float = param(1000.0, "encoder output rate (must divide sim_rate_hz)", 1e-3, 100000.0, unit="Hz")
    base_rate_hz: float = param(1000.0, "UAV autopilot body-rate output rate (must divide sim_rate_hz)",
        1e-3, 100000.0, unit="Hz")
    encoder_gate_s: float = param(_CORE.encoder_gate_s, "pulse-count gate T_g of the encoder velocity and of the "
        "filter updates (paper 2 eq. 1: 1024 lines and 0.2 s give ~2 deg/s resolution)", 1e-4, 100.0, unit="s")
    loop_bandwidth_hz: float = param(LOOP_BANDWIDTH_HZ, "triple-pole bandwidth of the gyro/fused PID loops (at most "
        "sim_rate_hz / 25)", 1e-3, 4000.0, unit="Hz")
    encoder_loop_bandwidth_hz: float = param(ENCODER_LOOP_BANDWIDTH_HZ, "triple-pole bandwidth of the encoder-mode "
        "PID loops (the pulse-count velocity lags ~encoder_gate_s: keep it slow)", 1e-3, 4000.0, unit="Hz")
    azimuth_inertia_kg_m2: float = param(UAV_AZIMUTH_INERTIA_KG_M2, "azimuth-loop inertia the gains are placed for",
        1e-9, 1e4, unit="kg m^2")
    elevation_inertia_kg_m2: float = param(UAV_ELEVATION_INERTIA_KG_M2, "elevation-loop inertia the gains are placed "
        "for", 1e-9, 1e4, unit="kg m^2")
    torque_limit_nm: float = param(TORQUE_LIMIT_NM, "PID output clip (anti-windup by conditional integration)",
        1e-9, 1e6, unit="N m")
    derivative_tau_s: float = param(0.0, "low-pass time constant of the PID's measured-rate D term (0: none)",
        0.0, 10.0, unit="s")
    min_cos_elevation: float = param(_CORE.min_cos_elevation, "floor of cos(theta_m) in tau_a = u_r / cos(theta_m)",
        1e-3, 1.0, unit="-")
    max_gap_s: float = param(_CORE.max_gap_s, "a longer gap between gyro samples restarts the gate and D term",
        1e-6, 1e3, unit="s")
    clock_jump_s: float = param(1.0, "a stamp this far behind the last resets the controller (bag "
        "loop)", 1e-6, 1e6, unit="s", aliases=CLOCK_JUMP_ALIASES)
    kf_q_angle_deg_rt_s: float = param(_KF.q_angle_deg_rt_s, "KF Q: gyro angle-random-walk density",
        0.0, 1e3, unit="deg/sqrt(s)")
    kf_q_scale_rt_s: float = param(_KF.q_scale_rt_s, "KF Q: scale-factor random-walk density",
        0.0, 1e3, unit="1/sqrt(s)")
    kf_q_drift_deg_s_rt_s: float = param(_KF.q_drift_deg_s_rt_s, "KF Q: gyro drift random-walk density",
        0.0, 1e3, unit="deg/s/sqrt(s)")
    kf_r_deg: float = param(_KF.r_deg, "KF R: sigma of z, the encoder-minus-gyro angle over a gate",
        1e-9, 1e3, unit="deg")
    kf_p0_angle_deg: float = param(_KF.p0_angle_deg, "KF initial sigma of the angle error", 1e-9, 1e3, unit="deg")
    kf_p0_scale: float = param(_KF.p0_scale, "KF initial sigma of the scale-factor error", 1e-9, 10.0, unit="-")
    kf_p0_drift_deg_s: float = param(_KF.p0_drift_deg_s, "KF initial sigma of the gyro drift",
        1e-9, 1e3, unit="deg/s")
    kf_gate_sigma: float = param(0.0, "KF innovation gate (0: no gate)", 0.0, 1e3, unit="sigma")


PARAMS, DESCRIPTION = declaration(EncoderFusionControllerNodeParams)
