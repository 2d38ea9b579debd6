"""Encoder, INS, accelerometer, flexure truth and LGU models against closed forms,
Monte Carlo statistics and scipy rotations."""
import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from gimbal_sim.world.sensors import (
    PAPER1_ENCODER,
    PAPER2_ENCODER,
    PAPER3_ACCELEROMETER,
    AccelerometerModel,
    AccelerometerParams,
    EncoderModel,
    EncoderParams,
    FlexureParams,
    GyroParams,
    InsModel,
    InsParams,
    LguPair,
    SecondOrderGaussMarkov,
    ShipFlexureTruth,
    lgu2_rate,
)

SEED = 20261122
DEG = math.pi / 180.0
ARCSEC = DEG / 3600.0
DEG_H = DEG / 3600.0
UG = 9.80665e-6


# ---------------------------------------------------------------- encoders
def test_encoder_quantisation_error_is_uniform_half_count():
    enc = EncoderModel(EncoderParams(lines_per_rev=1024, quadrature=4), 1, np.random.default_rng(SEED), 0.001)
    delta = 2 * math.pi / 4096
    assert enc.quantum_rad == pytest.approx(delta, rel=1e-15)
    angles = np.random.default_rng(SEED).uniform(-20.0, 20.0, 50_000)
    meas = np.array([enc.step([a])[0][0] for a in angles])
    counts = meas / delta
    np.testing.assert_allclose(counts, np.round(counts), atol=1e-6)
    err = meas - angles
    assert np.max(np.abs(err)) <= 0.5 * delta * (1 + 1e-9)
    assert abs(np.mean(err)) < 4 * delta / math.sqrt(12 * 50_000)
    assert np.std(err) == pytest.approx(delta / math.sqrt(12), rel=0.02)


def test_encoder_pulse_frequency_velocity_resolution_paper2():
    dt = 0.001
    enc = EncoderModel(PAPER2_ENCODER, 2, np.random.default_rng(SEED), dt)
    # Paper 2 eq. 1: rpm = 60 f / N, f = one pulse per gate -> resolution in °/s.
    N, gate = 1024, 0.2
    res_rpm = 60.0 * (1.0 / gate) / N
    res = res_rpm * 2 * math.pi / 60.0
    assert enc.gate_time_s == pytest.approx(gate)
    assert enc.velocity_resolution_rad_s == pytest.approx(res, rel=1e-12)
    assert 1.5 < res / DEG < 2.5  # the paper's "approximately 2 deg/sec"
    # Constant slow (1 °/s) and faster (10.3 °/s) rotations, 60 s.
    w = np.array([1.0, 10.3]) * DEG
    readings = []
    for k in range(1, 60_001):
        _, rate = enc.step((w * k * dt).tolist())
        if k % 200 == 0:
            readings.append(rate)
    readings = np.array(readings[1:])  # first gate still filling
    for axis in range(2):
        counts = readings[:, axis] / res
        np.testing.assert_allclose(counts, np.round(counts), atol=1e-9)
        lo = math.floor(w[axis] / res)
        assert set(np.round(counts).astype(int)) <= {lo, lo + 1}
        # Counts are conserved, so the long-run average is the true rate to one count per run.
        assert np.mean(readings[:, axis]) == pytest.approx(w[axis], abs=res / len(readings) * 2)
    # At 1 °/s (below the resolution) the reading is only ever 0 or 1.76 °/s.
    assert set(np.round(readings[:, 0] / res).astype(int)) == {0, 1}


def test_encoder_readout_noise_paper1():
    enc = EncoderModel(PAPER1_ENCODER, 3, np.random.default_rng(SEED), 0.01)
    true = [0.3, -0.1, 1.2]
    meas = np.array([enc.step(true)[0] for _ in range(20_000)])
    np.testing.assert_allclose(np.std(meas, axis=0), 0.05 * DEG, rtol=0.03)  # 0.5 % s.e.
    np.testing.assert_allclose(np.mean(meas, axis=0), true, atol=4 * 0.05 * DEG / math.sqrt(20_000))


@pytest.mark.parametrize(
    "kwargs, field",
    [
        ({"noise_deg": -1.0}, "noise_deg"),
        ({"lines_per_rev": -4}, "lines_per_rev"),
        ({"lines_per_rev": 10.5}, "lines_per_rev"),
        ({"quadrature": 3}, "quadrature"),
        ({"velocity_gate_s": 0.0}, "velocity_gate_s"),
    ],
)
def test_encoder_bad_params(kwargs, field):
    with pytest.raises(ValueError, match=field):
        EncoderParams(**kwargs)


# ---------------------------------------------------------------- INS
def test_ins_attitude_error_rms_and_correlation():
    # Steps of 10 τ make successive samples independent (exact discretisation), so 4000
    # samples give the RMS to ~1.1 % s.e.
    tau = 300.0
    ins = InsModel(InsParams(attitude_tau_s=tau), np.random.default_rng(SEED), 10 * tau)
    euler_true = [0.01, -0.02, 3.1]
    errs = []
    for _ in range(4000):
        e, _ = ins.step(euler_true, [0.0, 0.0, 0.0])
        d = np.array(e) - euler_true
        d[2] = (d[2] + math.pi) % (2 * math.pi) - math.pi
        errs.append(d)
        assert -math.pi < e[2] <= math.pi
    errs = np.array(errs)
    np.testing.assert_allclose(np.sqrt(np.mean(errs**2, axis=0)), np.array([0.05, 0.05, 0.2]) * DEG, rtol=0.05)
    # Lag correlation at a step of one τ is e^{-1}.
    ins2 = InsModel(InsParams(attitude_tau_s=tau), np.random.default_rng(SEED + 1), tau)
    errs2 = np.array([np.array(ins2.step([0.0, 0.0, 0.0], [0.0, 0.0, 0.0])[0]) for _ in range(6000)])
    rho = np.mean(errs2[:-1] * errs2[1:], axis=0) / np.mean(errs2**2, axis=0)
    np.testing.assert_allclose(rho, math.exp(-1.0), atol=0.05)


def test_ins_constant_attitude_error_and_rate_errors():
    ins = InsModel(InsParams(attitude_tau_s=math.inf), np.random.default_rng(SEED), 0.01)
    omega = [0.05, -0.02, 0.1]
    first, _ = ins.step([0.0, 0.0, 0.0], omega)
    diffs = []
    for _ in range(3000):
        e, w = ins.step([0.0, 0.0, 0.0], omega)
        assert e == first  # random constant per run
        diffs.append(np.array(w) - omega - ins.true_gyro_bias)
    # After removing the published true bias only the ARW remains: zero mean, σ = ARW/√Δt.
    arw = 0.1 * DEG / 60.0
    diffs = np.array(diffs)
    np.testing.assert_allclose(np.std(diffs, axis=0), arw / math.sqrt(0.01), rtol=0.06)
    np.testing.assert_allclose(np.mean(diffs, axis=0), 0.0, atol=4 * arw / math.sqrt(0.01 * 3000))


# ---------------------------------------------------------------- accelerometers
def test_accelerometer_bias_and_noise():
    root = np.random.default_rng(SEED)
    biases = np.array([AccelerometerModel(PAPER3_ACCELEROMETER, 3, r, 0.01).true_bias for r in root.spawn(500)])
    assert np.std(biases) == pytest.approx(100 * UG, rel=0.08)  # 1500 draws: 1.8 % s.e.
    params = AccelerometerParams(bias_ug=(100.0, -100.0), noise_ug_rt_hz=50.0)
    acc = AccelerometerModel(params, 2, np.random.default_rng(SEED), 0.01)  # 2-axis level pair
    f_true = [0.02, -0.03]
    y = np.array([acc.step(f_true) for _ in range(20_000)])
    sd = 50 * UG / math.sqrt(0.01)
    np.testing.assert_allclose(np.std(y, axis=0), sd, rtol=0.03)
    expected_mean = np.array(f_true) + np.array([100, -100]) * UG
    np.testing.assert_allclose(np.mean(y, axis=0), expected_mean, atol=4 * sd / math.sqrt(20_000))
    np.testing.assert_allclose(acc.true_bias, [100 * UG, -100 * UG], rtol=1e-15)
    dv = acc.step_increment(f_true)
    assert len(dv) == 2
    with pytest.raises(ValueError, match="noise_ug_rt_hz"):
        AccelerometerParams(noise_ug_rt_hz=-1.0)
    with pytest.raises(ValueError, match="bias_sigma_ug"):
        AccelerometerParams(bias_sigma_ug=-1.0)


# ---------------------------------------------------------------- flexure
def _quasi_static_closed_form(t):
    # Paper 5 §5.1 for every axis: 0.1° + 0.2°/h t + 90″ sin(2πt/1h) + 0.1° sin(2πt/200 s).
    slow = 90 * ARCSEC * np.sin(2 * np.pi * t / 3600)
    helm = 0.1 * DEG * np.sin(2 * np.pi * t / 200)
    return 0.1 * DEG + 0.2 * DEG_H * t + slow + helm


def test_flexure_quasi_static_closed_form_and_rate():
    flex = ShipFlexureTruth(FlexureParams(dynamic_rms_arcsec=0.0), np.random.default_rng(SEED), 1.0)
    for _ in range(7200):
        flex.step()
        np.testing.assert_allclose(flex.angle, [_quasi_static_closed_form(flex.t)] * 3, rtol=0, atol=1e-13)
    # Rate against a central difference of the closed form.
    for t in (0.0, 37.0, 1234.5, 5000.0):
        h = 1e-3
        num = (_quasi_static_closed_form(t + h) - _quasi_static_closed_form(t - h)) / (2 * h)
        np.testing.assert_allclose(flex.quasi_static_rate(t), [num] * 3, rtol=1e-6)


def _gm2_autocov(tau, beta, lam, sigma):
    # R(τ) of θ̈ + 2βθ̇ + (β²+λ²)θ = w (stationary σ²): standard result for a damped oscillator.
    if lam == 0.0:
        return sigma**2 * np.exp(-beta * tau) * (1 + beta * tau)
    return sigma**2 * np.exp(-beta * tau) * (np.cos(lam * tau) + beta / lam * np.sin(lam * tau))


@pytest.mark.parametrize("beta, lam, dt", [(0.1, 0.5, 0.5), (0.1, 0.0, 0.5), (0.3, 1.0, 0.05)])
def test_second_order_markov_rms_and_autocorrelation(beta, lam, dt):
    # 2000 independent chains from the stationary start, 200 steps: the variance pooled over
    # chains and time has a few-% standard error; the autocovariance matches the closed form.
    sigma, chains, steps = 60 * ARCSEC, 2000, 200
    gm = SecondOrderGaussMarkov(sigma, beta, lam, np.random.default_rng(SEED), dt, n_axes=chains)
    x = np.empty((steps, chains))
    v = np.empty((steps, chains))
    for k in range(steps):
        gm.step()
        x[k] = gm.value
        v[k] = gm.rate
    assert np.sqrt(np.mean(x**2)) == pytest.approx(sigma, rel=0.03)
    assert np.sqrt(np.mean(x[-1] ** 2)) == pytest.approx(sigma, rel=0.06)  # no drift over the run
    assert np.sqrt(np.mean(v**2)) == pytest.approx(math.sqrt(beta**2 + lam**2) * sigma, rel=0.03)
    for lag_s in (1.0, 3.0, 6.0):
        m = int(round(lag_s / dt))
        r = np.mean(x[:-m] * x[m:])
        assert r == pytest.approx(_gm2_autocov(lag_s, beta, lam, sigma), abs=0.04 * sigma**2)


def test_flexure_dynamic_rms_paper5():
    # Long run with a large exact step: dynamic = total - quasi-static closed form.
    flex = ShipFlexureTruth(FlexureParams(), np.random.default_rng(SEED), 5.0)
    d = []
    for _ in range(20_000):
        flex.step()
        d.append(np.array(flex.angle) - _quasi_static_closed_form(flex.t))
    rms = np.sqrt(np.mean(np.array(d) ** 2, axis=0))
    np.testing.assert_allclose(rms, np.array([20.0, 60.0, 40.0]) * ARCSEC, rtol=0.06)


def test_flexure_bad_params():
    with pytest.raises(ValueError, match="helm_period_s"):
        FlexureParams(helm_period_s=0.0)
    with pytest.raises(ValueError, match="dynamic_rms_arcsec"):
        FlexureParams(dynamic_rms_arcsec=(1.0, 2.0))
    with pytest.raises(ValueError, match="dynamic_beta_per_s"):
        FlexureParams(dynamic_beta_per_s=-0.1)


# ---------------------------------------------------------------- LGUs
_NOISELESS = (GyroParams(bias_deg_h=0.05), GyroParams(bias_deg_h=-0.05))


def test_lgu_difference_consistent_with_flexure_rate_and_bias_difference():
    # Ship at rest, bias-only LGUs: each step LGU2 - LGU1 must equal the flexure rate
    # (the model's analytic rate, integrated by the trapezoid rule) plus (ε2 - ε1) Δt.
    dt, n = 0.01, 20_000
    flex = ShipFlexureTruth(FlexureParams(), np.random.default_rng(SEED), dt)
    pair = LguPair(flex, np.random.default_rng(SEED + 1), dt, *_NOISELESS)
    rate0 = np.array(flex.rate)
    resid, incs = [], []
    for _ in range(n):
        a1, a2 = pair.step([0.0, 0.0, 0.0])
        rate1 = np.array(flex.rate)
        d = np.array(a2) - np.array(a1)
        resid.append(d - 0.5 * (rate0 + rate1) * dt)
        incs.append(d)
        rate0 = rate1
    resid, incs = np.array(resid), np.array(incs)
    # Bias difference -0.1 °/h is 1e-3″ per step; the quadrature residual averages out.
    np.testing.assert_allclose(np.mean(resid, axis=0) / dt, -0.1 * DEG_H, rtol=0.05)
    # What is left is the trapezoid error of a rate driven by white noise (~2 % here).
    spread = np.sqrt(np.mean((resid - resid.mean(axis=0)) ** 2, axis=0))
    assert np.all(spread < 0.05 * np.sqrt(np.mean(incs**2, axis=0)))

    # With the default (noisy) LGUs over 1 h: the summed difference minus the flexure
    # change gives the bias difference to the ARW level (4σ bound; the ½∫θ×dθ coning
    # term, ~1″/h, is 50× smaller than the bound).
    dt, n = 0.1, 36_000
    flex = ShipFlexureTruth(FlexureParams(), np.random.default_rng(SEED), dt)
    pair = LguPair(flex, np.random.default_rng(SEED + 2), dt)
    th0 = np.array(flex.angle)
    diff = np.zeros(3)
    for _ in range(n):
        a1, a2 = pair.step([0.0, 0.0, 0.0])
        diff += np.array(a2) - np.array(a1)
    T = n * dt
    bias_diff = (diff - (np.array(flex.angle) - th0)) / T
    arw = 0.001 * DEG / 60.0
    np.testing.assert_allclose(bias_diff, -0.1 * DEG_H, atol=4 * math.sqrt(2) * arw / math.sqrt(T))


def _ship_attitude(t):
    # Paper 5 §5.1: heading, pitch, roll sinusoids of 3°, 3°, 5°.
    yaw = 3 * DEG * np.sin(2 * np.pi * t / 9.0 + 0.3)
    pitch = 3 * DEG * np.sin(2 * np.pi * t / 7.0)
    roll = 5 * DEG * np.sin(2 * np.pi * t / 11.0 + 1.0)
    return Rotation.from_euler("ZYX", np.column_stack([yaw, pitch, roll]))


def test_lgu2_attitude_matches_exact_flexed_frame():
    # Truth with exact rotations: R_i_b2 = R_i_b1 exp([θ×]) (C_b1b2 = exp([θ×]) ≈ I + [θ×]).
    # Integrating LGU2's (noise- and bias-free) increments must reproduce b2's attitude
    # relative to its initial frame to well under the 20″ accuracy the method aims at.
    dt, n = 0.02, 15_000
    t = np.arange(n + 1) * dt
    R1 = _ship_attitude(t)
    dalpha1 = (R1[:-1].inv() * R1[1:]).as_rotvec()
    flex = ShipFlexureTruth(FlexureParams(), np.random.default_rng(SEED), dt)
    ideal = GyroParams()
    pair = LguPair(flex, np.random.default_rng(SEED + 3), dt, ideal, ideal)
    thetas = [np.array(flex.angle)]
    est = np.eye(3)
    worst = 0.0
    R2_0 = R1[0].as_matrix() @ Rotation.from_rotvec(thetas[0]).as_matrix()
    for k in range(n):
        a1, a2 = pair.step(dalpha1[k].tolist())
        np.testing.assert_allclose(a1, dalpha1[k], rtol=1e-13, atol=1e-17)
        est = est @ Rotation.from_rotvec(a2).as_matrix()
        if k % 50 == 49:
            R2 = R1[k + 1].as_matrix() @ Rotation.from_rotvec(flex.angle).as_matrix()
            err = Rotation.from_matrix((R2_0.T @ R2).T @ est).magnitude()
            worst = max(worst, err)
    assert worst < 0.05 * ARCSEC


def test_lgu2_rate_matches_exact_relative_rotation():
    # ω_ib2^b2 = C_b2b1 ω_ib1^b1 + ω_b1b2^b2 with C_b1b2 = exp([θ×]); the relative rate is
    # vee(C_b1b2ᵀ dC_b1b2/dt), here by central differences of scipy rotations.
    rng = np.random.default_rng(SEED)
    for _ in range(20):
        w1 = rng.normal(scale=0.05, size=3)
        th = rng.normal(scale=3e-3, size=3)
        thd = rng.normal(scale=1e-4, size=3)
        h = 1e-3
        Rp = Rotation.from_rotvec(th + h * thd).as_matrix()
        Rm = Rotation.from_rotvec(th - h * thd).as_matrix()
        R = Rotation.from_rotvec(th).as_matrix()
        W = R.T @ (Rp - Rm) / (2 * h)
        w_rel = np.array([W[2, 1], W[0, 2], W[1, 0]])
        exact = R.T @ w1 + w_rel
        bound = np.linalg.norm(th) ** 3 * (np.linalg.norm(w1) + np.linalg.norm(thd)) + 1e-12
        np.testing.assert_allclose(lgu2_rate(w1, th, thd), exact, rtol=0, atol=bound)
