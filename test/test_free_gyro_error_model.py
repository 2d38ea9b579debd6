"""Paper 4's linear error model (gimbal_estimators.free_gyro_error_model) against independent
computations: scipy's integration of the nonlinear attitude kinematics, finite differences of
the nonlinear fix and heading cores, closed forms and seeded Monte Carlo through the
simulated sensor. Each test prints the agreement it measures (``pytest -s``)."""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.linalg import expm

from gimbal_estimators.free_gyro_error_model import (
    ARCSEC, D_OMEGA_A, D_OMEGA_B, D_OMEGA_IB, DEG_H, GAMMA, N_ATTITUDE, XI_A, XI_B, AttitudeError, AttitudeSample,
    ErrorSources, FixErrorModel, circle_probability, expm_augmented, fdop_circle_probability, propagate_attitude_error,
    spin_drift_error_cov_i)
from gimbal_estimators.free_gyro_positioning import FreeGyroPositioning, FreeGyroPositioningParams
from gimbal_kinematics.maths.earth import OMEGA_IE, earth_rate_n, meridian_radius, prime_vertical_radius
from gimbal_kinematics.maths.free_gyro import dcm_ni, nadir_angle, spin_axes_for_site_deg
from gimbal_kinematics.maths.rotations import (
    dcm_from_rotation_vector, euler321_to_dcm, euler_rates_to_body_rates, rotation_vector_from_dcm, skew)
from gimbal_sim.experiments.free_gyro import run_free_gyro_experiment, simulate_truth
from gimbal_sim.experiments.free_gyro_errors import fix_model
from gimbal_sim.world.sensors.free_gyro_sensor import FreeGyroSensorParams
from gimbal_sim.world.sensors.gyro import GyroParams

LAT_DEG, LON_DEG = 35.0, 129.0
LAT, LON = math.radians(LAT_DEG), math.radians(LON_DEG)
U_A, U_B = spin_axes_for_site_deg(LAT_DEG, LON_DEG, (60.0, 50.0), (-40.0, 50.0))


# --- attitude-error dynamics (eq. 19–20) against the nonlinear kinematics --------------------
def _euler(t: float) -> tuple[np.ndarray, np.ndarray]:
    """A rolling, pitching, yawing ship at rest: Euler angles and their rates at t."""
    a, w = np.radians([5.0, 3.0, 4.0]), 2 * math.pi / np.array([8.0, 6.0, 20.0])
    ph = np.array([0.0, 1.0, 2.0])
    e = a * np.sin(w * t + ph) + np.array([0.0, 0.0, math.radians(30.0)])
    return e, a * w * np.cos(w * t + ph)


def _motion(t: float) -> AttitudeSample:
    e, de = _euler(t)
    C_nb = euler321_to_dcm(*e)
    w_in = earth_rate_n(LAT)
    w_ib = euler_rates_to_body_rates(e[0], e[1], de) + C_nb.T @ w_in
    return AttitudeSample(w_ib, w_in, C_nb.T @ dcm_ni(LAT, LON, t), C_nb)


def _nonlinear_errors(t_end: float, drift: tuple[np.ndarray, np.ndarray], bias: np.ndarray, gamma0: np.ndarray,
                      t_eval: np.ndarray) -> np.ndarray:
    """Integrate (solve_ivp) the computed Ĉ_b^n and Ĉ_g^b of paper 4 Figs. 3–4 — from the
    biased triad, with the spin axes taken as fixed — and return the exact error angles
    (ξ_a, ξ_b, γ, η_a, η_b) at ``t_eval`` against the true ones (true gyro frames turn at d
    in i)."""
    def rhs(t, y):
        s = _motion(t)
        C_nb, out = y[18:27].reshape(3, 3), []
        w_ib = s.omega_ib_b + bias
        for k in (0, 9):
            C_bg = y[k:k + 9].reshape(3, 3)
            out.append((C_bg @ skew(-C_bg.T @ w_ib)).ravel())  # ω̂_bg^g = 0 − Ĉ_b^g ω̂_ib^b (eq. 17)
        out.append((C_nb @ skew(w_ib - C_nb.T @ s.omega_in_n)).ravel())
        return np.concatenate(out)

    s0 = _motion(0.0)
    y0 = np.concatenate([s0.C_bi.ravel(), s0.C_bi.ravel(),
                         (dcm_from_rotation_vector(-gamma0) @ s0.C_nb).ravel()])
    sol = solve_ivp(rhs, (0.0, t_end), y0, t_eval=t_eval, rtol=1e-11, atol=1e-12, method="DOP853")
    errs = []
    for j, t in enumerate(sol.t):
        s = _motion(t)
        y = sol.y[:, j]
        row = [-rotation_vector_from_dcm(y[k:k + 9].reshape(3, 3) @ (s.C_bi @ dcm_from_rotation_vector(d * t)).T)
               for k, d in ((0, drift[0]), (9, drift[1]))]
        row.append(-rotation_vector_from_dcm(y[18:27].reshape(3, 3) @ s.C_nb.T))
        # the spin axes' error angles in n: Ĉ_b^n Ĉ_g^b against the true C_b^n C_g^b
        row += [-rotation_vector_from_dcm(y[18:27].reshape(3, 3) @ y[k:k + 9].reshape(3, 3)
                                          @ (s.C_nb @ s.C_bi @ dcm_from_rotation_vector(d * t)).T)
                for k, d in ((0, drift[0]), (9, drift[1]))]
        errs.append(np.concatenate(row))
    return np.array(errs)


def test_attitude_error_dynamics_match_nonlinear_integration():
    rng = np.random.default_rng(25)
    drift = tuple(np.cross(rng.standard_normal(3), u) * 2.0 * DEG_H for u in (U_A, U_B))  # ⊥ u, ~2 °/h
    bias = np.array([1.0, -0.7, 0.5]) * DEG_H
    gamma0 = np.array([20.0, -15.0, 60.0]) * ARCSEC
    times = np.array([60.0, 300.0, 600.0])
    nonlinear = _nonlinear_errors(600.0, drift, bias, gamma0, times)
    z0 = np.zeros(N_ATTITUDE)
    z0[GAMMA], z0[D_OMEGA_A], z0[D_OMEGA_B], z0[D_OMEGA_IB] = gamma0, -drift[0], -drift[1], bias  # δω = computed − true
    state, t_prev = AttitudeError(z0, np.zeros((N_ATTITUDE, N_ATTITUDE))), 0.0
    for t, nl in zip(times, nonlinear):
        state, t_prev = propagate_attitude_error(state, t_prev, t, _motion, max_step_s=1.0), t
        linear = np.concatenate([state.z[:9], *state.spin_axis_errors_n(_motion(t).C_nb)])
        for name, sl in (("xi_a", slice(0, 3)), ("xi_b", slice(3, 6)), ("gamma", slice(6, 9)),
                         ("eta_a", slice(9, 12)), ("eta_b", slice(12, 15))):
            rel = np.linalg.norm(linear[sl] - nl[sl]) / np.linalg.norm(nl[sl])
            print(f"t={t:.0f} s {name}: |nonlinear| {np.linalg.norm(nl[sl]) / ARCSEC:.1f}″, "
                  f"linear−nonlinear {rel:.2e} of it")
            assert rel < 0.01


def test_closed_form_transition_equals_scipy_expm():
    rng = np.random.default_rng(19)
    for scale in (1e-6, 1e-3, 0.5, 2.0):
        Om = np.zeros((N_ATTITUDE, N_ATTITUDE))
        for k in (0, 3, 6):
            Om[k:k + 3, k:k + 3] = skew(rng.standard_normal(3) * scale)
        Om[:9, 9:] = rng.standard_normal((9, 12))
        assert np.max(np.abs(expm_augmented(Om) - expm(Om))) < 1e-12


def test_triad_bias_cancels_and_drift_propagates_as_closed_form():
    """η = γ + C_b^n ξ: the triad bias drops out, and the drift's η covariance equals
    C_ni (σ t)² (I − uuᵀ) C_niᵀ (the closed form the fix model uses)."""
    sd, sb, t1 = 2.0 * DEG_H, 5.0 * DEG_H, 900.0
    P0 = np.zeros((N_ATTITUDE, N_ATTITUDE))
    for k, u in ((D_OMEGA_A, U_A), (D_OMEGA_B, U_B)):  # drift drawn ⊥ u, as the sensor draws it
        P0[k, k] = sd**2 * (np.eye(3) - np.outer(u, u))
    P0[D_OMEGA_IB, D_OMEGA_IB] = sb**2 * np.eye(3)
    state = propagate_attitude_error(AttitudeError(np.zeros(N_ATTITUDE), P0), 0.0, t1, _motion, max_step_s=1.0)
    C_ni = dcm_ni(LAT, LON, t1)
    for k, u, P_eta in zip((XI_A, XI_B), (U_A, U_B), state.spin_axis_error_covs_n(_motion(t1).C_nb)):
        expected = C_ni @ spin_drift_error_cov_i(u, sd, t1) @ C_ni.T
        rel = np.linalg.norm(P_eta - expected) / np.linalg.norm(expected)
        xi = math.sqrt(np.trace(state.P[k, k]))
        print(f"η covariance vs closed form: {rel:.2e} (ξ holds {xi / ARCSEC:.0f}″ rms of drift and triad bias)")
        assert rel < 1e-3


# --- linear map against finite differences of the nonlinear cores -------------------------------
ROLL, PITCH, YAW = math.radians(4.0), math.radians(-3.0), math.radians(30.0)


def _core_outputs(e: np.ndarray) -> tuple[np.ndarray, object]:
    """The nonlinear core's nadir errors (as the fix sees them), north/east error [m] and
    both headings' errors for a ship at rest with a fixed attitude, the inputs perturbed by
    ``e`` = (δroll, δpitch, ε_a (3), ε_b (3), triad bias (3))."""
    core = FreeGyroPositioning(FreeGyroPositioningParams(U_A, U_B, nadir_noise_arcsec=1.0, fix_interval_s=10.0,
                                                         heading_window_s=5.0))
    C_bn = euler321_to_dcm(ROLL, PITCH, YAW).T
    u_true = (dcm_from_rotation_vector(e[2:5]) @ np.array(U_A), dcm_from_rotation_vector(e[5:8]) @ np.array(U_B))
    fix = None
    for k in range(200):
        t = 0.1 * k
        C_ni = dcm_ni(LAT, LON, t)
        core.on_level(t, ROLL + e[0], PITCH + e[1])
        core.on_body_rates(t, C_bn @ (C_ni[:, 2] * OMEGA_IE) + e[8:11])
        fix = core.on_spin_axes(t, C_bn @ C_ni @ u_true[0], C_bn @ C_ni @ u_true[1]).output
        if fix is not None:
            break
    rm, rn = meridian_radius(LAT), prime_vertical_radius(LAT) * math.cos(LAT)
    return np.array([fix.nadir[0] - nadir_angle(U_A, LAT, LON, fix.t), fix.nadir[1] - nadir_angle(U_B, LAT, LON, fix.t),
                     (fix.lat - LAT) * rm, math.remainder(fix.lon - LON, math.tau) * rn,
                     math.remainder(fix.heading - YAW, math.tau),
                     math.remainder(fix.heading_earth_rate - YAW, math.tau)]), fix


def test_linear_map_matches_finite_differences_of_nonlinear_core():
    _, fix = _core_outputs(np.zeros(11))
    model = FixErrorModel(U_A, U_B, LAT, LON, fix.t, roll=ROLL, pitch=PITCH, heading=YAW,
                          samples_per_fix=fix.n_samples, heading_window_s=5.0)
    steps = [ARCSEC] * 8 + [0.01 * DEG_H] * 3
    J = np.zeros((6, 11))
    for j, h in enumerate(steps):
        d = np.zeros(11)
        d[j] = h
        J[:, j] = (_core_outputs(d)[0] - _core_outputs(-d)[0]) / (2.0 * h)
    scale = np.max(np.abs(J), axis=1, keepdims=True)
    rel = np.abs(model.H - J) / scale
    print(f"H vs central differences of the core, worst |ΔH| / row scale per output: {np.max(rel, axis=1)}")
    assert np.all(rel < 1e-4)
    # what the mechanisation does not couple is exactly zero in the core too
    assert np.all(J[:5, 8:11] == 0.0) and np.all(J[5, 2:8] == 0.0)


def test_position_of_iid_and_levelling_errors_closed_forms():
    """Pickoff noise alone (i.i.d. nadir errors) gives FixGeometry's FDOP²σ² covariance; a
    levelling error alone moves the fix by the tilt itself, σ √(R_M² + R_N²) whatever the
    geometry, where eq. 38's FDOP σ_θ does not hold (correlated nadir errors)."""
    u_a, u_b = spin_axes_for_site_deg(LAT_DEG, LON_DEG, (60.0, 50.0), (-40.0, 20.0))  # Δα = 60°
    m = FixErrorModel(u_a, u_b, LAT, LON, 0.0, samples_per_fix=100)
    p = m.predict(ErrorSources(pickoff_noise_arcsec=5.0))
    expected = m.geometry.covariance_ne_m(5.0 * ARCSEC / 10.0)
    assert np.allclose(p.cov_ne_m, expected, rtol=1e-9)
    lev = m.predict(ErrorSources(level_error_arcsec=10.0))
    closed = 10.0 * ARCSEC * math.hypot(meridian_radius(LAT), prime_vertical_radius(LAT))
    print(f"levelling 10″, Δα = 60°: model drms {lev.position_drms_m:.2f} m, tilt closed form {closed:.2f} m, "
          f"eq. 38 FDOP σ_θ {lev.position_fdop_m:.2f} m (FDOP {lev.fdop:.3f}, nadir correlation "
          f"{lev.nadir_correlation:.3f})")
    assert lev.position_drms_m == pytest.approx(closed, rel=1e-9)


# --- the FDOP circle (eq. 38) -------------------------------------------------------------------
def test_circle_probability_isotropic_closed_form_and_paper_63_percent():
    for k in (0.5, 1.0, math.sqrt(2.0), 2.0, 3.0):
        got = circle_probability(np.eye(2) * 4.0, 2.0 * k)
        print(f"isotropic, radius {k:.3f} σ: {got:.6f} (1 − e^(−k²/2) = {1 - math.exp(-k * k / 2):.6f})")
        assert got == pytest.approx(1.0 - math.exp(-k * k / 2.0), abs=1e-9)
    # FDOP σ = drms = √2 σ per axis in the circular case: the paper's "about 0.63" is 1 − e⁻¹
    assert fdop_circle_probability(np.diag([3.0, 3.0])) == pytest.approx(1.0 - math.exp(-1.0), abs=1e-9)
    assert fdop_circle_probability(np.diag([1.0, 0.0])) == pytest.approx(0.6826894921, abs=1e-9)


def test_circle_probability_anisotropic_against_monte_carlo():
    P = np.array([[237.0, -120.0], [-120.0, 140.0]])  # m², elongated and rotated
    x = np.random.default_rng(63).multivariate_normal(np.zeros(2), P, size=400_000)
    for r in (10.0, math.sqrt(np.trace(P)), 30.0):
        mc = float(np.mean(np.hypot(x[:, 0], x[:, 1]) <= r))
        exact = circle_probability(P, r)
        print(f"anisotropic P, radius {r:.2f} m: exact {exact:.5f}, Monte Carlo {mc:.5f}")
        assert abs(mc - exact) < 0.003   # 400 000 draws: binomial σ ≤ 0.0008
    print(f"FDOP circle of this P holds {fdop_circle_probability(P):.4f} (paper: about 0.63)")


# --- Monte Carlo through the simulated sensor and the core, one source at a time --------------
N_DRAWS = 300


@pytest.fixture(scope="module")
def ship_truth():
    return simulate_truth("paper5_ship", LAT_DEG, LON_DEG, duration_s=10.0, rate_hz=10.0)


def _fix_errors(seed: int, truth, sensor: FreeGyroSensorParams) -> tuple[np.ndarray, object]:
    """The first fix's errors (nadir a, b [rad] as the fix sees them, north, east [m],
    heading, earth-rate heading [rad]) through the sensor and core, and the fix."""
    core = FreeGyroPositioningParams(U_A, U_B, nadir_noise_arcsec=1e-6, fix_interval_s=10.0, heading_window_s=5.0)
    run = run_free_gyro_experiment(seed, truth, LAT_DEG, LON_DEG, sensor, core)
    fix = run.fixes[0]
    nadir = [fix.nadir[k] - nadir_angle(u, LAT, LON, fix.t) for k, u in enumerate((U_A, U_B))]
    return np.array([*nadir, *run.errors_ne_m[0], run.heading_errors[0], run.heading_er_errors[0]]), fix


def _monte_carlo(truth, sensor_kwargs, level_sigma_arcsec: float = 0.0) -> tuple[np.ndarray, object]:
    """(N_DRAWS, 6) fix errors (:func:`_fix_errors`), seeds 1..N_DRAWS, less those of the
    same ship with no error source (the core's own residual, e.g. the rolling ship's effect on
    the 5 s earth-rate window, which is no term of the error model), and the fix."""
    quiet = FreeGyroSensorParams(U_A, U_B, pickoff_noise_arcsec=0.0, triad=GyroParams())
    baseline, _ = _fix_errors(0, truth, quiet)
    print(f"no error source: residual fix errors {baseline[[0, 1, 4, 5]] / ARCSEC} ″ (nadir a, b, heading, "
          f"earth-rate heading), {baseline[2:4]} m (north, east)")
    rng = np.random.default_rng(4)
    rows, fix = [], None
    for seed in range(1, N_DRAWS + 1):
        sp = FreeGyroSensorParams(U_A, U_B, pickoff_noise_arcsec=0.0,
                                  level_bias_arcsec=tuple(rng.standard_normal(2) * level_sigma_arcsec),
                                  **sensor_kwargs)
        err, fix = _fix_errors(seed, truth, sp)
        rows.append(err - baseline)
    return np.array(rows), fix


def _model_for(truth, fix) -> FixErrorModel:
    """The model at the fix, as the error-study campaign builds it (5 s earth-rate window)."""
    return fix_model(truth, fix, U_A, U_B, LAT, LON, 5.0)


CASES = {
    "spin drift 20 °/h": ({"spin_drift_sigma_deg_h": 20.0, "triad": GyroParams()}, 0.0,
                          ErrorSources(spin_drift_deg_h=20.0)),
    "levelling 10″": ({"triad": GyroParams()}, 10.0, ErrorSources(level_error_arcsec=10.0)),
    "triad bias 0.05 °/h": ({"triad": GyroParams(bias_sigma_deg_h=0.05)}, 0.0, ErrorSources(triad_bias_deg_h=0.05)),
    "triad ARW 0.005 °/√h": ({"triad": GyroParams(arw_deg_rt_h=0.005)}, 0.0, ErrorSources(triad_arw_deg_rt_h=0.005)),
}


@pytest.mark.parametrize("case", list(CASES))
def test_monte_carlo_sigma_within_15_percent_of_model(ship_truth, case):
    sensor_kwargs, level_sigma, sources = CASES[case]
    err, fix = _monte_carlo(ship_truth, sensor_kwargs, level_sigma)
    pred = _model_for(ship_truth, fix).predict(sources)
    mc = {"nadir a": math.sqrt(np.mean(err[:, 0] ** 2)), "nadir b": math.sqrt(np.mean(err[:, 1] ** 2)),
          "position drms": math.sqrt(np.mean(err[:, 2] ** 2 + err[:, 3] ** 2)),
          "heading": math.sqrt(np.mean(err[:, 4] ** 2)), "earth-rate heading": math.sqrt(np.mean(err[:, 5] ** 2))}
    model = {"nadir a": pred.sigma_nadir[0], "nadir b": pred.sigma_nadir[1], "position drms": pred.position_drms_m,
             "heading": pred.sigma_heading, "earth-rate heading": pred.sigma_heading_earth_rate}
    unit = {"position drms": (1.0, "m")}
    for key in mc:
        div, name = unit.get(key, (ARCSEC, "″"))
        ratio = mc[key] / model[key] if model[key] > 0.0 else float("nan")
        print(f"{case}, {N_DRAWS} draws, {key}: Monte Carlo {mc[key] / div:.4g} {name}, model {model[key] / div:.4g} "
              f"{name}, ratio {ratio:.3f}")
        if model[key] > 0.0:
            assert abs(ratio - 1.0) < 0.15
        else:  # the mechanisation does not couple this source into this output
            assert mc[key] == 0.0


def test_bad_inputs_are_refused_naming_them():
    with pytest.raises(ValueError, match="level_error_arcsec"):
        ErrorSources(level_error_arcsec=-1.0)
    with pytest.raises(ValueError, match="spin_drift_deg_h"):
        ErrorSources(spin_drift_deg_h=float("nan"))
    with pytest.raises(ValueError, match="z must have shape"):
        AttitudeError(np.zeros(N_ATTITUDE - 1), np.zeros((N_ATTITUDE, N_ATTITUDE)))
    with pytest.raises(ValueError, match="positive semi-definite"):
        circle_probability(np.diag([1.0, -1.0]), 1.0)
    with pytest.raises(ValueError, match="shape"):
        fdop_circle_probability(np.eye(3))
    with pytest.raises(ValueError, match="samples_per_fix"):
        FixErrorModel(U_A, U_B, LAT, LON, 0.0, samples_per_fix=0)
