"""Free-gyro sensor and positioning core (paper 4) against independent constructions (scipy
rotations), eq. 6 / eq. 29 closed forms and a seeded 200-run FDOP Monte Carlo."""
import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation
from scipy.stats import chi2

from gimbal_estimators.free_gyro_positioning import (
    FreeGyroPositioning,
    FreeGyroPositioningParams,
    navsat_covariance_enu,
)
from gimbal_kinematics.maths import earth
from gimbal_estimators.free_gyro_positioning_params import PARAMS as FGP_PARAMS
from gimbal_kinematics.params.table import defaults
from gimbal_kinematics.maths import free_gyro as fg
from gimbal_kinematics.maths.free_gyro import spin_axis_for_site
from gimbal_kinematics.maths.rotations import rot3
from gimbal_sim.experiments.free_gyro import (
    make_spin_axes,
    run_fdop_monte_carlo,
    run_free_gyro_experiment,
    simulate_truth,
)
from gimbal_sim.world.sensors import GyroParams
from gimbal_sim.world.sensors.free_gyro_sensor import FreeGyroSensor, FreeGyroSensorParams

ARCSEC = math.radians(1.0 / 3600.0)
ARCMIN = math.radians(1.0 / 60.0)
LAT, LON = 35.0, 129.0  # off Busan (paper 4's authors)
U_A, U_B = make_spin_axes(LAT, LON)


@pytest.fixture(scope="module")
def ship_truth():
    """paper5_ship motion (roll 5°, pitch 3°, yaw 3°) at a fixed site, 10 Hz, 130 s."""
    return simulate_truth("paper5_ship", LAT, LON, 130.0, 10.0, {"mean_heading_deg": 40.0})


# ---------------------------------------------------------------- parameters
@pytest.mark.parametrize("field, value", [
    ("u_a_i", (1.0, 1.0, 0.0)), ("u_b_i", U_A), ("nadir_noise_arcsec", 0.0), ("fix_interval_s", -1.0),
    ("min_samples", 2), ("max_fdop", 1.0), ("min_sin_crossing_angle", 1.0), ("heading_window_s", float("nan")),
    ("triad_arw_deg_rt_h", 0.0), ("height_m", float("inf")),
])
def test_core_params_refused_naming_the_field(field, value):
    kwargs = {"u_a_i": U_A, "u_b_i": U_B, field: value}
    with pytest.raises(ValueError, match=field):
        FreeGyroPositioningParams(**kwargs)


@pytest.mark.parametrize("field, value", [
    ("u_a_i", (0.0, 0.0, 2.0)), ("u_b_i", tuple(-c for c in U_A)), ("pickoff_noise_arcsec", -1.0),
    ("spin_drift_sigma_deg_h", float("nan")), ("level_bias_arcsec", (1.0, 2.0, 3.0)), ("level_noise_arcsec", -0.1),
])
def test_sensor_params_refused_naming_the_field(field, value):
    kwargs = {"u_a_i": U_A, "u_b_i": U_B, field: value}
    with pytest.raises(ValueError, match=field):
        FreeGyroSensorParams(**kwargs)


# ---------------------------------------------------------------- sensor
def test_sensor_spin_axes_match_independent_rotation_chain(ship_truth):
    """u_b = C_bn C_ni u_i rebuilt with scipy: intrinsic ZYX Euler angles for the body and a
    rotation about the earth's axis for the inertial frame."""
    sensor = FreeGyroSensor(FreeGyroSensorParams(U_A, U_B, pickoff_noise_arcsec=0.0), np.random.default_rng(1), 0.1)
    lat, lon = math.radians(LAT), math.radians(LON)
    for tr in ship_truth[::97]:
        s = sensor.update_from_truth(tr, lat, lon, 0.1)
        roll, pitch, yaw = tr.euler
        R_nb = Rotation.from_euler("ZYX", [yaw, pitch, roll]).as_matrix()
        R_ie = Rotation.from_euler("z", earth.OMEGA_IE * tr.t).as_matrix()
        C_ni = (R_ie @ earth.dcm_en(lat, lon)).T
        for u, meas in ((U_A, s.spin_a_b), (U_B, s.spin_b_b)):
            assert np.allclose(R_nb.T @ C_ni @ np.array(u), meas, atol=1e-12)
        assert s.true_nadir[0] == pytest.approx(fg.nadir_angle(U_A, lat, lon, tr.t), abs=1e-12)
        assert s.true_azimuth[1] == pytest.approx(fg.gyro_azimuth(U_B, lat, lon, tr.t), abs=1e-12)
        assert np.allclose(s.true_omega_ie_b, R_nb.T @ earth.earth_rate_n(lat), atol=1e-15)


def test_sensor_pickoff_noise_statistics_and_seeding():
    """Nadir-angle error σ equals the per-axis pickoff σ; the read-out stays a unit vector;
    the same seed reproduces the same stream."""
    sigma = 20.0
    params = FreeGyroSensorParams(U_A, U_B, pickoff_noise_arcsec=sigma)
    lat, lon = math.radians(LAT), math.radians(LON)
    outs = []
    for seed in (5, 5):
        sensor = FreeGyroSensor(params, np.random.default_rng(seed), 0.1)
        outs.append([sensor.update(0.1 * k, lat, lon, (0.0, 0.0, 0.3), (0.0, 0.0, 0.0)) for k in range(1, 4001)])
    assert outs[0][-1].spin_a_b == outs[1][-1].spin_a_b
    err = np.array([math.atan2(math.hypot(s.spin_a_b[0], s.spin_a_b[1]), s.spin_a_b[2]) - s.true_nadir[0]
                    for s in outs[0]])
    n = err.size
    ratio = float(np.sum(err**2) / n) / (sigma * ARCSEC) ** 2
    assert chi2.ppf(0.001, n) / n < ratio < chi2.ppf(0.999, n) / n
    assert all(abs(np.linalg.norm(s.spin_b_b) - 1.0) < 1e-12 for s in outs[0][:50])


def test_spin_axis_for_site_round_trip():
    lat, lon, t = math.radians(-20.0), math.radians(150.0), 3000.0
    u = spin_axis_for_site(lat, lon, t, math.radians(70.0), math.radians(-120.0))
    assert fg.nadir_angle(u, lat, lon, t) == pytest.approx(math.radians(70.0), abs=1e-12)
    assert fg.gyro_azimuth(u, lat, lon, t) == pytest.approx(math.radians(-120.0), abs=1e-12)


# ---------------------------------------------------------------- fix
def test_noise_free_fix_on_a_rolling_ship_and_measured_tilt_rate(ship_truth):
    """No noise: every fix is on the site to < 0.5 m while the ship rolls 5°, the mirror
    branch is never taken, and the integrated tilting rate is paper eq. 6, ω_θ = Ω cos φ sin α
    (and the finite difference of eq. 1)."""
    sp = FreeGyroSensorParams(U_A, U_B, pickoff_noise_arcsec=0.0, triad=GyroParams())
    run = run_free_gyro_experiment(3, ship_truth, LAT, LON, sp)
    assert len(run.fixes) == 13 and run.degenerate == 0
    assert np.all(np.abs(run.errors_ne_m) < 0.5)
    lat, lon = math.radians(LAT), math.radians(LON)
    for fix in run.fixes:
        assert fix.fdop == pytest.approx(math.sqrt(2.0), rel=1e-3)
        for k, u in enumerate((U_A, U_B)):
            alpha = fg.gyro_azimuth(u, lat, lon, fix.t)
            closed = earth.OMEGA_IE * math.cos(lat) * math.sin(alpha)
            fd = (fg.nadir_angle(u, lat, lon, fix.t + 1.0) - fg.nadir_angle(u, lat, lon, fix.t - 1.0)) / 2.0
            assert fix.tilt_rate[k] == pytest.approx(closed, rel=1e-4)
            assert fix.tilt_rate[k] == pytest.approx(fd, rel=1e-4)
    assert np.all(np.abs(run.heading_errors) < 0.05 * ARCSEC)


def test_fdop_monte_carlo_matches_fdop_squared_sigma_squared():
    """Acceptance: 200 seeded runs (2 fix windows each, independent pickoff noise, rolling
    ship); the empirical north/east error covariance matches the FDOP²σ² covariance the core
    publishes: drms² within 10 %, each variance within 15 %, the correlation within 0.1 and
    mean NEES inside its 99.9 % χ² band. The second geometry (Δα = 30°) has FDOP 2√2 and a
    strongly correlated ellipse."""
    for azimuths in ((-40.0, 50.0), (-40.0, -10.0)):
        mc = run_fdop_monte_carlo(200, fixes_per_run=2, azimuth_deg=azimuths)
        assert mc.n_fixes == 400
        assert mc.fdop == pytest.approx(math.sqrt(2.0) / abs(math.sin(math.radians(azimuths[1] - azimuths[0]))),
                                        rel=2e-3)
        assert abs(mc.trace_ratio - 1.0) < 0.10, mc
        assert np.all(np.abs(mc.variance_ratios - 1.0) < 0.15), mc
        emp, pred = mc.empirical_cov_ne_m, mc.predicted_cov_ne_m
        rho = lambda c: c[0, 1] / math.sqrt(c[0, 0] * c[1, 1])  # noqa: E731
        assert abs(rho(emp) - rho(pred)) < 0.1
        n = mc.n_fixes
        assert chi2.ppf(0.0005, 2 * n) / n < mc.mean_nees < chi2.ppf(0.9995, 2 * n) / n
        # free-gyro heading σ (pickoff + fix error through eq. 2) is consistent too
        assert 0.8 < mc.heading_error_std / mc.heading_sigma_mean < 1.2


@pytest.mark.parametrize("azimuths", [(30.0, 30.0), (30.0, 210.0), (30.0, 31.0)])
def test_degenerate_geometry_is_reported_without_a_fix(azimuths):
    """Spin axes whose horizontal projections are parallel (Δα = 0 or 180°: tangent circles)
    or within 1° (FDOP ≈ 81 > max_fdop): every window is reported degenerate with a reason,
    and no latitude/longitude or covariance is given."""
    u_a, u_b = make_spin_axes(LAT, LON, 0.0, (60.0, 40.0), azimuths)
    truth = simulate_truth("static", LAT, LON, 40.0, 10.0)
    sp = FreeGyroSensorParams(u_a, u_b, pickoff_noise_arcsec=5.0)
    run = run_free_gyro_experiment(1, truth, LAT, LON, sp)
    assert len(run.fixes) == 0 and run.degenerate == 4
    for reason in run.reasons:
        assert ("tangent" in reason) or ("FDOP" in reason) or ("intersect" in reason)
    core = FreeGyroPositioning(FreeGyroPositioningParams(u_a, u_b))
    sensor = FreeGyroSensor(sp, np.random.default_rng(2), 0.1)
    last = None
    for tr in truth:
        s = sensor.update_from_truth(tr, math.radians(LAT), math.radians(LON), 0.1)
        core.on_level(s.t, s.roll, s.pitch)
        last = core.on_spin_axes(s.t, s.spin_a_b, s.spin_b_b).output or last
    assert last is not None and not last.valid and last.status == "degenerate"
    assert math.isnan(last.lat) and math.isnan(last.lon) and np.all(np.isnan(last.cov_ne_m))
    assert core.counters.degenerate == 4 and core.counters.fixes == 0


# ---------------------------------------------------------------- heading
@pytest.mark.parametrize("case", [
    dict(roll=3.0, pitch=-2.0, yaw=40.0, bias=(0.01, -0.02, 0.03), level=(0.0, 0.0)),
    dict(roll=-8.0, pitch=5.0, yaw=-135.0, bias=(-0.02, 0.0, 0.05), level=(30.0, -20.0)),
    dict(roll=0.0, pitch=0.0, yaw=100.0, bias=(0.0, 0.015, 0.0), level=(0.0, 60.0)),
])
def test_earth_rate_heading_error_matches_eq29(case):
    """Static ship, triad bias δω and vertical-reference bias (δroll, δpitch), no noise: the
    earth-rate heading error equals paper eq. 29's first-order δψ (free_gyro.heading_error)
    to second-order accuracy (errors of a few arcminutes)."""
    truth = simulate_truth("static", LAT, LON, 70.0, 10.0,
                           {"roll_deg": case["roll"], "pitch_deg": case["pitch"], "yaw_deg": case["yaw"]})
    sp = FreeGyroSensorParams(U_A, U_B, pickoff_noise_arcsec=1.0, level_bias_arcsec=case["level"],
                              triad=GyroParams(bias_deg_h=case["bias"]))
    run = run_free_gyro_experiment(1, truth, LAT, LON, sp)
    err = run.heading_er_errors[np.isfinite(run.heading_er_errors)]
    assert err.size >= 1
    sensor = FreeGyroSensor(sp, np.random.default_rng(0), 0.1)
    s = sensor.update_from_truth(truth[-1], math.radians(LAT), math.radians(LON), 0.1)
    predicted = fg.heading_error(s.true_omega_ie_b, s.true_triad_bias, math.radians(case["roll"]),
                                 math.radians(case["pitch"]), case["level"][0] * ARCSEC, case["level"][1] * ARCSEC)
    assert abs(predicted) > 0.5 * ARCMIN
    assert err[-1] == pytest.approx(predicted, rel=0.01, abs=0.5 * ARCSEC)


def test_earth_rate_heading_removes_ship_rotation(ship_truth):
    """Rolling/pitching/yawing ship, perfect triad: the levelled-rate window with the roll and
    pitch rates telescoped out leaves the earth rate alone (heading error < 0.1″), while the
    ship's rates are ~10³ times the earth rate."""
    sp = FreeGyroSensorParams(U_A, U_B, pickoff_noise_arcsec=1.0, triad=GyroParams())
    run = run_free_gyro_experiment(1, ship_truth, LAT, LON, sp)
    err = run.heading_er_errors[np.isfinite(run.heading_er_errors)]
    assert err.size >= 5 and np.all(np.abs(err) < 0.1 * ARCSEC)


def test_earth_rate_heading_sigma_is_consistent_with_triad_noise():
    """White triad noise only: the heading errors of 40 seeded 60-s windows scatter with the
    σ the core reports, (N/√T)/(Ω cos φ) (eq. 29 for white noise)."""
    truth = simulate_truth("static", LAT, LON, 70.5, 5.0, {"yaw_deg": 70.0})
    sp = FreeGyroSensorParams(U_A, U_B, pickoff_noise_arcsec=1.0, triad=GyroParams(arw_deg_rt_h=0.002))
    errs, sig = [], []
    for seed in range(40):
        run = run_free_gyro_experiment(seed, truth, LAT, LON, sp)
        errs.append(run.heading_er_errors[-1])
        sig.append(run.fixes[-1].heading_earth_rate_sigma)
    z2 = np.sum((np.array(errs) / np.array(sig)) ** 2)
    assert chi2.ppf(0.001, 40) < z2 < chi2.ppf(0.999, 40)
    assert np.mean(sig) == pytest.approx(0.002 * math.radians(1) / 60 / math.sqrt(60.0)
                                         / (earth.OMEGA_IE * math.cos(math.radians(LAT))), rel=0.02)


# ---------------------------------------------------------------- robustness and outputs
def test_bad_inputs_rejected_and_counted_and_backjump_resets():
    core = FreeGyroPositioning(FreeGyroPositioningParams(U_A, U_B, fix_interval_s=1.0))
    ua, ub = (0.6, 0.0, 0.8), (0.0, 0.6, 0.8)
    assert core.on_spin_axes(0.0, ua, ub).why == "no vertical reference yet"
    assert core.counters.rejected_no_level == 1
    core.on_level(0.0, 0.0, 0.0)
    core.on_level(0.1, float("nan"), 0.0)
    core.on_spin_axes(0.0, (float("nan"), 0.0, 1.0), ub)
    core.on_body_rates(0.0, (0.0, float("inf"), 0.0))
    core.on_velocity(0.0, (1.0, None, 0.0))
    assert core.counters.rejected_nonfinite == 4
    core.on_spin_axes(0.0, (0.5, 0.0, 0.5), ub)
    assert core.counters.rejected_not_unit == 1
    core.on_spin_axes(0.0, ua, ub)
    assert core.counters.spin_accepted == 1
    core.on_spin_axes(0.5, ua, ub)
    assert core.counters.rejected_stale_level == 1


def test_late_read_outs_are_refused_and_a_clock_jump_resets_through_the_input_policy():
    """Stamps are the node's synced input policy's to judge (as the node builds it): a late or
    repeated read-out never makes a group; one more than clock_jump_s back calls the node's
    reset, and the new run's groups follow."""
    from gimbal_kinematics.timing.input_policy import synced_policy

    resets = []
    policy = synced_policy("free", ("a", "b"), rate_hz=100.0, progress_every=1,
                           clock_jump_ns=int(defaults(FGP_PARAMS)["clock_jump_s"] * 1e9),
                           on_restart=resets.append)
    read_out = lambda t_s: [s for k in ("a", "b") for s in policy.add(k, int(t_s * 1e9), k)]  # noqa: E731
    assert [s.stamp_ns for s in read_out(10.0) + read_out(10.1)] == [10_000_000_000, 10_100_000_000]
    assert read_out(10.1) == [] and read_out(9.5) == [] and policy.rejected == 4 and not resets
    assert len(read_out(5.0)) == 1 and len(resets) == 1 and "jumped back" in resets[0]
    assert len(read_out(5.1)) == 1 and len(resets) == 1


def test_navsat_covariance_is_enu_row_major():
    cov = navsat_covariance_enu(np.array([[4.0, 1.5], [1.5, 9.0]]), 100.0)
    assert cov == (9.0, 1.5, 0.0, 1.5, 4.0, 0.0, 0.0, 0.0, 100.0)
    with pytest.raises(ValueError, match="cov_ne_m"):
        navsat_covariance_enu(np.eye(3), 1.0)


def test_earth_rate_heading_removes_transport_rate_given_velocity():
    """A level ship steaming at 10 m/s senses ω_ib^b = rot3(ψ)(ω_ie^n + ω_en^n); the transport
    rate (~2.5 % of the horizontal earth rate here) must be removed with the NED velocity,
    the latest fix and heading, else it biases the heading by about 0.7°."""
    lat, lon = math.radians(LAT), math.radians(LON)
    psi, v_n = math.radians(60.0), np.array([5.0, 10.0 * math.cos(math.radians(30.0)), 0.0])
    w_b = rot3(psi) @ (earth.earth_rate_n(lat) + earth.transport_rate_n(lat, 0.0, v_n))
    sp = FreeGyroSensorParams(U_A, U_B, pickoff_noise_arcsec=1.0, triad=GyroParams())
    results = {}
    for with_velocity in (False, True):
        sensor = FreeGyroSensor(sp, np.random.default_rng(4), 0.1)
        core = FreeGyroPositioning(FreeGyroPositioningParams(U_A, U_B))
        fix = None
        for k in range(1, 1302):
            s = sensor.update(0.1 * k, lat, lon, (0.0, 0.0, psi), w_b)
            core.on_level(s.t, s.roll, s.pitch)
            if with_velocity:
                core.on_velocity(s.t, v_n)
            core.on_body_rates(s.t, s.omega_ib_b)
            fix = core.on_spin_axes(s.t, s.spin_a_b, s.spin_b_b).output or fix
        results[with_velocity] = math.remainder(fix.heading_earth_rate - psi, math.tau)
    assert abs(results[False]) > 0.5 * math.pi / 180.0
    assert abs(results[True]) < 0.5 * ARCSEC


# ---------------------------------------------------------------- sensor suite wiring
def test_sensor_suite_free_gyro_against_an_independent_rotation_chain():
    """The suite's free gyro at 10 Hz on a 50 Hz paper5_ship run, noise-free: the spin axes
    are C_bn C_ni u_i and the triad rate is the rotation of b over the sample interval in
    inertial space divided by the interval, both rebuilt with scipy from the truth Euler
    angles; the core fed these samples fixes the ship's site to < 0.5 m."""
    from gimbal_sim.world.sensor_suite import SensorSuite, SensorSuiteConfig
    from gimbal_sim.world.vehicle import VehicleConfig, VehicleCore

    rate, lat, lon = 50.0, math.radians(LAT), math.radians(LON)
    core = VehicleCore(VehicleConfig(profile="paper5_ship", plant="host_only", sim_rate_hz=rate, duration_s=21.0,
                                     profile_params={"lat_deg": LAT, "lon_deg": LON, "mean_heading_deg": 40.0}))
    suite = SensorSuite(SensorSuiteConfig(
        sensors=("free_gyro",), sim_rate_hz=rate, free_gyro_rate_hz=10.0, free_gyro_site_deg=(LAT, LON),
        free_gyro=FreeGyroSensorParams(U_A, U_B, pickoff_noise_arcsec=0.0, triad=GyroParams())))
    positioning = FreeGyroPositioning(FreeGyroPositioningParams(U_A, U_B))

    def R_ib(t, euler):
        R_nb = Rotation.from_euler("ZYX", [euler[2], euler[1], euler[0]])
        return Rotation.from_euler("z", earth.OMEGA_IE * t) * Rotation.from_matrix(earth.dcm_en(lat, lon)) * R_nb

    samples, prev, fixes = [], None, []
    while True:
        truth = core.truth()
        for s in suite.update(truth):
            samples.append(s)
            R = R_ib(truth.t, truth.euler)
            for u, meas in ((U_A, s.spin_a_b), (U_B, s.spin_b_b)):
                assert np.allclose(R.inv().apply(u), meas, atol=1e-12)
            if prev is not None:
                expected = (prev.inv() * R).as_rotvec() / 0.1
                assert np.allclose(s.omega_ib_b, expected, rtol=0.0, atol=1e-12)
            prev = R
            positioning.on_level(s.t, s.roll, s.pitch)
            positioning.on_body_rates(s.t, s.omega_ib_b)
            fix = positioning.on_spin_axes(s.t, s.spin_a_b, s.spin_b_b).output
            if fix is not None:
                fixes.append(fix)
        if core.finished:
            break
        core.step(())
    assert [round(s.t, 9) for s in samples[:3]] == [0.0, 0.1, 0.2] and len(samples) == 211
    assert len(fixes) == 2 and all(f.valid for f in fixes)
    rm, rn = earth.meridian_radius(lat), earth.prime_vertical_radius(lat) * math.cos(lat)
    for f in fixes:
        assert abs((f.lat - lat) * rm) < 0.5 and abs((f.lon - lon) * rn) < 0.5
