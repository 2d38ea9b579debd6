"""Gyro error model against Allan-variance theory, Monte Carlo statistics and closed forms.

Reference formulas (independent of the code under test):

* white rate noise with ARW density N [rad/√s]: Allan deviation σ_A(τ) = N/√τ;
* first-order Gauss-Markov rate with stationary σ and correlation time T
  (autocovariance σ² e^{-|s|/T}): the Allan variance is
  σ_A²(τ) = var(ȳ_τ) - cov(ȳ_τ[k], ȳ_τ[k+1]) = (σ² T²/τ²) (2x - 3 + 4e^{-x} - e^{-2x}),
  x = τ/T, whose maximum is 0.6174 σ at τ = 1.893 T.
"""
import math

import allantools
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from gimbal_sim.world.sensors import PAPER1_GIMBAL_GYRO, PAPER1_INS_GYRO, GyroModel, GyroParams
from gimbal_sim.world.sensors.markov import FirstOrderGaussMarkov

SEED = 20261121
DEG_H = math.pi / 180.0 / 3600.0
DEG_RT_H = math.pi / 180.0 / 60.0


def _gm_allan_var(tau, sigma, T):
    x = np.asarray(tau) / T
    return sigma**2 * T**2 / np.asarray(tau) ** 2 * (2 * x - 3 + 4 * np.exp(-x) - np.exp(-2 * x))


def test_gm_allan_closed_form_peak():
    # Guard on the reference formula itself: peak value and location quoted in the literature.
    tau = np.linspace(0.1, 10.0, 100_000)
    adev = np.sqrt(_gm_allan_var(tau, 1.0, 1.0))
    assert adev.max() == pytest.approx(0.6174, abs=5e-4)
    assert tau[adev.argmax()] == pytest.approx(1.893, abs=0.01)


def test_allan_deviation_recovers_paper1_gimbal_gyro():
    dt, hours = 0.01, 2.0
    n_steps = int(hours * 3600 / dt)
    gyro = GyroModel(PAPER1_GIMBAL_GYRO, 2, np.random.default_rng(SEED), dt)
    zero = [0.0, 0.0]
    y = np.array([gyro.step_rate(zero) for _ in range(n_steps)])  # at rest: output = errors

    arw = 0.15 * DEG_RT_H
    sigma_gm, T = 30.0 * DEG_H, 100.0
    taus = np.array([1.0, 30.0, 60.0, 100.0, 150.0, 200.0, 300.0, 500.0])
    adev = []
    for axis in range(2):
        t_out, a, _, _ = allantools.oadev(y[:, axis], rate=1.0 / dt, data_type="freq", taus=taus)
        np.testing.assert_allclose(t_out, taus)
        adev.append(a)
    adev = np.array(adev)

    # ARW: read on the -1/2 slope at τ = 1 s (tolerance 10 %). The GM term adds
    # (2/3) σ² τ/T there (+3.6 % in σ_A); with it removed the read is within 3 %.
    for axis in range(2):
        assert adev[axis, 0] == pytest.approx(arw, rel=0.10)
        assert math.sqrt(adev[axis, 0] ** 2 - _gm_allan_var(1.0, sigma_gm, T)) == pytest.approx(arw, rel=0.03)

    # Bias instability: remove the white-noise part, then fit the GM σ to the theoretical
    # curve over 30..500 s (both axes) and compare the peak region to 0.6174 σ.
    gm_avar = adev[:, 1:] ** 2 - arw**2 / taus[1:]
    unit_curve = _gm_allan_var(taus[1:], 1.0, T)
    sigma_fit = math.sqrt(np.mean(gm_avar / unit_curve))
    assert sigma_fit == pytest.approx(sigma_gm, rel=0.20)
    peak = np.sqrt(np.mean(adev[:, 4:6] ** 2))  # τ = 150, 200 s bracket the 189 s peak
    assert peak == pytest.approx(0.6174 * sigma_gm, rel=0.20)
    # The curve must rise towards the peak as the GM shape does (0.40 σ at 30 s vs 0.62 σ).
    assert np.all(adev[:, 4] > 1.2 * adev[:, 1])


def _gm_only(sigma_deg_h, tau_s):
    return GyroParams(bias_instability_deg_h=sigma_deg_h, bias_instability_tau_s=tau_s)


@pytest.mark.parametrize("dt", [0.001, 0.01])
def test_gauss_markov_variance_and_correlation_independent_of_step(dt):
    # 300 independent chains (axes) over 50 correlation times: relative standard error of the
    # pooled variance ≈ sqrt(2 T / (duration * chains)) ≈ 1.2 %, so 5 % is a > 4σ bound.
    sigma, T, chains, duration = 30.0 * DEG_H, 0.2, 300, 10.0
    gyro = GyroModel(_gm_only(30.0, T), chains, np.random.default_rng(SEED + int(1 / dt)), dt)
    zero = [0.0] * chains
    n = int(round(duration / dt))
    lag = int(round(T / dt))
    stride = max(1, n // 2000)
    states = np.empty((n // stride + 1, chains))
    k_out = 0
    for k in range(n):
        gyro.step_rate(zero)
        if k % stride == 0:
            states[k_out] = gyro.gm_bias
            k_out += 1
    states = states[:k_out]
    var = np.mean(states**2)
    assert var == pytest.approx(sigma**2, rel=0.05)
    # Lag-T correlation must be e^{-1}, whatever the step.
    m = lag // stride
    rho = np.mean(states[:-m] * states[m:]) / var
    assert rho == pytest.approx(math.exp(-1.0), abs=0.03)
    # The accessor the simulator publishes is the applied total bias.
    np.testing.assert_array_equal(gyro.true_bias, gyro.fixed_bias + gyro.gm_bias + gyro.rrw_bias)


def test_first_order_gm_zero_start_transient_matches_closed_form():
    # From b(0) = 0 the exact variance is σ² (1 - e^{-2t/T}) at any t and any step.
    sigma, T, chains = 2.0, 1.0, 4000
    for dt in (0.05, 0.5):
        gm = FirstOrderGaussMarkov(sigma, T, np.random.default_rng(SEED + 7), dt, n_axes=chains, stationary_start=False)
        for _ in range(int(round(1.0 / dt))):
            x = gm.step()
        expected = sigma**2 * (1 - math.exp(-2.0))
        assert np.var(x) == pytest.approx(expected, rel=0.07)  # 4000 samples: 2.2 % s.e.


def test_arw_rate_and_increment_variance():
    dt, chains, steps = 0.01, 1000, 400
    arw = 0.15 * DEG_RT_H
    params = GyroParams(arw_deg_rt_h=0.15)
    zero = [0.0] * chains
    g_inc = GyroModel(params, chains, np.random.default_rng(SEED + 1), dt)
    g_rate = GyroModel(params, chains, np.random.default_rng(SEED + 1), dt)
    inc = np.array([g_inc.step_increment(zero) for _ in range(steps)])
    rate = np.array([g_rate.step_rate(zero) for _ in range(steps)])
    # Same noise stream: the increment is exactly the step-average rate times the step.
    np.testing.assert_allclose(inc, rate * dt, rtol=1e-14, atol=0.0)
    # 400k samples: s.e. of the variance 0.2 %.
    assert np.var(inc) == pytest.approx(arw**2 * dt, rel=0.01)
    assert np.var(rate) == pytest.approx(arw**2 / dt, rel=0.01)
    # Integrated angle is a random walk with variance ARW² t, for any step size.
    for step in (0.001, 0.05):
        g = GyroModel(params, chains, np.random.default_rng(SEED + 2), step)
        n = int(round(2.0 / step))
        total = np.sum([g.step_increment(zero) for _ in range(n)], axis=0)
        assert np.var(total) == pytest.approx(arw**2 * 2.0, rel=0.10)  # 1000 chains: 4.5 % s.e.


def test_increment_and_rate_consistent_with_bias_and_input():
    dt = 0.005
    params = GyroParams(bias_deg_h=(100.0, -50.0), scale_factor_ppm=(1000.0, -2000.0))
    g = GyroModel(params, 2, np.random.default_rng(SEED), dt)
    omega = [0.3, -0.2]
    total = np.zeros(2)
    for _ in range(1000):
        total += g.step_increment(omega)
    expected = (np.array(omega) * (1 + np.array([1e-3, -2e-3])) + np.array([100.0, -50.0]) * DEG_H) * dt * 1000
    np.testing.assert_allclose(total, expected, rtol=1e-12)
    # Variable step recomputes the discretisation and integrates with the given step.
    inc = g.step_increment(omega, dt=0.02)
    np.testing.assert_allclose(inc, expected / 1000 / dt * 0.02, rtol=1e-12)


def test_quantisation_has_no_accumulated_bias():
    q, dt, omega = 1e-5, 0.001, 0.0123  # 1.23 quanta per step: per-step rounding would lose 0.23 q/step
    g = GyroModel(GyroParams(quantisation_rad=q), 1, np.random.default_rng(SEED), dt)
    total, worst = 0.0, 0.0
    for k in range(1, 20001):
        out = g.step_increment([omega])[0]
        n_q = out / q
        assert abs(n_q - round(n_q)) < 1e-9
        total += out
        worst = max(worst, abs(total - omega * dt * k))
    assert worst <= 0.5 * q * (1 + 1e-9)
    # Rate output is the quantised increment over the step, with the same guarantee.
    g2 = GyroModel(GyroParams(quantisation_rad=q), 1, np.random.default_rng(SEED), dt)
    rates = np.array([g2.step_rate([omega])[0] for _ in range(20000)])
    assert abs(rates.sum() * dt - omega * dt * 20000) <= 0.5 * q * (1 + 1e-9)
    assert set(np.round(rates * dt / q).astype(int)) == {1, 2}


def test_saturation_clamps():
    sat = 100.0 * math.pi / 180.0
    params = GyroParams(saturation_deg_s=100.0, bias_deg_h=3600.0, arw_deg_rt_h=30.0)
    g = GyroModel(params, 3, np.random.default_rng(SEED), 0.01)
    for _ in range(200):
        y = g.step_rate([10.0, -10.0, 0.5])
        assert y[0] == sat and y[1] == -sat
        assert abs(y[2]) < sat
    inc = g.step_increment([5.0, -5.0, 0.0])
    assert inc[0] == pytest.approx(sat * 0.01, rel=1e-15) and inc[1] == pytest.approx(-sat * 0.01, rel=1e-15)


def test_scale_factor_closed_form():
    ppm = (150.0, -300.0, 2500.0)
    g = GyroModel(GyroParams(scale_factor_ppm=ppm), 3, np.random.default_rng(SEED), 0.01)
    omega = np.array([0.7, -1.3, 0.01])
    np.testing.assert_allclose(g.step_rate(omega.tolist()), omega * (1 + np.array(ppm) * 1e-6), rtol=1e-15)


def test_misalignment_matches_rotated_triad():
    # A rigid triad turned by a small rotation vector ε measures C_sb ω, C_sb = (exp[ε×])ᵀ;
    # to first order this is the misalignment matrix -[ε×]. Check against scipy to O(ε²).
    rng = np.random.default_rng(SEED)
    eps = np.array([2e-3, -1e-3, 3e-3])
    M = -np.array([[0, -eps[2], eps[1]], [eps[2], 0, -eps[0]], [-eps[1], eps[0], 0]])
    g = GyroModel(GyroParams(misalignment_rad=M.tolist()), 3, np.random.default_rng(SEED), 0.01)
    C_sb = Rotation.from_rotvec(eps).as_matrix().T
    for _ in range(50):
        omega = rng.normal(size=3)
        err = np.array(g.step_rate(omega.tolist())) - C_sb @ omega
        assert np.linalg.norm(err) <= np.linalg.norm(eps) ** 2 * np.linalg.norm(omega)
    # Non-orthogonal misalignment: sensed axis i is e_i + Σ_j M_ij e_j (normalised).
    M2 = np.array([[0.0, 1e-3, -2e-3], [5e-4, 0.0, 1e-3], [-1e-3, 3e-3, 0.0]])
    g2 = GyroModel(GyroParams(misalignment_rad=M2.tolist()), 3, np.random.default_rng(SEED), 0.01)
    axes = np.eye(3) + M2
    axes /= np.linalg.norm(axes, axis=1, keepdims=True)
    for _ in range(50):
        omega = rng.normal(size=3)
        err = np.array(g2.step_rate(omega.tolist())) - axes @ omega
        assert np.linalg.norm(err) <= 1e-5 * np.linalg.norm(omega)  # O(|M|²) ≈ 1e-5


def test_fixed_bias_given_and_drawn():
    g = GyroModel(PAPER1_GIMBAL_GYRO, 2, np.random.default_rng(SEED), 0.01)
    np.testing.assert_allclose(g.fixed_bias, [100.0 * DEG_H] * 2, rtol=1e-15)
    root = np.random.default_rng(SEED)
    draws = np.array([GyroModel(PAPER1_INS_GYRO, 3, r, 0.01).fixed_bias for r in root.spawn(400)])
    # 1200 draws: the sample σ has ~2 % standard error.
    assert np.std(draws) == pytest.approx(1.0 * DEG_H, rel=0.08)
    assert abs(np.mean(draws)) < 4 * DEG_H / math.sqrt(1200)
    # Same seed, same run.
    a = GyroModel(PAPER1_INS_GYRO, 3, np.random.default_rng(5), 0.01)
    b = GyroModel(PAPER1_INS_GYRO, 3, np.random.default_rng(5), 0.01)
    assert [a.step_rate([0.1, 0.2, 0.3]) for _ in range(10)] == [b.step_rate([0.1, 0.2, 0.3]) for _ in range(10)]


def test_rate_random_walk_variance():
    K = 10.0 * DEG_H / 60.0  # 10 °/h/√h in rad/s/√s
    chains, dt, t_end = 2000, 0.1, 50.0
    g = GyroModel(GyroParams(rrw_deg_h_rt_h=10.0), chains, np.random.default_rng(SEED), dt)
    zero = [0.0] * chains
    for _ in range(int(round(t_end / dt))):
        g.step_rate(zero)
    assert np.var(g.rrw_bias) == pytest.approx(K**2 * t_end, rel=0.10)  # 2000 chains: 3.2 % s.e.


@pytest.mark.parametrize(
    "kwargs, field",
    [
        ({"arw_deg_rt_h": -1.0}, "arw_deg_rt_h"),
        ({"bias_instability_tau_s": 0.0}, "bias_instability_tau_s"),
        ({"bias_instability_tau_s": -5.0}, "bias_instability_tau_s"),
        ({"bias_instability_deg_h": -1.0}, "bias_instability_deg_h"),
        ({"bias_sigma_deg_h": -0.1}, "bias_sigma_deg_h"),
        ({"rrw_deg_h_rt_h": -2.0}, "rrw_deg_h_rt_h"),
        ({"quantisation_rad": -1e-6}, "quantisation_rad"),
        ({"saturation_deg_s": 0.0}, "saturation_deg_s"),
        ({"arw_deg_rt_h": float("nan")}, "arw_deg_rt_h"),
        ({"bias_deg_h": float("inf")}, "bias_deg_h"),
        ({"scale_factor_ppm": "big"}, "scale_factor_ppm"),
        ({"misalignment_rad": [[1e-3, 0.0], [0.0, 0.0]]}, "misalignment_rad"),
        ({"misalignment_rad": [[0.0, 1e-3, 0.0]]}, "misalignment_rad"),
    ],
)
def test_bad_params_raise_naming_field(kwargs, field):
    with pytest.raises(ValueError, match=field):
        GyroParams(**kwargs)


def test_model_rejects_mismatched_axes():
    with pytest.raises(ValueError, match="bias"):
        GyroModel(GyroParams(bias_deg_h=(1.0, 2.0, 3.0)), 2, np.random.default_rng(0), 0.01)
    with pytest.raises(ValueError, match="misalignment"):
        GyroModel(GyroParams(misalignment_rad=[[0.0, 1e-3], [0.0, 0.0]]), 3, np.random.default_rng(0), 0.01)
    with pytest.raises(ValueError, match="dt"):
        GyroModel(PAPER1_GIMBAL_GYRO, 2, np.random.default_rng(0), 0.0)
    g = GyroModel(PAPER1_GIMBAL_GYRO, 2, np.random.default_rng(0), 0.01)
    with pytest.raises(ValueError, match="2 elements"):
        g.step_rate([0.0, 0.0, 0.0])
    with pytest.raises(TypeError, match="Generator"):
        GyroModel(PAPER1_GIMBAL_GYRO, 2, np.random.RandomState(0), 0.01)


def test_si_spec_and_gauss_markov_validate():
    from gimbal_sim.world.sensors import ErrorSpecSI

    with pytest.raises(ValueError, match="white_density"):
        ErrorSpecSI(white_density=-1.0)
    with pytest.raises(ValueError, match="gm_tau"):
        ErrorSpecSI(gm_tau=0.0)
    with pytest.raises(ValueError, match="tau_s"):
        FirstOrderGaussMarkov(1.0, 0.0, np.random.default_rng(0), 0.01)
    with pytest.raises(ValueError, match="sigma"):
        FirstOrderGaussMarkov(-1.0, 1.0, np.random.default_rng(0), 0.01)
