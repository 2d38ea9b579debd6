"""The host INS's Schuler attitude-error model (paper 1's INS as an INS error model has it):
the tilt oscillates at 2π√(R/g) from WGS-84, scaled to the paper's RMS, the heading wanders;
checked against the closed forms of a damped oscillator driven by white noise (stationary
variance, autocorrelation at a half period) by Monte Carlo over independent INSs, against
numpy's own Cholesky of the exact discrete covariance, and the parameters refused by name."""
import math

import numpy as np
import pytest
from scipy.linalg import expm, solve_continuous_lyapunov

from gimbal_estimators.gyro_bias_ekf_params import GyroBiasEkfParams
from gimbal_kinematics.maths.units import DEG
from gimbal_sim.core.loop_plan import node_values
from gimbal_sim.graph.scenario import load
from gimbal_sim.world.sensor_suite import SensorSuiteConfig
from gimbal_sim.world.sensors import InsModel, InsParams
from gimbal_sim.world.sensors.ins import SCHULER_PERIOD_S, InsAttitudeError
from gimbal_sim.world.sensors.markov import gm2_discrete

N_INS = 800  # independent INSs: a correlation to about ±3/√N ≈ 0.1


def _wgs84_schuler_period_s(lat: float) -> float:
    """2π√(R/g), R the Gaussian mean radius, g Somigliana's normal gravity (WGS-84 constants)."""
    a, f = 6378137.0, 1.0 / 298.257223563
    e2 = f * (2.0 - f)
    w = 1.0 - e2 * math.sin(lat) ** 2
    r = math.sqrt(a * (1.0 - e2) / w ** 1.5 * a / math.sqrt(w))
    g = 9.7803253359 * (1.0 + 0.00193185265241 * math.sin(lat) ** 2) / math.sqrt(w)
    return 2.0 * math.pi * math.sqrt(r / g)


def test_the_default_period_is_the_schuler_period_of_the_earth():
    for lat in (0.0, 45.0, 60.0):
        assert SCHULER_PERIOD_S == pytest.approx(_wgs84_schuler_period_s(math.radians(lat)), rel=2e-3)
    assert InsParams().schuler_period_s == SCHULER_PERIOD_S


def _ensemble(params: InsParams, dt: float, n_steps: int) -> np.ndarray:
    """(N_INS, n_steps + 1, 3) errors of independent INSs, from their stationary start."""
    out = np.empty((N_INS, n_steps + 1, 3))
    for i, rng in enumerate(np.random.default_rng(20261206).spawn(N_INS)):
        err = InsAttitudeError(params, rng, dt)
        out[i, 0] = err.state[:, 0]
        for k in range(n_steps):
            out[i, k + 1] = err.step()
    return out


def test_tilt_rms_and_half_period_correlation_match_the_damped_oscillator():
    p = InsParams(attitude_model="schuler", schuler_damping=0.1, attitude_tau_s=3600.0)
    half = p.schuler_period_s / 2.0
    e = _ensemble(p, half / 4.0, 4)  # samples at 0 and at half a period
    w0 = 2.0 * math.pi / p.schuler_period_s
    beta, lam = p.schuler_damping * w0, w0 * math.sqrt(1.0 - p.schuler_damping ** 2)
    tau = 4 * (half / 4.0)
    rho = math.exp(-beta * tau) * (math.cos(lam * tau) + beta / lam * math.sin(lam * tau))
    sigma = p.roll_pitch_rms_deg * DEG
    for axis in (0, 1):
        x0, x1 = e[:, 0, axis], e[:, -1, axis]
        # stationary: the RMS at the end is the paper's (chi-square, 4.5 sigma of the ensemble's variance)
        assert np.sqrt(np.mean(x1 ** 2)) == pytest.approx(sigma, rel=4.5 * math.sqrt(0.5 / N_INS))
        r = np.mean(x0 * x1) / np.sqrt(np.mean(x0 ** 2) * np.mean(x1 ** 2))
        assert rho < -0.7  # half a period later the tilt is (mostly) the opposite
        assert abs(r - rho) < 4.0 * (1.0 - rho ** 2) / math.sqrt(N_INS)
    # the heading: first order with attitude_tau_s
    h0, h1 = e[:, 0, 2], e[:, -1, 2]
    r = np.mean(h0 * h1) / np.sqrt(np.mean(h0 ** 2) * np.mean(h1 ** 2))
    rho_h = math.exp(-tau / p.attitude_tau_s)
    assert abs(r - rho_h) < 4.0 * (1.0 - rho_h ** 2) / math.sqrt(N_INS)


def test_the_tilt_step_is_the_exact_discretisation_with_numpys_cholesky():
    p = InsParams(attitude_model="schuler", schuler_damping=0.3)
    dt = 0.01
    err = InsAttitudeError(p, np.random.default_rng(3), dt)
    w0 = 2.0 * math.pi / p.schuler_period_s
    beta, lam = p.schuler_damping * w0, w0 * math.sqrt(1.0 - p.schuler_damping ** 2)
    sigma = p.roll_pitch_rms_deg * DEG
    # Φ from scipy's expm of the oscillator; Q_d's stationary consistency: Φ P∞ Φᵀ + Q_d = P∞
    A = np.array([[0.0, 1.0], [-w0 ** 2, -2.0 * beta]])
    Phi, Qd = gm2_discrete(beta, lam, sigma, dt)
    assert np.allclose(Phi, expm(A * dt), rtol=1e-12, atol=1e-15)
    P_inf = solve_continuous_lyapunov(A, -np.array([[0.0, 0.0], [0.0, 4.0 * beta * w0 ** 2 * sigma ** 2]]))
    assert np.allclose(P_inf, np.diag([sigma ** 2, w0 ** 2 * sigma ** 2]), rtol=1e-9)
    scale = np.diag(1.0 / np.sqrt(np.diag(P_inf)))  # θ and θ̇ differ by ω_s: compare correlations
    assert np.allclose(scale @ (Phi @ P_inf @ Phi.T + Qd) @ scale, scale @ P_inf @ scale, rtol=0.0, atol=1e-9)
    L = np.linalg.cholesky(Qd)
    twin = InsAttitudeError(p, np.random.default_rng(3), dt)
    for _ in range(50):
        x = err.state[0].copy()
        z, j = twin._normals.take(5)  # the twin's stream is err's: the draws err.step takes
        err.step()
        assert np.allclose(err.state[0], Phi @ x + L @ np.array(z[j:j + 2]), rtol=1e-12, atol=1e-20)


def test_the_gauss_markov_model_keeps_its_white_limit():
    model = InsModel(InsParams(attitude_tau_s=0.001), np.random.default_rng(1), 0.01)
    errs = np.array([model.step((0.0, 0.0, 0.0), (0.0, 0.0, 0.0))[0] for _ in range(4000)])
    lag1 = np.corrcoef(errs[:-1, 0], errs[1:, 0])[0, 1]
    assert abs(lag1) < 4.0 / math.sqrt(4000)
    assert np.std(errs[:, 2]) == pytest.approx(0.2 * DEG, rel=0.1)


@pytest.mark.parametrize("field, value", [("attitude_model", "kalman"), ("schuler_damping", 1.0),
                                          ("schuler_damping", 0.0), ("schuler_period_s", -1.0)])
def test_bad_parameters_are_refused_by_name(field, value):
    with pytest.raises(ValueError, match=field):
        InsParams(**{field: value})


def test_the_headline_scenarios_ins_is_not_its_ekfs_model():
    """The simulated INS errs as an INS does (Schuler tilt, minutes-long correlation); the
    headline's EKF takes its angles as white noise (paper 1's 6-state filter): the truth's
    one-minute autocorrelation, measured over independent INSs, is far from the zero its
    filter assumes, and the filter's own model has no oscillation at all."""
    values = node_values(load("sighting_land_vehicle"))
    ins = SensorSuiteConfig.from_values(values["sensor_models"][1]).ins
    ekf = GyroBiasEkfParams.from_values(values["gyro_bias_ekf"][1])
    assert ins.attitude_model == "schuler" and not ekf.ins_error_states
    e = _ensemble(ins, 60.0, 1)
    r = np.mean(e[:, 0, 0] * e[:, 1, 0]) / np.sqrt(np.mean(e[:, 0, 0] ** 2) * np.mean(e[:, 1, 0] ** 2))
    assert r > 0.9 > 4.0 / math.sqrt(N_INS)  # white: 0 within ±4/√N
