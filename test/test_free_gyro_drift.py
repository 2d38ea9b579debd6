"""The drifting free gyro and its rate sensors against independent references: the
Gauss–Markov drift's rate variance and correlation and its integral's variance against the
closed forms, the integrated spin-axis rate sensors' random walk (σ² ∝ t, independent
increments), the error model against a small seeded Monte Carlo per source (χ² intervals),
the gimbal-lock suppression's bias against its prediction, and the FDOP circle (FDOP = √2,
the fraction of fixes inside FDOP·σ_θ against the probability the covariance implies).
Each test prints the agreement it measures (``pytest -s``)."""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.stats import binom, chi2

from gimbal_estimators.free_gyro_drift import gauss_markov_integral_variance, random_walk_window_time
from gimbal_kinematics.maths.free_gyro import fix_geometry, spin_axes_for_site_deg
from gimbal_kinematics.maths.units import DEG_H, DEG_RT_H
from gimbal_sim.experiments import free_gyro_errors as fe
from gimbal_sim.world.sensors.free_gyro_sensor import FreeGyroSensor, FreeGyroSensorParams
from gimbal_sim.world.sensors.gyro import GyroParams

LAT, LON = math.radians(35.0), math.radians(129.0)
U_A, U_B = spin_axes_for_site_deg(35.0, 129.0, (60.0, 50.0), (-40.0, 50.0))
EULER = (0.02, -0.01, 0.7)


def _sensors(n: int, **kw) -> list[FreeGyroSensor]:
    sp = FreeGyroSensorParams(U_A, U_B, pickoff_noise_arcsec=0.0, triad=GyroParams(), **kw)
    return [FreeGyroSensor(sp, np.random.default_rng([seed, 44]), 1.0) for seed in range(n)]


def _angle(u, v) -> float:
    return math.atan2(float(np.linalg.norm(np.cross(u, v))), float(np.dot(u, v)))


def test_gauss_markov_drift_matches_closed_forms():
    """Rate: variance σ², lag correlation e^{−L/τ}; axis error: per-axis variance
    2 σ² τ² (t/τ − 1 + e^{−t/τ}) (the sensor starts the rate stationary, at t = 0)."""
    sigma_deg_h, tau = 20.0, 15.0
    n, lag, steps = 300, 15, 45
    sensors = _sensors(n, gm_drift_sigma_deg_h=sigma_deg_h, gm_drift_tau_s=tau)
    x_at, ang2 = {}, {}
    for t in range(1, steps + 1):
        for k, s in enumerate(sensors):
            s.update(float(t), LAT, LON, EULER, (0.0, 0.0, 0.0), 1.0)
        if t in (10, 10 + lag):
            x_at[t] = np.array([np.concatenate(s.gm_drift_rates) for s in sensors]).ravel()
        if t in (5, 20, 45):
            axes0 = [s.released_axes_i for s in sensors]
            ang2[t] = np.array([_angle(a, b) ** 2 for s, u0 in zip(sensors, axes0)
                                for a, b in zip(s.spin_axes_i(t), u0)])
    sigma = sigma_deg_h * DEG_H
    var_x = float(np.mean(x_at[10] ** 2))
    rho = float(np.corrcoef(x_at[10], x_at[10 + lag])[0, 1])
    m = x_at[10].size
    print(f"GM rate: variance / σ² = {var_x / sigma**2:.3f} ({m} draws), correlation at lag {lag} s "
          f"{rho:.3f} vs e^(-L/τ) = {math.exp(-lag / tau):.3f}")
    lo, hi = chi2.ppf([0.0005, 0.9995], m) / m
    assert lo < var_x / sigma**2 < hi
    assert abs(rho - math.exp(-lag / tau)) < 4.0 * (1.0 - math.exp(-2 * lag / tau)) / math.sqrt(m)
    for t, a2 in ang2.items():
        model = 2.0 * gauss_markov_integral_variance(sigma, tau, t)   # two axes ⊥ u
        r = float(np.mean(a2)) / model
        dof = 2 * a2.size   # each angle² is σ² χ²₂
        lo, hi = chi2.ppf([0.0005, 0.9995], dof) / dof
        print(f"t = {t} s: axis error² mean / closed form = {r:.3f} (99.9 % range {lo:.3f}-{hi:.3f})")
        assert lo < r < hi


def test_gauss_markov_integral_limits():
    """The closed form's limits: σ² t² for t ≪ τ (a constant), 2 σ² τ t for t ≫ τ (a random walk)."""
    s, tau = 1e-5, 300.0
    assert gauss_markov_integral_variance(s, tau, 0.03) == pytest.approx((s * 0.03) ** 2, rel=1e-4)
    assert gauss_markov_integral_variance(s, tau, 3e6) == pytest.approx(2 * s * s * tau * 3e6, rel=1e-3)
    # the window mean of a random walk: Σᵢⱼ min(tᵢ, tⱼ)/n² by brute force
    t = 3.0 + 0.1 * np.arange(100)
    assert random_walk_window_time(3.0, 100, 0.1) == pytest.approx(np.mean(np.minimum.outer(t, t)), rel=1e-12)


def test_integrated_rate_sensors_random_walk_grows_as_t():
    """Spin-axis rate sensors integrated from t = 0: the read-out's angle to the true axis has
    mean square 2 N² t (two axes), so mean square / t is constant; increments independent. With
    no rate-sensor noise (angle pickoffs, no pickoff noise) the read-out is the true axis."""
    arw = 0.5   # °/√h
    n_rate = arw * DEG_RT_H
    sensors = _sensors(400, spin_rate_arw_deg_rt_h=arw)
    err = {}
    for t in range(1, 81):
        samples = [s.update(float(t), LAT, LON, EULER, (0.0, 0.0, 0.0), 1.0) for s in sensors]
        if t in (5, 20, 80):
            err[t] = np.array([s.rate_sensor_error_i[0] for s in sensors])
            a2 = np.array([_angle(x.spin_a_b, x.true_spin_a_b) ** 2 for x in samples]
                          + [_angle(x.spin_b_b, x.true_spin_b_b) ** 2 for x in samples])
            r = float(np.mean(a2)) / (2.0 * n_rate**2 * t)
            dof = 2 * a2.size
            lo, hi = chi2.ppf([0.0005, 0.9995], dof) / dof
            print(f"t = {t:2d} s: read-out angle² mean / (2 N² t) = {r:.3f} (99.9 % range {lo:.3f}-{hi:.3f})")
            assert lo < r < hi
    inc = err[80] - err[20]
    c = float(np.sum(inc * err[20]) / math.sqrt(np.sum(inc**2) * np.sum(err[20] ** 2)))
    print(f"correlation of the 20-80 s increment with the 20 s error: {c:+.3f}")
    assert abs(c) < 4.0 / math.sqrt(2 * len(sensors))
    quiet = _sensors(1)[0].update(10.0, LAT, LON, EULER, (0.0, 0.0, 0.0), 1.0)
    assert np.allclose(quiet.spin_a_b, quiet.true_spin_a_b, atol=1e-15)


N_RUNS = 40
SOURCES = ("caging", "gm_drift", "rate_sensors", "drifting")


@pytest.fixture(scope="module")
def runs() -> dict[str, list[dict]]:
    return {v: [fe.campaign_run(v, seed, fe.DEFAULTS) for seed in range(1, N_RUNS + 1)] for v in SOURCES}


def test_monte_carlo_against_error_model_per_source(runs):
    """Std / model σ of the last fix's nadir errors and position drms, per source, inside the
    99.9 % χ² range of N_RUNS draws (the 200-run table in docs/results/paper4.md asks 15 %)."""
    lo, hi = np.sqrt(chi2.ppf([0.0005, 0.9995], N_RUNS - 1) / (N_RUNS - 1))
    for v in SOURCES:
        t = fe.variant_table(runs[v])
        ratios = [t["nadir_a"]["ratio"], t["nadir_b"]["ratio"], t["heading"]["ratio"]]
        print(f"{v}: std/σ nadir a {ratios[0]:.3f}, b {ratios[1]:.3f}, heading {ratios[2]:.3f}, "
              f"position drms {t['position_drms_m']['ratio']:.3f} (range {lo:.3f}-{hi:.3f})")
        assert all(lo < r < hi for r in ratios)
        # drms: the mean of two χ² components, 2(N−1) degrees of freedom
        dlo, dhi = np.sqrt(chi2.ppf([0.0005, 0.9995], 2 * (N_RUNS - 1)) / (2 * (N_RUNS - 1)))
        assert dlo < t["position_drms_m"]["ratio"] < dhi


def test_suppression_bias_against_prediction():
    """The gimbal-lock suppression (guard wide enough for gyro b to enter it) biases gyro b's
    nadir and the fix; the mean over a few runs against the model's bias from the attitude
    history, within 5 % (the pickoff noise is 0.5″ against a ~220″ bias)."""
    rs = [fe.campaign_run("suppression", seed, fe.DEFAULTS) for seed in (1, 2, 3)]
    t = fe.variant_table(rs)
    for name in ("nadir_b", "north_m", "east_m", "heading"):
        print(f"suppression {name}: MC mean / model bias = {t[name]['bias_ratio']:.4f}")
        assert 0.95 < t[name]["bias_ratio"] < 1.05
    assert abs(t["nadir_a"]["mean_over_sigma"]) < 3.0 and math.isnan(t["nadir_a"]["bias_ratio"])


def test_fdop_circle_headline(runs):
    """FDOP = √2 at Δα = 90° (eq. 37); each run's last fix inside eq. 38's FDOP·σ_θ circle as
    often as the model's covariance implies (≈ 1 − e⁻¹), within a binomial 99.9 % range."""
    g = fix_geometry(U_A, U_B, LAT, LON, 0.0)
    assert g.fdop == pytest.approx(math.sqrt(2.0), rel=1e-9)
    last = [r["fixes"][-1] for v in SOURCES for r in runs[v]]
    assert all(f["fdop"] == pytest.approx(math.sqrt(2.0), rel=1e-3) for f in last)
    inside = sum(math.hypot(*f["errors"][2:4]) <= f["fdop_radius_m"] for f in last)
    p = float(np.mean([f["p_circle"] for f in last]))
    lo, hi = binom.ppf([0.0005, 0.9995], len(last), p)
    print(f"inside FDOP·σ_θ: {inside}/{len(last)} = {inside / len(last):.3f}; covariance implies {p:.3f} "
          f"(99.9 % range {lo / len(last):.3f}-{hi / len(last):.3f}); paper 1 − e⁻¹ = {1 - math.exp(-1):.3f}")
    assert abs(p - (1.0 - math.exp(-1.0))) < 0.01
    assert lo <= inside <= hi


def test_positioning_core_claims_the_rate_sensors_walk_from_its_own_figure():
    """The core's fix σ with its own ``spin_rate_arw_deg_rt_h``: the pickoff σ²/n plus the
    window mean's random walk N² Σᵢⱼ min(tᵢ, tⱼ)/n² (brute force here), independent of the
    sensor's figure (set to another value: the core is told 0.008 °/√h, the sensor has 0.01)."""
    from gimbal_estimators.free_gyro_positioning import FreeGyroPositioningParams
    from gimbal_kinematics.maths.units import ARCSEC
    from gimbal_sim.experiments.free_gyro import run_free_gyro_experiment, simulate_truth
    truth = simulate_truth("paper5_ship", 35.0, 129.0, 30.1, 10.0)
    sp = FreeGyroSensorParams(U_A, U_B, pickoff_noise_arcsec=5.0, spin_rate_arw_deg_rt_h=0.01)
    cp = FreeGyroPositioningParams(U_A, U_B, nadir_noise_arcsec=5.0, spin_rate_arw_deg_rt_h=0.008)
    run = run_free_gyro_experiment(3, truth, 35.0, 129.0, sp, cp)
    assert len(run.fixes) >= 2
    for fix in run.fixes:
        t = fix.t + 0.1 * (np.arange(fix.n_samples) - 0.5 * (fix.n_samples - 1))
        walk = float(np.mean(np.minimum.outer(t, t)))
        want = (5.0 * ARCSEC) ** 2 / fix.n_samples + (0.008 * DEG_RT_H) ** 2 * walk
        print(f"fix at {fix.t:.2f} s: σ_θ {fix.nadir_sigma / ARCSEC:.4f}″ vs {math.sqrt(want) / ARCSEC:.4f}″")
        assert fix.nadir_sigma ** 2 == pytest.approx(want, rel=1e-3)
