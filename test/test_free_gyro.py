"""Free-gyro geometry (paper 4) against independent constructions, numerical derivatives
and Monte Carlo statistics."""
import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from gimbal_kinematics.maths import earth
from gimbal_kinematics.maths import free_gyro as fg

RNG_SEED = 20260404
OMEGA = earth.OMEGA_IE


def _random_unit(rng):
    v = rng.normal(size=3)
    return v / np.linalg.norm(v)


def _down_i_scipy(lat, lon, t):
    """Ellipsoid-normal nadir in the inertial frame: NED down via dcm_en, then earth rotation."""
    down_e = earth.dcm_en(lat, lon) @ np.array([0.0, 0.0, 1.0])
    return Rotation.from_euler("z", OMEGA * t).as_matrix() @ down_e


def _down_i_ellipsoid(lat, lon, t, h=1e-6):
    """Outward normal of the WGS-84 surface from finite differences of the geodetic map."""
    d_lat = (earth.ecef_from_geodetic(lat + h, lon) - earth.ecef_from_geodetic(lat - h, lon)) / (2 * h)
    d_lon = (earth.ecef_from_geodetic(lat, lon + h) - earth.ecef_from_geodetic(lat, lon - h)) / (2 * h)
    up_e = np.cross(d_lon, d_lat)
    up_e /= np.linalg.norm(up_e)
    return -(Rotation.from_euler("z", OMEGA * t).as_matrix() @ up_e)


def _gyro_from_ned(lat, lon, t, theta, alpha):
    """Inertial gyro vector with nadir angle theta and azimuth alpha at (lat, lon, t)."""
    u_n = np.array([math.sin(theta) * math.cos(alpha), math.sin(theta) * math.sin(alpha), math.cos(theta)])
    return Rotation.from_euler("z", OMEGA * t).as_matrix() @ earth.dcm_en(lat, lon) @ u_n


def _random_geometry(rng, min_sin_crossing=0.2, max_lat=1.4):
    """Random truth and gyro pair whose circles cross at a usable angle."""
    while True:
        lat = rng.uniform(-max_lat, max_lat)
        lon = rng.uniform(-math.pi, math.pi)
        t = rng.uniform(0.0, 2.0e5)
        u_a, u_b = _random_unit(rng), _random_unit(rng)
        alpha_a = fg.gyro_azimuth(u_a, lat, lon, t)
        alpha_b = fg.gyro_azimuth(u_b, lat, lon, t)
        if abs(math.sin(alpha_b - alpha_a)) >= min_sin_crossing:
            return lat, lon, t, u_a, u_b, alpha_a, alpha_b


def test_nadir_angle_matches_independent_down_vector():
    rng = np.random.default_rng(RNG_SEED)
    for _ in range(300):
        lat, lon = rng.uniform(-math.pi / 2, math.pi / 2), rng.uniform(-4.0, 4.0)
        t = rng.uniform(0.0, 3.0 * 86400.0)
        u = _random_unit(rng)
        theta = fg.nadir_angle(u, lat, lon, t)
        ref = math.acos(np.clip(u @ _down_i_scipy(lat, lon, t), -1.0, 1.0))
        assert abs(theta - ref) < 1e-10
        # The same angle from the numerically built ellipsoid normal: eq. 1 is exact for
        # geodetic latitude, not only on a sphere.
        ref_ell = math.acos(np.clip(u @ _down_i_ellipsoid(lat, lon, t), -1.0, 1.0))
        assert abs(theta - ref_ell) < 1e-8


def test_nadir_and_azimuth_closed_forms_for_polar_axis_gyro():
    # A gyro along the earth's axis: θ = 90° + φ, azimuth north, at any longitude and time.
    for lat in np.linspace(-1.5, 1.5, 7):
        for lon, t in ((0.3, 0.0), (-2.0, 5000.0)):
            assert abs(fg.nadir_angle([0.0, 0.0, 1.0], lat, lon, t) - (math.pi / 2 + lat)) < 1e-14
            assert abs(fg.gyro_azimuth([0.0, 0.0, 1.0], lat, lon, t)) < 1e-14


def test_gyro_azimuth_matches_ned_resolution():
    rng = np.random.default_rng(RNG_SEED + 1)
    for _ in range(300):
        lat, lon, t = rng.uniform(-1.5, 1.5), rng.uniform(-math.pi, math.pi), rng.uniform(0.0, 1e5)
        u = _random_unit(rng)
        C_ie = Rotation.from_euler("z", OMEGA * t).as_matrix()
        u_n = earth.dcm_en(lat, lon).T @ C_ie.T @ u
        np.testing.assert_allclose(fg.gyro_vector_n(u, lat, lon, t), u_n, atol=1e-14)
        np.testing.assert_allclose(fg.dcm_ni(lat, lon, t) @ u, u_n, atol=1e-14)
        assert abs(fg.wrap_pi(fg.gyro_azimuth(u, lat, lon, t) - math.atan2(u_n[1], u_n[0]))) < 1e-12


def test_position_fix_round_trips():
    rng = np.random.default_rng(RNG_SEED + 2)
    checked_prior = 0
    for _ in range(500):
        lat, lon, t, u_a, u_b, alpha_a, alpha_b = _random_geometry(rng)
        theta_a, theta_b = fg.nadir_angle(u_a, lat, lon, t), fg.nadir_angle(u_b, lat, lon, t)
        sense = math.copysign(1.0, math.sin(alpha_b - alpha_a))
        fix_lat, fix_lon = fg.position_fix(u_a, u_b, theta_a, theta_b, t, azimuth_sense=sense)
        assert abs(fix_lat - lat) < 1e-9
        assert abs(fg.wrap_pi(fix_lon - lon)) < 1e-9
        # Candidate 1 is the branch with gyro b east of gyro a (documented rule).
        first, second = fg.position_fix_candidates(u_a, u_b, theta_a, theta_b, t)
        s1 = math.sin(fg.gyro_azimuth(u_b, *first, t) - fg.gyro_azimuth(u_a, *first, t))
        s2 = math.sin(fg.gyro_azimuth(u_b, *second, t) - fg.gyro_azimuth(u_a, *second, t))
        assert s1 > 0.0 > s2
        # Both candidates satisfy eq. 1.
        for cand in (first, second):
            assert abs(fg.nadir_angle(u_a, *cand, t) - theta_a) < 1e-9
            assert abs(fg.nadir_angle(u_b, *cand, t) - theta_b) < 1e-9
        # Nearest-prior rule, when the mirror solution is clearly farther than the prior offset.
        other = second if sense > 0 else first
        sep = _great_circle(lat, lon, *other)
        if sep > 0.05:
            prior = (lat + 0.01 * rng.uniform(-1, 1), lon + 0.01 * rng.uniform(-1, 1))
            p_lat, p_lon = fg.position_fix(u_a, u_b, theta_a, theta_b, t, prior=prior)
            assert abs(p_lat - lat) < 1e-9 and abs(fg.wrap_pi(p_lon - lon)) < 1e-9
            checked_prior += 1
    assert checked_prior > 400


def _great_circle(lat1, lon1, lat2, lon2):
    c = math.sin(lat1) * math.sin(lat2) + math.cos(lat1) * math.cos(lat2) * math.cos(lon2 - lon1)
    return math.acos(max(-1.0, min(1.0, c)))


def test_perturbation_matrix_matches_numerical_derivative():
    rng = np.random.default_rng(RNG_SEED + 3)
    h = 1e-6
    for _ in range(200):
        lat, lon, t, u_a, u_b, *_ = _random_geometry(rng, min_sin_crossing=0.05)
        W = fg.perturbation_matrix(u_a, u_b, lat, lon, t)
        W_num = np.empty((2, 2))
        dtheta_dt = np.empty(2)
        for k, u in enumerate((u_a, u_b)):
            W_num[k, 0] = (fg.nadir_angle(u, lat + h, lon, t) - fg.nadir_angle(u, lat - h, lon, t)) / (2 * h)
            W_num[k, 1] = (fg.nadir_angle(u, lat, lon + h, t) - fg.nadir_angle(u, lat, lon - h, t)) / (2 * h)
            dtheta_dt[k] = (fg.nadir_angle(u, lat, lon, t + 1.0) - fg.nadir_angle(u, lat, lon, t - 1.0)) / 2.0
        np.testing.assert_allclose(W, W_num, atol=2e-8)
        # A clock error acts exactly like a longitude error (only λ + ω_e t enters eq. 1).
        np.testing.assert_allclose(dtheta_dt, OMEGA * W[:, 1], atol=1e-11)


def test_fix_geometry_closed_forms():
    rng = np.random.default_rng(RNG_SEED + 4)
    for _ in range(100):
        lat, lon, t, u_a, u_b, alpha_a, alpha_b = _random_geometry(rng, min_sin_crossing=0.05)
        geo = fg.fix_geometry(u_a, u_b, lat, lon, t)
        np.testing.assert_allclose(geo.Q_latlon, np.linalg.inv(geo.W.T @ geo.W), rtol=1e-9)
        assert geo.fdop == pytest.approx(math.sqrt(2.0) / abs(math.sin(alpha_b - alpha_a)), rel=1e-12)
        assert geo.fdop_latlon == pytest.approx(math.sqrt(np.trace(geo.Q_latlon)), rel=1e-12)
        sigma = 3e-5
        cov_m = geo.covariance_ne_m(sigma, h=100.0)
        rm, rn = earth.meridian_radius(lat) + 100.0, earth.prime_vertical_radius(lat) + 100.0
        J = np.diag([rm, rn * math.cos(lat)])
        np.testing.assert_allclose(cov_m, J @ geo.covariance_latlon(sigma) @ J.T, rtol=1e-9)
        assert geo.position_error_m(sigma, h=100.0) == pytest.approx(math.sqrt(np.trace(cov_m)), rel=1e-12)


@pytest.mark.parametrize(
    "lat, lon, theta_ab, alpha_ab",
    [
        (math.radians(35.1), math.radians(129.0), (1.05, 1.30), (math.radians(20.0), math.radians(95.0))),
        (math.radians(-68.0), math.radians(-40.0), (0.7, 2.2), (math.radians(-150.0), math.radians(-100.0))),
    ],
)
def test_fdop_covariance_matches_monte_carlo(lat, lon, theta_ab, alpha_ab):
    rng = np.random.default_rng(RNG_SEED + 5)
    t, sigma, n = 5400.0, 1e-5, 10_000
    u_a = _gyro_from_ned(lat, lon, t, theta_ab[0], alpha_ab[0])
    u_b = _gyro_from_ned(lat, lon, t, theta_ab[1], alpha_ab[1])
    theta_a, theta_b = fg.nadir_angle(u_a, lat, lon, t), fg.nadir_angle(u_b, lat, lon, t)
    geo = fg.fix_geometry(u_a, u_b, lat, lon, t)
    noise = rng.normal(scale=sigma, size=(n, 2))
    err = np.empty((n, 2))
    for k in range(n):
        f_lat, f_lon = fg.position_fix(
            u_a, u_b, theta_a + noise[k, 0], theta_b + noise[k, 1], t, prior=(lat, lon)
        )
        err[k] = (f_lat - lat, fg.wrap_pi(f_lon - lon))
    P = geo.covariance_latlon(sigma)
    S = np.cov(err, rowvar=False)
    # Each sample variance has relative std √(2/n) ≈ 1.4 %: 5 % is a 3.5σ band.
    assert S[0, 0] / P[0, 0] == pytest.approx(1.0, abs=0.05)
    assert S[1, 1] / P[1, 1] == pytest.approx(1.0, abs=0.05)
    # Trace in metres (east arc scaled by cos φ): FDOP²σ² times the radii.
    scale = np.diag([earth.meridian_radius(lat), earth.prime_vertical_radius(lat) * math.cos(lat)])
    trace_m = np.trace(scale @ S @ scale)
    assert trace_m / geo.position_error_m(sigma) ** 2 == pytest.approx(1.0, abs=0.05)
    # Whitened errors: mean squared Mahalanobis distance is χ²₂/n with std 2/√n = 1 %.
    L = np.linalg.cholesky(P)
    white = np.linalg.solve(L, err.T)
    assert np.mean(np.sum(white**2, axis=0)) == pytest.approx(2.0, rel=0.05)
    # Correlation coefficient: std ≈ (1 − ρ²)/√n ≤ 0.01.
    rho_pred = P[0, 1] / math.sqrt(P[0, 0] * P[1, 1])
    rho_mc = S[0, 1] / math.sqrt(S[0, 0] * S[1, 1])
    assert abs(rho_mc - rho_pred) < 0.04


def test_degenerate_geometry_raises_with_cause():
    lat, lon, t = 0.6, 1.2, 100.0
    u_a = _gyro_from_ned(lat, lon, t, 1.0, 0.3)
    theta = fg.nadir_angle(u_a, lat, lon, t)
    with pytest.raises(ValueError, match="parallel"):
        fg.position_fix(u_a, u_a, theta, theta, t, prior=(lat, lon))
    with pytest.raises(ValueError, match="antiparallel"):
        fg.position_fix(u_a, -u_a, theta, math.pi - theta, t, prior=(lat, lon))
    nearly = Rotation.from_rotvec([1e-8, 0.0, 0.0]).apply(u_a)
    with pytest.raises(ValueError, match="parallel"):
        fg.position_fix_candidates(u_a, nearly, theta, theta, t)
    # Nadirs 90° apart, circles of 10° radius: cannot meet.
    x, y = [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]
    with pytest.raises(ValueError, match="do not intersect.*inconsistent"):
        fg.position_fix(x, y, 0.17, 0.17, t, azimuth_sense=1.0)
    # Radii summing to the 90° separation: tangent circles.
    with pytest.raises(ValueError, match="tangent"):
        fg.position_fix(x, y, 0.6, math.pi / 2 - 0.6, t, azimuth_sense=1.0)
    # Linearised geometry with both gyros at the same azimuth is tangent too.
    u_b = _gyro_from_ned(lat, lon, t, 1.4, 0.3)
    with pytest.raises(ValueError, match="tangent"):
        fg.fix_geometry(u_a, u_b, lat, lon, t)


def test_bad_inputs_raise_naming_the_parameter():
    u = [1.0, 0.0, 0.0]
    with pytest.raises(ValueError, match="u_a_i must be a unit vector"):
        fg.position_fix([2.0, 0.0, 0.0], [0.0, 1.0, 0.0], 1.0, 1.0, 0.0, azimuth_sense=1.0)
    with pytest.raises(ValueError, match="theta_b"):
        fg.position_fix(u, [0.0, 1.0, 0.0], 1.0, 3.5, 0.0, azimuth_sense=1.0)
    with pytest.raises(ValueError, match="exactly one of prior or azimuth_sense"):
        fg.position_fix(u, [0.0, 1.0, 0.0], 1.0, 1.0, 0.0)
    with pytest.raises(ValueError, match="lat"):
        fg.nadir_angle(u, 2.0, 0.0, 0.0)
    with pytest.raises(ValueError, match="vertical"):
        fg.gyro_azimuth([0.0, 0.0, 1.0], math.pi / 2, 0.0, 0.0)
    with pytest.raises(ValueError, match="min_sin_crossing_angle"):
        fg.FixTolerances(min_sin_crossing_angle=0.0)
    with pytest.raises(ValueError, match="sigma_theta"):
        fg.fix_geometry(u, [0.0, 1.0, 0.0], 0.3, 0.2, 0.0).covariance_latlon(-1.0)


def _earth_rate_b(lat, roll, pitch, yaw):
    C_nb = Rotation.from_euler("ZYX", [yaw, pitch, roll]).as_matrix()
    return C_nb.T @ earth.earth_rate_n(lat)


def test_heading_from_earth_rate_round_trips():
    rng = np.random.default_rng(RNG_SEED + 6)
    for _ in range(500):
        lat, yaw = rng.uniform(-1.4, 1.4), rng.uniform(-math.pi, math.pi)
        roll, pitch = rng.uniform(-0.5, 0.5, size=2)
        w_b = _earth_rate_b(lat, roll, pitch, yaw)
        assert abs(fg.wrap_pi(fg.heading_from_earth_rate(w_b, roll, pitch) - yaw)) < 1e-12
        # Level body: the fore-aft/athwartship components of eq. 3 with FRD signs.
        w_level = _earth_rate_b(lat, 0.0, 0.0, yaw)
        c = OMEGA * math.cos(lat)
        np.testing.assert_allclose(w_level[:2], [c * math.cos(yaw), -c * math.sin(yaw)], atol=1e-18)
        assert abs(fg.wrap_pi(fg.heading_from_earth_rate(w_level) - yaw)) < 1e-12
    with pytest.raises(ValueError, match="pole"):
        fg.heading_from_earth_rate(_earth_rate_b(math.pi / 2, 0.0, 0.0, 0.4))


def test_heading_error_matches_finite_perturbation():
    rng = np.random.default_rng(RNG_SEED + 7)
    eps = 1e-6
    for _ in range(300):
        lat, yaw = rng.uniform(-1.3, 1.3), rng.uniform(-math.pi, math.pi)
        roll, pitch = rng.uniform(-0.3, 0.3, size=2)
        w_b = _earth_rate_b(lat, roll, pitch, yaw)
        d_w = eps * OMEGA * rng.normal(size=3)
        d_roll, d_pitch = eps * rng.normal(size=2)
        nominal = fg.heading_from_earth_rate(w_b, roll, pitch)
        zero = np.zeros(3)
        cases = ((d_w, 0.0, 0.0), (zero, d_roll, 0.0), (zero, 0.0, d_pitch), (d_w, d_roll, d_pitch))
        for dw, dr, dp in cases:
            true = fg.wrap_pi(fg.heading_from_earth_rate(w_b + dw, roll + dr, pitch + dp) - nominal)
            lin = fg.heading_error(w_b, dw, roll, pitch, dr, dp)
            # Second-order remainder ~ (ε sec φ)²; the first-order term is ~ ε sec φ.
            assert abs(lin - true) < 1e-9 / math.cos(lat) ** 2


def test_heading_error_from_tilt_closed_form():
    # Level body: a tilt error leaks the vertical earth rate −Ω sin φ into a horizontal axis
    # (pitch: fore-aft, δψ = tan φ sin ψ δθ; roll: athwartship, δψ = −tan φ cos ψ δφ) —
    # the classic gyrocompass tilt/latitude error, derived by hand from eq. 3–4.
    for lat in (-0.9, 0.2, 1.1):
        for yaw in (-2.5, 0.4, 1.9):
            w_b = _earth_rate_b(lat, 0.0, 0.0, yaw)
            assert fg.heading_error(w_b, np.zeros(3), delta_pitch=1e-4) == pytest.approx(
                math.tan(lat) * math.sin(yaw) * 1e-4, rel=1e-9
            )
            assert fg.heading_error(w_b, np.zeros(3), delta_roll=1e-4) == pytest.approx(
                -math.tan(lat) * math.cos(yaw) * 1e-4, rel=1e-9
            )
