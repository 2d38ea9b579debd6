"""Paper 5's original attitude matching (eq. 1) against scipy rotations, numerical
differentiation, Monte Carlo NEES (chi-square band from scipy), the gimbal_sim flexure and
LGU models, the simplified filter on the same runs, and bad input."""
import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation
from scipy.stats import chi2

from lgu_pairs import Fed
from gimbal_estimators import flexure_attitude_matching as am
from gimbal_estimators.flexure_attitude_matching import AttitudeMatchingKf, AttitudeMatchingParams
from gimbal_estimators.flexure_kf import FlexureKfParams
from gimbal_estimators.flexure_method_comparison import LguRun, compare_methods, flexure_covariance
from gimbal_kinematics.params.table import ParameterError
from gimbal_sim.world.sensors import FlexureParams
from gimbal_sim.world.sensors.flexure import ShipFlexureTruth
from gimbal_sim.world.sensors.lgu import LguPair

AS = math.pi / 180.0 / 3600.0
DEG = math.pi / 180.0
DEG_H = DEG / 3600.0
T = 0.1


def _ship_dcm(t):
    """Rocking ship attitude C_i1b1(t): 5°, 3°, 3° at 10 s, 6 s, 15 s periods."""
    a = np.array([5.0 * math.sin(0.628 * t), 3.0 * math.sin(1.047 * t), 3.0 * math.sin(0.419 * t)]) * DEG
    return Rotation.from_rotvec(a).as_matrix()


def _rot(v):
    return Rotation.from_rotvec(v).as_matrix()


def sim_run(seed, duration_s, flexure=None, lgu1=None, lgu2=None):
    """One run of the gimbal_sim flexure truth and LGU pair on the rocking ship (exact body
    increments), as an :class:`LguRun` with the true flexure at each stamp."""
    rng = np.random.default_rng(seed)
    kw = {k: v for k, v in (("lgu1", lgu1), ("lgu2", lgu2)) if v is not None}
    pair = LguPair(ShipFlexureTruth(flexure or FlexureParams(), rng, T), rng, T, **kw)
    n = int(round(duration_s / T))
    t = T * np.arange(1, n + 1)
    d1, d2, truth = np.empty((n, 3)), np.empty((n, 3)), np.empty((n, 3))
    C_prev = _ship_dcm(0.0)
    for k in range(n):
        C = _ship_dcm(t[k])
        m1, m2 = pair.step(Rotation.from_matrix(C_prev.T @ C).as_rotvec(), T)
        d1[k], d2[k], truth[k] = m1, m2, pair.flexure.angle
        C_prev = C
    return LguRun(t, d1, d2, np.full(n, T), truth)


def feed(kf, run, start=0, stop=None):
    est = None
    for k in range(start, run.t.size if stop is None else stop):
        kf.on_lgu1(run.t[k], run.dalpha1[k], run.dt[k])
        e = kf.on_lgu2(run.t[k], run.dalpha2[k], run.dt[k])
        est = e if e is not None else est
    return est


# ---------------------------------------------------------------- observation (eq. 1)
def _random_geometry(rng, scale):
    C1 = _rot(rng.normal(0.0, 0.1, 3))
    phi0, phi, r1, r2 = (rng.normal(0.0, scale, 3) for _ in range(4))
    return C1, phi0, phi, r1, r2


def test_predicted_observation_matches_exact_rotations():
    """Ĉ_ib = exp(−[θ×]) C_ib, C_i2b2 = exp(−[φ0×]) C_i1b1 exp([φ×]): the matrix logarithm of
    Ĉ_i1b1ᵀ Ĉ_i2b2 (scipy) against eq. 1 (first order) and the second-order form."""
    rng = np.random.default_rng(1)
    worst1 = worst2 = 0.0
    for _ in range(50):
        C1, phi0, phi, r1, r2 = _random_geometry(rng, 2e-3)  # 0.1°-scale angles
        C1_hat = _rot(-r1) @ C1
        C2_hat = _rot(-r2) @ _rot(-phi0) @ C1 @ _rot(phi)
        z = Rotation.from_matrix(C1_hat.T @ C2_hat).as_rotvec()
        x = np.zeros(am.N_STATES)
        x[am.PHI_K], x[am.PHI_0], x[am.THETA_R1], x[am.THETA_R2] = phi, phi0, r1, r2
        first = am.observation_matrix(C1_hat, C2_hat) @ x  # eq. 1 as printed
        worst1 = max(worst1, float(np.max(np.abs(z - first))))
        worst2 = max(worst2, float(np.max(np.abs(z - am.predicted_observation(C1_hat, x)))))
    assert worst2 < 0.05 * AS  # third order: (4e-3)³ ≈ 0.01″
    assert worst1 > 20 * worst2  # the second-order terms are real (and the test can fail)
    assert worst1 < 10 * AS


def test_observation_matrix_is_the_jacobian_to_first_order():
    """Central differences of h(X) at small X equal eq. 1's H to O(|X|)."""
    rng = np.random.default_rng(2)
    C1, phi0, phi, r1, r2 = _random_geometry(rng, 1e-3)
    C2 = _rot(-r2) @ _rot(-phi0) @ C1 @ _rot(phi)
    x = np.zeros(am.N_STATES)
    x[am.PHI_K], x[am.PHI_0], x[am.THETA_R1], x[am.THETA_R2] = phi, phi0, r1, r2
    J = np.empty((3, am.N_STATES))
    for j in range(am.N_STATES):
        dx = np.zeros(am.N_STATES)
        dx[j] = 1e-6
        J[:, j] = (am.predicted_observation(C1, x + dx) - am.predicted_observation(C1, x - dx)) / 2e-6
    H = am.observation_matrix(C1, C2)
    assert np.max(np.abs(J - H)) < 1e-2  # |X| ≈ 2e-3 rad
    assert np.all(H[:, am.PHI_K1] == 0.0) and np.all(H[:, am.EPS1.start:] == 0.0)


# ---------------------------------------------------------------- consistency
def _model_consistent_final_nees(params, duration_s, seed):
    """Truth drawn from the filter's prior and its flexure and bias models, observed through
    exact rotations with each unit's own bias and angle random walk in its increments.
    Returns the NEES of the total flexure at the last epoch (3 dof)."""
    rng = np.random.default_rng(seed)
    kf = Fed(AttitudeMatchingKf(params))
    F, Q = kf.discrete_model(T)  # θr, θr' come from the increments, not from F
    kf.on_lgu1(T, [0.0, 0.0, 0.0], T)
    kf.on_lgu2(T, [0.0, 0.0, 0.0], T)
    x = rng.multivariate_normal(np.zeros(am.N_STATES), kf.covariance)
    L = np.linalg.cholesky(Q + 1e-30 * np.eye(am.N_STATES))
    arw = params.lgu_arw_deg_rt_h * DEG / 60.0 * math.sqrt(T)
    phi = x[am.PHI_K] + x[am.THETA_K]
    C_i2i1 = _rot(phi).T
    C1p, C2p = _ship_dcm(0.0), C_i2i1 @ _ship_dcm(0.0) @ _rot(phi)
    kf = Fed(AttitudeMatchingKf(params))
    for k in range(1, int(round(duration_s / T)) + 1):
        t = k * T
        x = F @ x + L @ rng.standard_normal(am.N_STATES)
        phi = x[am.PHI_K] + x[am.THETA_K]
        C1 = _ship_dcm(t)
        C2 = C_i2i1 @ C1 @ _rot(phi)
        d1 = Rotation.from_matrix(C1p.T @ C1).as_rotvec() + x[am.EPS1] * T + rng.normal(0.0, arw, 3)
        d2 = Rotation.from_matrix(C2p.T @ C2).as_rotvec() + x[am.EPS2] * T + rng.normal(0.0, arw, 3)
        C1p, C2p = C1, C2
        kf.on_lgu1(t, d1, T)
        est = kf.on_lgu2(t, d2, T)
    err = est.flexure - phi
    assert kf.counters["updates"] == k and kf.counters["gated"] == 0
    return float(err @ np.linalg.solve(flexure_covariance(kf), err))


def test_nees_of_the_flexure_is_within_its_chi_square_band():
    """One epoch per run (independent runs): the sum of N NEES values is chi-square with 3N
    degrees of freedom when the filter's model is the truth's."""
    params = AttitudeMatchingParams(qs_initial_sigma_deg=0.1, qs_rate_initial_sigma_deg_h=1.0,
                                    qs_rate_rw_arcsec_s_rt_s=0.05, bias_diff_initial_sigma_deg_h=1.0)
    n = 16
    values = np.array([_model_consistent_final_nees(params, 45.0, seed) for seed in range(n)])
    lo, hi = chi2.ppf([0.025, 0.975], 3 * n) / n
    print(f"\nmodel-consistent NEES, {n} runs x 45 s, final epoch: mean {values.mean():.2f} "
          f"(95 % band {lo:.2f}..{hi:.2f})")
    assert lo < values.mean() < hi


# ---------------------------------------------------------------- the paper's ship, both methods
@pytest.fixture(scope="module")
def paper_runs():
    # Paper 5 §5.1 truth (0.1° initial, 0.2 °/h, 90″ at 1 h, helm 0.1° at 200 s, dynamic
    # 20″/60″/40″; LGU biases ±0.05 °/h): two seeds of 12 min.
    return [sim_run(seed, 720.0) for seed in (0, 1)]


def test_original_and_simplified_methods_on_the_same_runs(paper_runs):
    """With per-unit bias priors of σ_diff/√2 both filters model the same flexure, so their
    errors agree; the CPU time per LGU pair is reported, not asserted."""
    res = compare_methods(paper_runs, convergence_s=480.0)
    o, s = res["original"], res["simplified"]
    for name, r in res.items():
        print(f"\n{name}: flexure RMS error {np.round(r.rms_arcsec, 2)} arcsec over {r.epochs} epochs, "
              f"NEES mean {r.nees_mean:.2f}, final {np.round(r.final_nees, 2)}, "
              f"CPU {r.cpu_us_per_pair:.0f} us per LGU pair ({r.pairs} pairs)")
    assert o.pairs == s.pairs == 2 * 7200 and o.epochs == s.epochs == 2 * 2400
    assert np.all(np.abs(o.rms_arcsec - s.rms_arcsec) < 0.05 * s.rms_arcsec)
    assert np.all(o.rms_arcsec < 60.0)  # converged: well below the 360″ helm sinusoid
    assert 1.0 < o.nees_mean < 9.0
    assert o.cpu_us_per_pair > 0.0 and s.cpu_us_per_pair > 0.0


def test_constant_flexure_is_recovered_within_its_sigma():
    """Constant flexure (no drift, sinusoids or dynamic part) on the sim's LGUs: the estimate
    after 10 min is within 2σ of the truth on every axis, with σ of a few arcseconds."""
    flex = FlexureParams(initial_deg=(0.1, -0.05, 0.08), linear_rate_deg_h=0.0, slow_amplitude_arcsec=0.0,
                         helm_amplitude_deg=0.0, dynamic_rms_arcsec=0.0)
    run = sim_run(3, 600.0, flexure=flex)
    params = AttitudeMatchingParams(quasi_static_model="random_constant", dynamic_rms_arcsec=1.0)
    est = feed(Fed(AttitudeMatchingKf(params)), run)
    err = est.flexure - run.truth[-1]
    print(f"\nconstant flexure: error {np.round(err / AS, 2)} arcsec, sigma {np.round(est.flexure_sigma / AS, 2)}")
    assert np.all(np.abs(err) < 2.0 * est.flexure_sigma)
    assert np.all(est.flexure_sigma < 5.0 * AS)
    assert np.all(np.abs(est.bias_diff - 0.1 * DEG_H) < 3.0 * est.bias_diff_sigma)  # ε1 − ε2 = 0.1 °/h


# ---------------------------------------------------------------- bad input
@pytest.fixture(scope="module")
def short_run():
    return sim_run(5, 30.0)


def test_bad_samples_are_counted_and_not_fused(short_run):
    run = short_run
    clean = Fed(AttitudeMatchingKf())
    ref = feed(clean, run)
    kf = Fed(AttitudeMatchingKf())
    feed(kf, run, 0, 100)
    t, d, dt = run.t[99], run.dalpha1[99], run.dt[99]
    kf.on_lgu1(t + 0.05, [math.nan, 0.0, 0.0], T)
    kf.on_lgu2(t + 0.05, [0.0, math.inf, 0.0], T)
    kf.on_lgu1(math.nan, d, dt)
    kf.on_lgu1(t + 0.05, [0.0, 0.0], T)
    kf.on_lgu1(t + 0.05, "abc", T)
    kf.on_lgu1(t, d, dt)  # the stamp of the last pair again: out of order
    kf.on_lgu2(t - 0.5, d, dt)  # backward, within the clock-jump limit
    kf.on_lgu1(run.t[100], run.dalpha1[100], run.dt[100])
    est = feed(kf, run, 100)  # whose first LGU1 sample is then a duplicate
    c = kf.counters
    assert c["nonfinite"] == 3 and c["malformed"] == 2 and c["out_of_order"] == 2 and c["duplicates"] == 1
    assert c["resets"] == 0 and c["updates"] == clean.counters["updates"] == run.t.size
    np.testing.assert_array_equal(est.flexure, ref.flexure)
    np.testing.assert_array_equal(kf.covariance, clean.covariance)


def test_gap_reanchors_and_clock_jump_resets(short_run):
    run = short_run
    kf = Fed(AttitudeMatchingKf())
    feed(kf, run, 0, 100)
    sigma_before = kf.estimate().flexure_sigma
    est = feed(kf, run, 105)  # five pairs lost: re-anchor, keep what was learnt
    assert kf.counters["gaps"] == 1 and kf.counters["reanchors"] == 1 and kf.counters["resets"] == 0
    x = kf.state
    np.testing.assert_allclose(x[am.PHI_0] - x[am.THETA_R1] + x[am.THETA_R2], est.relative_attitude)
    assert np.all(est.flexure_sigma < sigma_before)
    assert np.all(np.abs(est.flexure - run.truth[-1]) < 5.0 * est.flexure_sigma)
    kf.reset("backward clock jump")  # 19 s back: the input policy's verdict
    kf.on_lgu1(run.t[10], run.dalpha1[10], run.dt[10])
    assert kf.counters["resets"] == 1 and "backward clock jump" in kf.last_reset_reason
    assert not kf.initialized


# ---------------------------------------------------------------- parameters and shapes
def test_states_covariance_and_parameters():
    kf = Fed(AttitudeMatchingKf())
    kf.on_lgu1(T, [0.0, 0.0, 0.0], T)
    kf.on_lgu2(T, [0.0, 0.0, 0.0], T)
    assert kf.state.shape == (27,) and kf.covariance.shape == (27, 27)
    P = kf.covariance
    # Per-unit bias priors σ_diff/√2 give ε1 − ε2 the simplified filter's prior σ.
    var_diff = P[am.EPS1, am.EPS1] + P[am.EPS2, am.EPS2] - 2 * P[am.EPS1, am.EPS2]
    np.testing.assert_allclose(np.sqrt(np.diag(var_diff)), 0.1 * DEG_H, rtol=1e-3)  # after one update
    # θr starts exact and grows over one step by the angle random walk and the bias prior.
    arw, sigma_unit = 0.001 * DEG / 60.0, 0.1 / math.sqrt(2.0) * DEG_H
    np.testing.assert_allclose(np.diag(P[am.THETA_R1, am.THETA_R1]), arw ** 2 * T + (sigma_unit * T) ** 2, rtol=1e-2)
    with pytest.raises(TypeError):
        Fed(AttitudeMatchingKf(FlexureKfParams()))
    with pytest.raises(ValueError, match="meas_noise_arcsec"):  # the shared fields are checked too
        AttitudeMatchingParams(meas_noise_arcsec=-1.0)
    with pytest.raises(ValueError, match="lgu_bias_initial_sigma_deg_h"):
        AttitudeMatchingParams(lgu_bias_initial_sigma_deg_h=0.0)
    with pytest.raises(ValueError, match="lgu_bias_rw_deg_h_rt_h"):
        AttitudeMatchingParams(lgu_bias_rw_deg_h_rt_h=(0.1, -1.0, 0.1))
    from gimbal_estimators.flexure_estimator_params import PARAMS
    values = {p.name: p.default for p in PARAMS}
    p = AttitudeMatchingParams.from_values({**values, "lgu_bias_initial_sigma_deg_h": 0.05})
    assert p.lgu_bias_initial_sigma_deg_h == (0.05, 0.05, 0.05)
    assert p.simplified() == FlexureKfParams.from_values(values)
    default = AttitudeMatchingParams.from_values(values)
    assert default.lgu_bias_rw_deg_h_rt_h == pytest.approx((0.001 / math.sqrt(2),) * 3)
    with pytest.raises(ParameterError, match="lgu_bias_rw_deg_h_rt_h"):
        AttitudeMatchingParams.from_values({**values, "lgu_bias_rw_deg_h_rt_h": math.nan})
