"""Paper 2: discrete PID against closed forms, the closed-loop complementary KF against the
DARE and synthetic truth, and the encoder/gyro/fused stabilization comparison on the
simulated UAV gimbal (reduced duration; the full figures come from run_encoder_fusion)."""
import math

import numpy as np
import pytest
from scipy import signal
from scipy.linalg import solve_discrete_are

from gimbal_control.encoder_fusion import (
    UAV_AZIMUTH_INERTIA_KG_M2, UAV_ELEVATION_INERTIA_KG_M2, EncoderFusionController, EncoderFusionParams,
)
from gimbal_control.fusion_kf import ClosedLoopComplementaryKf, FusionKfParams, process_noise, transition
from gimbal_control.pid import Pid, PidParams, pole_placement_gains
from gimbal_control.encoder_fusion_controller_params import PARAMS as EFC_PARAMS
from gimbal_kinematics.params.table import defaults
from gimbal_sim.experiments.encoder_fusion import MEMS_GYRO, UAV_GIMBAL, UAV_INITIAL_JOINTS_DEG, run_encoder_fusion
from gimbal_sim.world.plant import TwoAxisGimbal

DEG = math.pi / 180.0


# ---------------------------------------------------------------------------- PID
def test_pid_step_response_is_exact_at_the_samples():
    """Unit error step: u(t_k) = k_p + k_i t_k + (k_d/τ) exp(−t_k/τ) (step-invariant form)."""
    p = PidParams(kp=2.0, ki=5.0, kd=0.3, derivative_tau_s=0.02)
    pid, dt = Pid(p), 1e-3
    for k in range(300):
        u = pid.step(1.0, dt)
        t = k * dt
        assert u == pytest.approx(2.0 + 5.0 * t + 0.3 / 0.02 * math.exp(-t / 0.02), rel=1e-12, abs=1e-12)


def test_pid_angle_loop_matches_continuous_pole_placement():
    """PID on the angle with D from the rate, on J θ̈ = u, sampled at 10 kHz: the step
    response follows (3ω² s + ω³)/(s + ω)³ from scipy within 1 % of the step."""
    J, bw = 8e-4, 5.0
    p = pole_placement_gains(J, bw)
    w = 2 * math.pi * bw
    assert (p.kd, p.kp, p.ki) == pytest.approx((3 * w * J, 3 * w * w * J, w ** 3 * J))
    dt, n = 1e-4, 6000
    pid = Pid(p)
    th = om = 0.0
    out = np.zeros(n)
    for k in range(n):
        out[k] = th
        u = pid.step(1.0 - th, dt, error_rate=-om)
        # exact ZOH step of the double integrator
        th, om = th + om * dt + 0.5 * u / J * dt * dt, om + u / J * dt
    t_ref, y_ref = signal.step(([3 * w * w, w ** 3], np.poly([-w, -w, -w])), T=np.arange(n) * dt)
    assert np.max(np.abs(out - y_ref)) < 0.01


def test_pid_anti_windup_holds_the_integrator_while_clipped():
    pid = Pid(PidParams(kp=1.0, ki=10.0, output_limit=2.0))
    for _ in range(1000):
        pid.step(5.0, 1e-3)
    assert pid.saturated and pid.output == 2.0
    # without conditional integration the integrator would be at 10·5·1 = 50
    assert pid.integral < 1.0
    assert pid.step(-1.0, 1e-3) < 0.0  # recovers at once when the error reverses


def test_pid_refuses_bad_gains():
    for kwargs, name in (({"kp": -1.0}, "kp"), ({"kp": 1.0, "ki": math.nan}, "ki"),
                         ({"kp": 1.0, "output_limit": 0.0}, "output_limit"),
                         ({"kp": 1.0, "derivative_tau_s": -0.1}, "derivative_tau_s"), ({}, "kp")):
        with pytest.raises(ValueError, match=name):
            PidParams(**kwargs)


# ---------------------------------------------------------------------------- KF
def test_kf_gain_converges_to_the_dare_solution():
    """Δψ_g = 0 decouples the scale state; the (angle, drift) pair must reach the steady
    gain of the discrete algebraic Riccati equation."""
    params = FusionKfParams(q_scale_rt_s=0.0)
    kf = ClosedLoopComplementaryKf(params)
    T = 0.2
    for _ in range(3000):
        kf.predict(T, 0.0)
        kf.update(0.0)
    K = kf.kalman_gain(T)
    Q = process_noise(T, params.q_density)
    idx = np.ix_([0, 2], [0, 2])
    A = transition(T, 0.0)[idx]
    H = np.array([[1.0, 0.0]])
    P = solve_discrete_are(A.T, H.T, Q[idx], np.array([[params.r_rad2]]))
    K_ref = P @ H.T / (P[0, 0] + params.r_rad2)
    assert K[0] == pytest.approx(K_ref[0, 0], rel=1e-8)
    assert K[2] == pytest.approx(K_ref[1, 0], rel=1e-8)
    assert K[1] == 0.0


def test_joseph_covariance_stays_symmetric_positive_definite():
    rng = np.random.default_rng(4)
    kf = ClosedLoopComplementaryKf(FusionKfParams(r_deg=1e-4, p0_drift_deg_s=50.0))
    for _ in range(2000):
        kf.predict(rng.uniform(1e-3, 0.5), rng.normal(0.0, 0.5))
        kf.update(rng.normal(0.0, 1e-3))
        assert np.array_equal(kf.P, kf.P.T)
        assert np.linalg.eigvalsh(kf.P)[0] > 0.0


def _synthetic_fusion(bias, bias_rate, scale, amp_deg, seconds, seed):
    """The fused controller fed by a moving joint (no base motion): quantised encoder angle,
    a gyro with bias b0 + ḃ t, scale error and white noise. Returns the controller and the
    final true bias."""
    rng = np.random.default_rng(seed)
    ctl = EncoderFusionController(EncoderFusionParams(mode="fused"))
    delta = 2 * math.pi / 1024
    dt = 1e-3
    w1, w2 = 2 * math.pi * 0.7, 2 * math.pi * 0.23
    a = amp_deg * DEG
    for k in range(int(seconds / dt)):
        t = k * dt
        theta = -0.3 + a * math.sin(w1 * t) + 0.5 * a * math.sin(w2 * t + 1.0)
        rate = a * w1 * math.cos(w1 * t) + 0.5 * a * w2 * math.cos(w2 * t + 1.0)
        b = bias + bias_rate * t
        ctl.on_base_rates(t, (0.0, 0.0, 0.0))
        ctl.on_encoders(t, 0.0, delta * math.floor(theta / delta + 0.5))
        ctl.on_gyro(t, (1 + scale) * rate + b + 2e-4 * rng.standard_normal(), 0.0)
    return ctl, bias + bias_rate * seconds


def test_filter_drives_the_drift_state_to_the_true_drift():
    """Constant bias plus a ramp: the accumulated drift correction E reaches −b(t)."""
    ctl, b_end = _synthetic_fusion(0.12 * DEG, 0.001 * DEG, 0.0, 5.0, 60.0, seed=1)
    assert ctl.kf_q.drift_correction == pytest.approx(-b_end, rel=0.03)
    # the estimated velocity no longer carries the bias: ω̂ − ω = E + b → 0
    assert abs(ctl.kf_q.drift_correction + b_end) < 0.03 * b_end


def test_filter_observes_the_scale_factor_under_motion():
    ctl, b_end = _synthetic_fusion(0.05 * DEG, 0.0, 0.01, 30.0, 60.0, seed=2)
    assert ctl.kf_q.scale_correction == pytest.approx(-0.01, rel=0.2)
    assert ctl.kf_q.drift_correction == pytest.approx(-b_end, rel=0.1)


def test_kf_params_refuse_bad_values():
    for kwargs, name in (({"r_deg": 0.0}, "r_deg"), ({"q_drift_deg_s_rt_s": -1.0}, "q_drift_deg_s_rt_s"),
                         ({"p0_scale": math.inf}, "p0_scale"), ({"gate_sigma": 0.0}, "gate_sigma")):
        with pytest.raises(ValueError, match=name):
            FusionKfParams(**kwargs)


# ---------------------------------------------------------------------------- controller
def test_default_gains_use_the_uav_gimbal_inertias():
    M = TwoAxisGimbal(UAV_GIMBAL).mass_matrix(UAV_INITIAL_JOINTS_DEG[1] * DEG)
    assert UAV_AZIMUTH_INERTIA_KG_M2 == pytest.approx(M[0, 0], rel=0.01)
    assert UAV_ELEVATION_INERTIA_KG_M2 == pytest.approx(M[1, 1], rel=0.01)
    assert 0.9 < UAV_GIMBAL.outer_mass_kg + UAV_GIMBAL.inner_mass_kg < 1.1


def test_controller_params_refuse_bad_values():
    for kwargs, name in (({"mode": "magic"}, "mode"), ({"encoder_gate_s": 0.0}, "encoder_gate_s"),
                         ({"min_cos_elevation": 1.5}, "min_cos_elevation"),
                         ({"azimuth_pid": "fast"}, "azimuth_pid"), ({"max_gap_s": -1.0}, "max_gap_s")):
        with pytest.raises(ValueError, match=name):
            EncoderFusionParams(**kwargs)


def test_bad_input_is_counted_and_the_command_held():
    ctl = EncoderFusionController()
    ctl.on_base_rates(0.0, (0.0, 0.0, 0.0))
    ctl.on_encoders(0.0, 0.0, -0.3)
    first = ctl.on_gyro(0.0, 0.01, 0.0)
    ctl.on_base_rates(0.001, (0.0, 0.0, 0.0))
    ctl.on_encoders(0.001, 0.0, -0.3)
    second = ctl.on_gyro(0.001, 0.01, 0.0)
    held = ctl.on_gyro(0.002, math.nan, 0.0)
    assert held.held and (held.torque_azimuth, held.torque_elevation) == (second.torque_azimuth, second.torque_elevation)
    assert first is not None and not second.held
    ctl.on_encoders(0.002, math.inf, -0.3)
    assert ctl.rejected_nonfinite == 2 and ctl.held_commands == 1


def test_late_stamps_are_dropped_and_a_clock_jump_resets_through_the_lockstep_policy():
    """The node's lockstep policy (eager steps, as the node builds it) is where stamps are
    judged: a repeated or late step of a stream never reaches the core, a jump back of more
    than clock_jump_s restarts and the next step carries the reset."""
    from gimbal_kinematics.timing.control_policy import LockstepControl
    from gimbal_kinematics.timing.stamps import step_stamp_ns

    rate = 1000.0
    policy = LockstepControl(lambda k: ("gyro", "enc"), rate, defaults(EFC_PARAMS)["clock_jump_s"],
                             eager_stale_steps=1000)
    add = lambda kind, k: policy.add(kind, step_stamp_ns(k, rate), 0.0)  # noqa: E731
    assert add("enc", 5) == [] and [s.resets for s in add("gyro", 5)] == [()]
    assert add("gyro", 5) == [] and add("gyro", 3) == [] and add("enc", 4) == []  # repeated, late: dropped
    assert policy.rejected == 3
    assert add("enc", 6) == [] and len(add("gyro", 6)) == 1
    assert add("enc", 1006) == [] and len(add("gyro", 1006)) == 1
    assert add("enc", 2) == []  # 1.004 s back: more than clock_jump_s, a bag loop
    (step,) = add("gyro", 2)
    assert "jumped back" in step.resets[0] and policy.rejected == 3
    assert [s.resets for s in (add("enc", 3) or add("gyro", 3))] == [()]  # the reset comes once


# ---------------------------------------------------------------------------- closed loop
@pytest.fixture(scope="module")
def runs():
    return {mode: run_encoder_fusion(mode, 8.0, seed=3, settle_s=3.0, record_every=100)
            for mode in ("fused", "encoder", "gyro")}


def test_fusion_is_ten_times_better_than_encoder_feedback(runs):
    fused, enc = runs["fused"], runs["encoder"]
    assert fused["rms_error_rad"] * 10.0 <= enc["rms_error_rad"]
    assert fused["rms_error_rad"] < 2e-3  # a few hundred µrad class
    assert enc["rms_error_rad"] > 10e-3  # encoder-only: degrees, the paper's 1.2° class
    assert fused["kf_updates"] >= 30


def test_gyro_bias_no_longer_shows_in_the_fused_velocity(runs):
    fused, gyro = runs["fused"], runs["gyro"]
    for axis in (0, 1):
        b = gyro["gyro_bias_rad_s"][axis]
        # raw gyro feedback carries the bias one to one, the fused velocity does not
        assert gyro["velocity_bias_rad_s"][axis] == pytest.approx(b, rel=0.05)
        assert abs(fused["velocity_bias_rad_s"][axis]) < 0.1 * abs(fused["gyro_bias_rad_s"][axis])
    # and the gyro loop drifts away at the bias: far worse than the fused loop
    assert gyro["rms_error_rad"] > 5.0 * fused["rms_error_rad"]
    assert fused["gyro_bias_rad_s"] == gyro["gyro_bias_rad_s"]  # same sensor stream


def test_mems_gyro_is_the_documented_grade():
    assert 0.05 <= abs(MEMS_GYRO.bias_deg_h[0]) / 3600.0 <= 0.2
    assert MEMS_GYRO.bias_instability_deg_h > 0.0
