"""Ship-flexure KF (paper 5) against scipy rotations, closed-form Markov statistics,
numerical differentiation, the gimbal_sim ship simulation, and bad input."""
import math

import numpy as np
import pytest
from scipy.linalg import solve_discrete_lyapunov
from scipy.spatial.transform import Rotation

from lgu_pairs import Fed
from gimbal_kinematics.timing.sync import StampPairs
from gimbal_estimators import flexure_kf as fk
from gimbal_estimators import flexure_model as fm
from gimbal_estimators.flexure_kf import FlexureKf, FlexureKfParams
from gimbal_kinematics.maths.rotations import dcm_from_rotation_vector, small_angles_from_dcm
from gimbal_kinematics.timing.input_policy import sample_policy
from gimbal_sim.experiments.flexure import run_flexure_comparison
from gimbal_sim.world.sensors import FlexureParams

AS = math.pi / 180.0 / 3600.0
DEG = math.pi / 180.0
DEG_H = DEG / 3600.0


# ---------------------------------------------------------------- synthetic LGU pair
def _ship_dcm(t):
    """Rocking ship attitude C_i1b1(t): 5°, 3°, 3° at 10 s, 6 s, 15 s periods."""
    a = np.array([5.0 * math.sin(0.628 * t), 3.0 * math.sin(1.047 * t), 3.0 * math.sin(0.419 * t)]) * DEG
    return Rotation.from_rotvec(a).as_matrix()


PHI_TRUE = np.array([0.5, -0.3, 0.4]) * DEG  # constant flexure, C_b1b2 = exp([φ×])
EPS_TRUE = np.array([0.1, -0.05, 0.08]) * DEG_H  # ε1 − ε2 in b1


def synthetic_pairs(duration_s, dt=0.1, phi=PHI_TRUE, eps=EPS_TRUE, wobble_arcsec=0.0):
    """(t, Δα1, Δα2) of two LGUs on a rocking ship with flexure
    ``φ(t) = phi + wobble·(sin 0.5t, cos 0.5t, sin 0.7t)`` (C_b1b2 = exp([φ×])); LGU1's bias
    minus LGU2's is ``eps`` (LGU2 unbiased). Exact increments (matrix logarithm)."""
    w = wobble_arcsec * AS

    def flex(t):
        return Rotation.from_rotvec(phi + w * np.array([math.sin(0.5 * t), math.cos(0.5 * t) - 1.0,
                                                          math.sin(0.7 * t)])).as_matrix()

    C_i2i1 = flex(0.0).T  # i2 = b2(t0)
    out, C1_prev, C2_prev = [], _ship_dcm(0.0), C_i2i1 @ _ship_dcm(0.0) @ flex(0.0)
    for k in range(1, int(round(duration_s / dt)) + 1):
        t = k * dt
        C1 = _ship_dcm(t)
        C2 = C_i2i1 @ C1 @ flex(t)
        d1 = Rotation.from_matrix(C1_prev.T @ C1).as_rotvec()
        d2 = Rotation.from_matrix(C2_prev.T @ C2).as_rotvec()
        out.append((t, d1 + eps * dt, d2))
        C1_prev, C2_prev = C1, C2
    return out


def feed(kf, pairs, skip1=(), skip2=()):
    est = None
    for i, (t, d1, d2) in enumerate(pairs):
        if i not in skip1:
            e = kf.on_lgu1(t, d1, 0.1)
            est = e if e is not None else est
        if i not in skip2:
            e = kf.on_lgu2(t, d2, 0.1)
            est = e if e is not None else est
    return est


@pytest.fixture(scope="module")
def synthetic():
    return synthetic_pairs(300.0)


@pytest.fixture(scope="module")
def reference(synthetic):
    kf = Fed(FlexureKf())
    return feed(kf, synthetic), kf


#: A filter whose dynamic-flexure band (peaked at 0.5 rad/s) covers the wobble's 0.5 and
#: 0.7 rad/s; the default critically damped 10 s band would gate it as a model mismatch.
WOBBLE_BAND = FlexureKfParams(dynamic_beta_per_s=0.1, dynamic_freq_rad_s=0.5)


@pytest.fixture(scope="module")
def wobbly():
    """Flexure moving at up to 100″/s, so a lost sample also loses a flexure change."""
    return synthetic_pairs(300.0, wobble_arcsec=200.0)


@pytest.fixture(scope="module")
def wobbly_reference(wobbly):
    return feed(Fed(FlexureKf(WOBBLE_BAND)), wobbly)


# ---------------------------------------------------------------- models
def test_attitude_integration_matches_scipy_composition():
    rng = np.random.default_rng(3)
    kf = Fed(FlexureKf())
    R1, R2 = Rotation.identity(), Rotation.identity()
    for k in range(1, 400):
        d1 = rng.normal(0.0, 0.02, 3)
        d2 = d1 + rng.normal(0.0, 1e-5, 3)
        kf.on_lgu1(0.1 * k, d1, 0.1)
        kf.on_lgu2(0.1 * k, d2, 0.1)
        R1, R2 = R1 * Rotation.from_rotvec(d1), R2 * Rotation.from_rotvec(d2)
    C1, C2 = kf.attitudes
    np.testing.assert_allclose(C1, R1.as_matrix(), atol=1e-12)
    np.testing.assert_allclose(C2, R2.as_matrix(), atol=1e-12)
    # The inline extraction is small_angles_from_dcm.
    np.testing.assert_allclose(fm.match_attitudes(C1, C2), small_angles_from_dcm(C1.T @ C2), atol=1e-15)


@pytest.mark.parametrize("beta, lam, dt", [(0.1, 0.5, 0.1), (0.1, 0.5, 0.02), (0.3, 1.2, 0.1), (0.2, 0.0, 0.1)])
def test_ar2_matches_second_order_markov(beta, lam, dt):
    sigma = 40.0 * AS
    a1, a2, var_e = fm.ar2_coefficients(beta, lam, sigma, dt)
    # Poles are the exact ones exp((−β ± jλ)dt).
    np.testing.assert_allclose(np.sort_complex(np.roots([1.0, -a1, -a2])),
                               np.sort_complex(np.exp(np.array([-beta - 1j * lam, -beta + 1j * lam]) * dt)), atol=1e-12)
    # Stationary variance (discrete Lyapunov of the companion form) is σ².
    Fc = np.array([[a1, a2], [1.0, 0.0]])
    Pc = solve_discrete_lyapunov(Fc, np.diag([var_e, 0.0]))
    assert Pc[0, 0] == pytest.approx(sigma ** 2, rel=1e-9)
    # Autocorrelation vs the continuous closed form e^{−βτ}(cos λτ + (β/λ) sin λτ).
    lags = int(round(60.0 / dt))
    tau = np.arange(lags + 1) * dt
    if lam > 0:
        closed = np.exp(-beta * tau) * (np.cos(lam * tau) + (beta / lam) * np.sin(lam * tau))
    else:
        closed = np.exp(-beta * tau) * (1.0 + beta * tau)
    rho = fm.ar2_autocorrelation(a1, a2, lags)
    assert np.max(np.abs(rho - closed)) < 2e-3
    assert Pc[0, 1] / Pc[0, 0] == pytest.approx(rho[1], rel=1e-12)


def test_discrete_model_blocks_follow_eq_10_and_12():
    T = 0.1
    rwr = Fed(FlexureKf(FlexureKfParams(quasi_static_model="random_walk_rate", qs_rate_rw_arcsec_s_rt_s=2.0,
                                    dynamic_beta_per_s=0.1, dynamic_freq_rad_s=0.5)))
    rc = Fed(FlexureKf(FlexureKfParams(quasi_static_model="random_constant", qs_rw_arcsec_rt_s=0.5)))
    F, Q = rwr.discrete_model(T)
    I3 = np.eye(3)
    np.testing.assert_array_equal(F[0:3, 0:3], 2 * I3)
    np.testing.assert_array_equal(F[0:3, 3:6], -I3)
    np.testing.assert_array_equal(F[3:6, 0:3], I3)
    np.testing.assert_allclose(np.diag(Q[0:3, 0:3]), (2.0 * AS) ** 2 * T ** 3)
    F2, Q2 = rc.discrete_model(T)
    np.testing.assert_array_equal(F2[0:3, 0:3], I3)
    np.testing.assert_array_equal(F2[0:3, 3:6], 0 * I3)
    np.testing.assert_allclose(np.diag(Q2[0:3, 0:3]), (0.5 * AS) ** 2 * T)
    for i, s in enumerate((20.0, 60.0, 40.0)):
        a1, a2, ve = fm.ar2_coefficients(0.1, 0.5, s * AS, T)
        assert (F[6 + i, 6 + i], F[6 + i, 9 + i], Q[6 + i, 6 + i]) == pytest.approx((a1, a2, ve))
    np.testing.assert_array_equal(F[15:18, 15:18], I3)
    np.testing.assert_array_equal(F[12:15, 15:18], 0 * I3)  # filled per step with C̄ dt


def test_observation_matrix_matches_numerical_derivative():
    """Z(X) from the frame model C_i2b2 = C_i2i1 C_i1b1 C_b1b2 with C_i1i2 = exp([θ_d×]) and
    C_b1b2 = exp([(Φ + θ)×]); its Jacobian is H = [I 0 I 0 −Ĉ_i1b1ᵀ 0]."""
    rng = np.random.default_rng(8)
    C1 = Rotation.random(random_state=rng.integers(1 << 31)).as_matrix()

    def z_of(x):
        C_b1b2 = dcm_from_rotation_vector(x[0:3] + x[6:9])
        C_i2i1 = dcm_from_rotation_vector(x[12:15]).T
        return fm.match_attitudes(C1, C_i2i1 @ C1 @ C_b1b2)

    x0 = rng.normal(0.0, 1e-3, 18)
    h = 1e-7
    J = np.column_stack([(z_of(x0 + h * e) - z_of(x0 - h * e)) / (2 * h) for e in np.eye(18)])
    H = fm.observation_matrix(C1)
    np.testing.assert_allclose(J, H, atol=5e-3)  # second-order terms at |x| ~ 1e-3
    J0 = np.column_stack([(z_of(h * e) - z_of(-h * e)) / (2 * h) for e in np.eye(18)])
    np.testing.assert_allclose(J0, H, atol=1e-7)
    assert np.max(np.abs(z_of(x0) - H @ x0)) < 1e-5  # residual second order
    # The second-order prediction leaves third order only.
    x1 = rng.normal(0.0, 5e-3, 18)
    assert np.max(np.abs(z_of(x1) - H @ x1)) > 1e-5
    assert np.max(np.abs(z_of(x1) - fm.predicted_observation(C1, x1))) < 1e-6


def test_observation_model_against_the_ship_simulation():
    """Z = φ − Ĉ_i1b1ᵀ θ_d with θ_d = φ(t0) + ∫Ĉ_i1b1 (ε1 − ε2) dt, on the gimbal_sim ship
    (noise-free LGUs with ±0.05 °/h biases, earth rate on), to under 1″ (paper's first
    order) and 0.3″ (second order; over the 2 h scenario: 4″ and 0.4″)."""
    from gimbal_sim.world.sensor_suite import SensorSuite, SensorSuiteConfig
    from gimbal_sim.world.sensors import GyroParams
    from gimbal_sim.world.vehicle import VehicleConfig, VehicleCore

    vc = VehicleCore(VehicleConfig(profile="paper5_ship", plant="host_only", sim_rate_hz=50.0, duration_s=240.0))
    ss = SensorSuite(SensorSuiteConfig(sensors=("lgu",), sim_rate_hz=50.0, lgu_rate_hz=10.0, seed=4,
                                       lgu1=GyroParams(bias_deg_h=0.05), lgu2=GyroParams(bias_deg_h=-0.05)))
    kf = Fed(FlexureKf())
    theta_d = np.array(ss.lgu.flexure.angle)
    worst = worst2 = 0.0
    while True:
        for s in ss.update(vc.truth()):
            C_old = kf.attitudes[0]
            kf.on_lgu1(s.t, s.dalpha1, s.dt)
            kf.on_lgu2(s.t, s.dalpha2, s.dt)
            C1, C2 = kf.attitudes
            eps = ss.lgu.lgu1.true_bias - ss.lgu.lgu2.true_bias
            theta_d = theta_d + 0.5 * (C_old + C1) @ eps * s.dt
            z = fm.match_attitudes(C1, C2)
            worst = max(worst, float(np.max(np.abs(z - (np.array(s.flexure) - C1.T @ theta_d)))))
            x = np.zeros(18)
            x[0:3], x[12:15] = s.flexure, theta_d
            worst2 = max(worst2, float(np.max(np.abs(z - fm.predicted_observation(C1, x)))))
        if vc.finished:
            break
        vc.step()
    assert worst < 1.0 * AS
    assert worst2 < 0.3 * AS
    assert np.linalg.norm(theta_d - np.array(ss.lgu.flexure.angle)) > 20 * AS  # the test can fail


def _model_consistent_run(params, duration_s, seed):
    """Truth drawn from the filter's own model (prior, F, Q; biases and angle random walk
    in the LGU increments; exact rotations), fed as increments. Returns per-epoch NEES of
    the total flexure (3 dof, full 3×3 covariance)."""
    rng = np.random.default_rng(seed)
    kf = Fed(FlexureKf(params))
    T = params.filter_period_s
    F, Q = kf.discrete_model(T)
    # The prior the filter starts from: the state after its first (anchoring) pair.
    kf.on_lgu1(T, [0.0, 0.0, 0.0], T)
    kf.on_lgu2(T, [0.0, 0.0, 0.0], T)
    x = rng.multivariate_normal(np.zeros(18), kf.covariance)
    x[12:15] = x[0:3] + x[6:9]
    L = np.linalg.cholesky(Q + 1e-30 * np.eye(18))
    arw = params.lgu_arw_deg_rt_h * DEG / 60.0 * math.sqrt(T)
    flex = lambda v: Rotation.from_rotvec(v).as_matrix()  # noqa: E731
    C_i2i1 = flex(x[0:3] + x[6:9]).T
    kf = Fed(FlexureKf(params))
    C1p, C2p = _ship_dcm(0.0), C_i2i1 @ _ship_dcm(0.0) @ flex(x[0:3] + x[6:9])
    M = np.zeros((3, 18))
    M[:, 0:3] = M[:, 6:9] = np.eye(3)
    out = []
    for k in range(1, int(round(duration_s / T)) + 1):
        t = k * T
        x = F @ x + L @ rng.standard_normal(18)
        phi = x[0:3] + x[6:9]
        C1 = _ship_dcm(t)
        C2 = C_i2i1 @ C1 @ flex(phi)
        d1 = Rotation.from_matrix(C1p.T @ C1).as_rotvec() + x[15:18] * T + rng.normal(0.0, arw, 3)
        d2 = Rotation.from_matrix(C2p.T @ C2).as_rotvec() + rng.normal(0.0, arw, 3)
        C1p, C2p = C1, C2
        kf.on_lgu1(t, d1, T)
        est = kf.on_lgu2(t, d2, T)
        err = est.flexure - phi
        out.append(float(err @ np.linalg.solve(M @ kf.covariance @ M.T, err)))
    return np.array(out)


@pytest.mark.parametrize("model", fk.QS_MODELS)
def test_filter_is_consistent_with_its_own_model(model):
    """Monte Carlo NEES of the total flexure ≈ 3 (chi-square, 3 dof) when the truth follows
    the filter's model: F, Q, H and the anchoring are mutually right."""
    params = FlexureKfParams(quasi_static_model=model, qs_rw_arcsec_rt_s=0.5)
    values = np.concatenate([_model_consistent_run(params, 150.0, seed) for seed in range(8)])
    # Epochs are correlated in time, so the band is wider than chi2(3·N)/N would give.
    assert 2.2 < values.mean() < 3.8
    assert np.mean(values < 14.16) > 0.97  # chi2(3) 99.73 % point


# ---------------------------------------------------------------- filter behaviour
def test_synthetic_constant_flexure_and_bias_difference_are_estimated(synthetic, reference):
    est, kf = reference
    assert kf.counters["updates"] == 3000 and kf.counters["gated"] == 0
    err = est.flexure - PHI_TRUE
    assert np.all(np.abs(err) < 3 * est.flexure_sigma + AS)
    # With a dynamic-flexure model matching this flexure-free hull the rocking modulation
    # pins θ_d, hence the flexure, within arcseconds in 300 s.
    kf2 = Fed(FlexureKf(FlexureKfParams(dynamic_rms_arcsec=2.0)))
    est2 = feed(kf2, synthetic)
    assert np.all(np.abs(est2.flexure - PHI_TRUE) < 3.0 * AS)
    assert np.all(np.abs(est2.flexure - PHI_TRUE) < 3 * est2.flexure_sigma + 0.5 * AS)
    assert np.all(np.abs(est2.bias_diff - EPS_TRUE) < 3 * est2.bias_diff_sigma)
    assert np.all(np.abs(est2.bias_diff - EPS_TRUE) < 0.02 * DEG_H)
    # The paper's first-order prediction H X leaves the ½ u×φ term: arcseconds at 0.5°.
    kf3 = Fed(FlexureKf(FlexureKfParams(dynamic_rms_arcsec=2.0, second_order_observation=False)))
    est3 = feed(kf3, synthetic)
    assert np.max(np.abs(est3.flexure - PHI_TRUE)) > 2.0 * AS


def test_first_pair_anchors_relative_attitude_to_the_flexure():
    """θ_d(t0) = φ(t0) (paper 5 after eq. 6): the prior ties θ_d to Φ + θ within the anchor σ."""
    kf = Fed(FlexureKf(FlexureKfParams(filter_period_s=0.3, anchor_sigma_arcsec=0.1)))
    kf.on_lgu1(0.1, [0.0, 0.0, 0.0], 0.1)
    assert kf.on_lgu2(0.1, [0.0, 0.0, 0.0], 0.1) is None  # no filter step yet
    P = kf.covariance
    assert np.all(np.linalg.eigvalsh(P) > 0.0)
    T = np.zeros((3, 18))
    T[:, 12:15] = np.eye(3)
    T[:, 0:3] = T[:, 6:9] = -np.eye(3)
    np.testing.assert_allclose(np.diag(T @ P @ T.T), (0.1 * AS) ** 2, rtol=1e-6)
    # ... while θ_d itself carries the full prior of the flexure (0.5° quasi-static).
    assert np.sqrt(P[12, 12]) > 0.4 * DEG


def test_nan_inf_and_malformed_are_rejected_and_counted(wobbly, wobbly_reference):
    kf = Fed(FlexureKf(WOBBLE_BAND))
    feed(kf, wobbly[:100])
    x0 = kf.state
    t_next, d1, _ = wobbly[100]
    assert kf.on_lgu1(t_next, [np.nan, 0.0, 0.0], 0.1) is None
    assert kf.on_lgu1(t_next, d1, np.inf) is None
    assert kf.on_lgu1(np.nan, d1, 0.1) is None
    assert kf.on_lgu1(t_next, [0.0, 0.0], 0.1) is None
    assert kf.on_lgu1(t_next, "abc", 0.1) is None
    assert kf.on_lgu1(t_next, d1, -0.1) is None
    assert kf.counters["nonfinite"] == 3 and kf.counters["malformed"] == 2 and kf.counters["bad_dt"] == 1
    np.testing.assert_array_equal(kf.state, x0)
    # The NaN sample's rotation is lost: the filter re-anchors at the next complete pair and
    # ends where the clean run does.
    est = feed(kf, wobbly[100:], skip1=(0,))
    assert kf.counters["unpaired"] == 1 and kf.counters["gaps"] == 1 and kf.counters["reanchors"] == 1
    assert np.all(np.isfinite(kf.covariance))
    np.testing.assert_allclose(est.flexure, wobbly_reference.flexure, atol=3 * AS)


@pytest.mark.parametrize("skip1, skip2", [((), (1500,)), ((1500, 1501), (1500, 1501))],
                         ids=["lgu2_sample_lost", "both_lost_two_stamps"])
def test_dropped_samples_reanchor_and_keep_the_estimate(wobbly, wobbly_reference, skip1, skip2):
    kf = Fed(FlexureKf(WOBBLE_BAND))
    est = feed(kf, wobbly, skip1=skip1, skip2=skip2)
    c = kf.counters
    assert c["gaps"] == 1 and c["reanchors"] == 1 and c["resets"] == 0 and c["gated"] == 0
    assert c["unpaired"] == (1 if skip2 == (1500,) else 0)
    # Both units lose the same interval, so the common rotation cancels in Ĉ_i1b1ᵀĈ_i2b2,
    # but the flexure change over it (10-20″ here) would stay in θ_d without re-anchoring.
    np.testing.assert_allclose(est.flexure, wobbly_reference.flexure, atol=3 * AS)
    np.testing.assert_allclose(est.bias_diff, wobbly_reference.bias_diff, atol=0.01 * DEG_H)


def test_out_of_order_and_duplicate_stamps_are_rejected(synthetic):
    kf = Fed(FlexureKf())
    feed(kf, synthetic[:50])
    x0 = kf.state
    t_prev, d1, d2 = synthetic[48]
    assert kf.on_lgu1(t_prev, d1, 0.1) is None
    assert kf.on_lgu2(t_prev - 0.05, d2, 0.1) is None
    assert kf.counters["out_of_order"] == 2
    t_new, d1, _ = synthetic[50]
    kf.on_lgu1(t_new, d1, 0.1)
    kf.on_lgu1(t_new, d1, 0.1)
    assert kf.counters["duplicates"] == 1
    np.testing.assert_array_equal(kf.state, x0)
    assert kf.counters["resets"] == 0


def test_backward_clock_jump_is_the_policys_reset(synthetic):
    """The core judges no clock: a sample stamped before the fused pairs is out of order;
    the sampled input policy sees the jump back and resets the core before the new run."""
    kf = Fed(FlexureKf())
    feed(kf, synthetic[:600])
    x = kf.state.copy()
    assert kf.on_lgu1(5.0, synthetic[0][1], 0.1) is None
    assert kf.counters["out_of_order"] == 1 and kf.counters["resets"] == 0
    np.testing.assert_array_equal(kf.state, x)
    policy = sample_policy("lockstep", ("lgu1", "lgu2"), rate_hz=1000.0, sample_rate_hz=10.0, progress_every=10,
                           clock_jump_ns=10**9, warn=print, on_restart=kf.reset)
    policy.add("lgu1", 60 * 10**9, None)
    policy.add("lgu2", int(59.5e9), None)  # half a second back: not a jump
    assert kf.counters["resets"] == 0
    steps = policy.add("lgu1", 5 * 10**9, None)
    assert kf.counters["resets"] == 1 and not kf.initialized and [s.t for s in steps] == [5.0]
    assert "backward clock jump" in kf.last_reset_reason and "60.0" in kf.last_reset_reason
    kf.on_lgu1(5.0, synthetic[0][1], 0.1)
    est = kf.on_lgu2(5.0, synthetic[0][2], 0.1)
    assert kf.initialized and est is not None and est.t == 5.0


def test_long_gap_resets_short_gap_reanchors(synthetic):
    kf = Fed(FlexureKf(FlexureKfParams(max_gap_s=2.0)))
    feed(kf, synthetic[:100])
    feed(kf, synthetic[110:130])  # 1 s gap
    assert kf.counters["reanchors"] == 1 and kf.counters["resets"] == 0
    feed(kf, synthetic[160:200])  # 3 s gap
    assert kf.counters["resets"] == 1 and "gap" in kf.last_reset_reason
    assert kf.initialized


def test_mismatched_dt_of_a_pair_is_rejected():
    kf = Fed(FlexureKf())
    kf.on_lgu1(0.1, [0.0, 0.0, 0.0], 0.1)
    assert kf.on_lgu2(0.1, [0.0, 0.0, 0.0], 0.2) is None
    assert kf.counters["bad_dt"] == 1 and not kf.initialized


def test_a_corrupted_increment_is_gated_then_reanchored(synthetic, reference):
    kf = Fed(FlexureKf(FlexureKfParams(max_gate_rejections=20)))
    spiked = list(synthetic)
    t, d1, d2 = spiked[1500]
    spiked[1500] = (t, d1, d2 + np.array([2e-3, 0.0, 0.0]))  # 400″ spike on one sample
    est = feed(kf, spiked)
    c = kf.counters
    assert c["gated"] == 20 and c["reanchors"] == 1 and c["resets"] == 0
    ref, _ = reference
    np.testing.assert_allclose(est.flexure, ref.flexure, atol=5 * AS)
    # Without the gate the spike is fused: an error beyond the filter's own 3σ.
    kf2 = Fed(FlexureKf(FlexureKfParams(gate_probability=None)))
    est2 = feed(kf2, spiked)
    assert np.max(np.abs(est2.flexure - PHI_TRUE) / est2.flexure_sigma) > 3.0


def test_persistent_gating_after_reanchor_resets():
    kf = Fed(FlexureKf(FlexureKfParams(max_gate_rejections=5)))
    for k in range(1, 200):
        kf.on_lgu1(0.1 * k, [0.0, 0.0, 0.0], 0.1)
        # LGU2 turns at 1e-3 rad/sample: far beyond any flexure.
        kf.on_lgu2(0.1 * k, [1e-3 if k > 50 else 0.0, 0.0, 0.0], 0.1)
    assert kf.counters["reanchors"] >= 1 and kf.counters["resets"] >= 1
    assert "beyond the gate" in kf.reset_reasons[0]


@pytest.mark.parametrize("field, value", [
    ("quasi_static_model", "random_walk"),
    ("filter_period_s", 0.0),
    ("qs_initial_sigma_deg", -1.0),
    ("qs_rate_rw_arcsec_s_rt_s", 0.0),
    ("dynamic_rms_arcsec", (20.0, 60.0)),
    ("dynamic_beta_per_s", 0.0),
    ("dynamic_freq_rad_s", float("nan")),
    ("bias_diff_initial_sigma_deg_h", "x"),
    ("lgu_arw_deg_rt_h", -0.001),
    ("meas_noise_arcsec", 0.0),
    ("gate_probability", 1.0),
    ("max_gate_rejections", 0),
    ("max_gap_s", 0.05),
    ("dt_tolerance", 0.6),
])
def test_bad_parameters_are_refused_naming_the_field(field, value):
    with pytest.raises(ValueError, match=field):
        FlexureKfParams(**{field: value})


def test_the_pairing_refuses_a_bad_bound():
    with pytest.raises(ValueError, match="max_pending"):
        StampPairs.feeding(FlexureKf(), max_pending=2.5)


def test_random_constant_needs_its_own_process_noise():
    with pytest.raises(ValueError, match="qs_rw_arcsec_rt_s"):
        FlexureKfParams(quasi_static_model="random_constant", qs_rw_arcsec_rt_s=0.0)
    FlexureKfParams(quasi_static_model="random_constant", qs_rate_rw_arcsec_s_rt_s=0.0)


# ---------------------------------------------------------------- paper 5 §5, full size
@pytest.fixture(scope="module")
def ship_runs():
    # The ship_flexure_band scenario (truth on the filter's own band) without ROS: 2 h at 10 Hz, scored after 10 min (~20 s here).
    return run_flexure_comparison(7200.0, seed=0, sim_rate_hz=10.0, lgu_rate_hz=10.0, convergence_s=600.0)


def test_random_constant_model_leaves_half_the_variation(ship_runs):
    rc, rwr = ship_runs["random_constant"].metrics, ship_runs["random_walk_rate"].metrics
    # Paper 5 §5.2: the conventional model's quasi-static error reaches about half the variation.
    assert np.all(rc["qs_max_over_variation_pp"] > 0.35)
    assert np.all(rc["qs_max_over_variation_pp"] < 0.7)
    assert np.all(rwr["qs_max_over_variation_pp"] < 0.2)
    assert np.all(rwr["qs_rms_arcsec"] < 0.3 * rc["qs_rms_arcsec"])
    # ... and its error couples into the bias difference (truth 0.1 °/h per axis): it ends
    # beyond 3x the 0.01 °/h the random-walk-rate model converges within, on every axis.
    assert np.all(np.abs(rc["bias_diff_err_final_deg_h"]) > 0.03)
    assert np.all(np.abs(rwr["bias_diff_err_final_deg_h"]) < 0.01)
    assert np.all(rc["total_rms_arcsec"] > 3 * rwr["total_rms_arcsec"])
    assert rc["total_within_3sigma"] < 0.2  # its covariance does not know


def test_random_walk_rate_model_tracks_and_is_consistent(ship_runs):
    r = ship_runs["random_walk_rate"]
    m = r.metrics
    # The acceptance bounds: total flexure below 20″ RMS on every axis (paper 5's full-scale figure)
    # and the bias difference within 0.01 °/h. Seed 0 of the eight-seed run in docs/results/paper5.md.
    assert np.all(m["total_rms_arcsec"] < 20.0)
    assert np.all(np.abs(m["bias_diff_err_final_deg_h"]) < 0.01)
    assert m["total_within_3sigma"] > 0.9
    assert 1.0 < m["total_nees_mean"] < 9.0
    # The helm sinusoid (360″ at 200 s) is tracked: quasi-static error well below it.
    assert np.all(m["qs_rms_arcsec"] < 60.0)
    c = r.counters
    assert c["gated"] == 0 and c["resets"] == 0 and c["updates"] == m["n_epochs"] + 600 * 10 - 1
    assert r.series["t"].size == pytest.approx(7200, abs=2)


# ---------------------------------------------------------------- experiment command line
def test_experiment_cli_monte_carlo_table_and_bad_band(capsys):
    from gimbal_sim.experiments import flexure as fe

    # The table has to equal the figures of the same runs made directly, whatever their length:
    # a short run with a short convergence time is enough (the accuracy figures are the other tests').
    fe.main(["--seeds", "0", "1", "--duration", "120", "--convergence", "60", "--models", "random_walk_rate",
             "--dynamic-freq", "0.5"])
    out = capsys.readouterr().out
    assert "lambda (0.5, 0.5, 0.5)" in out and "[random_walk_rate] 2 seeds (0, 1)" in out
    kp = FlexureKfParams(dynamic_freq_rad_s=0.5)
    runs = [run_flexure_comparison(120.0, seed, models=("random_walk_rate",), sim_rate_hz=10.0, params=kp,
                                   convergence_s=60.0,
                                   flexure=FlexureParams(dynamic_freq_rad_s=0.5))["random_walk_rate"]
            for seed in (0, 1)]
    mean = np.mean([r.metrics["total_rms_arcsec"] for r in runs], axis=0)
    assert "mean " + " / ".join(f"{x:.1f}" for x in mean) in out
    for bad, named in ((["--dynamic-beta", "0.1", "0.2"], "--dynamic-beta"), (["--dynamic-beta", "-1"], "beta"),
                       (["--dynamic-freq", "nan"], "dynamic_freq"), (["--duration", "0"], "--duration"),
                       (["--convergence", "7200"], "--convergence"), (["--seeds", "1", "1"], "--seeds")):
        with pytest.raises(SystemExit) as exc:
            fe.main(bad)
        assert exc.value.code == 2
        assert named in capsys.readouterr().err
