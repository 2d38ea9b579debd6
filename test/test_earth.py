"""WGS-84 earth model against published constants and numerical differentiation."""
import math

import numpy as np
import pytest

from gimbal_kinematics.maths import earth
from gimbal_kinematics.maths.rotations import unskew


def test_published_wgs84_values():
    assert math.isclose(earth.E2, 6.69437999014e-3, rel_tol=1e-11)
    assert math.isclose(earth.B, 6356752.314245, abs_tol=1e-6)
    # NIMA TR8350.2 Table 3.4: normal gravity at the equator and the poles
    assert math.isclose(earth.normal_gravity(0.0), 9.7803253359, abs_tol=1e-10)
    assert math.isclose(earth.normal_gravity(math.pi / 2), 9.8321849378, abs_tol=1e-9)
    assert math.isclose(earth.meridian_radius(0.0), earth.A * (1 - earth.E2), rel_tol=1e-15)
    assert math.isclose(earth.prime_vertical_radius(0.0), earth.A, rel_tol=1e-15)
    assert math.isclose(earth.meridian_radius(math.pi / 2), earth.A / math.sqrt(1 - earth.E2), rel_tol=1e-12)


def test_radii_are_the_ellipsoid_metric():
    # |dp/dlat| = R_M + h and |dp/dlon| = (R_N + h) cos(lat), from the ECEF closed form
    h_step = 1e-7
    for lat in np.radians([-80.0, -33.0, 0.0, 12.5, 45.0, 71.0]):
        for h in (0.0, 1500.0):
            d_lat = (earth.ecef_from_geodetic(lat + h_step, 0.3, h) - earth.ecef_from_geodetic(lat - h_step, 0.3, h)) / (2 * h_step)
            d_lon = (earth.ecef_from_geodetic(lat, 0.3 + h_step, h) - earth.ecef_from_geodetic(lat, 0.3 - h_step, h)) / (2 * h_step)
            assert math.isclose(np.linalg.norm(d_lat), earth.meridian_radius(lat) + h, rel_tol=1e-8)
            assert math.isclose(np.linalg.norm(d_lon), (earth.prime_vertical_radius(lat) + h) * math.cos(lat), rel_tol=1e-8)


def test_ned_axes_and_earth_rate():
    lat, lon = math.radians(39.9), math.radians(116.4)
    C_en = earth.dcm_en(lat, lon)
    np.testing.assert_allclose(C_en @ C_en.T, np.eye(3), atol=1e-15)
    # down is minus the ellipsoid normal; north is the direction of increasing latitude
    normal = np.array([math.cos(lat) * math.cos(lon), math.cos(lat) * math.sin(lon), math.sin(lat)])
    np.testing.assert_allclose(C_en[:, 2], -normal, atol=1e-15)
    north = earth.ecef_from_geodetic(lat + 1e-7, lon) - earth.ecef_from_geodetic(lat - 1e-7, lon)
    np.testing.assert_allclose(C_en[:, 0], north / np.linalg.norm(north), atol=1e-8)
    # earth rate is the ECEF z axis resolved in NED
    np.testing.assert_allclose(earth.earth_rate_n(lat), C_en.T @ [0, 0, earth.OMEGA_IE], atol=1e-20)


def test_transport_rate_matches_frame_rotation_of_a_moving_vehicle():
    rng = np.random.default_rng(7)
    for _ in range(20):
        lat, lon, h = rng.uniform(-1.3, 1.3), rng.uniform(-3, 3), rng.uniform(0, 3000)
        v_n = np.array([rng.normal(scale=200), rng.normal(scale=200), 0.0])
        lat_dot = v_n[0] / (earth.meridian_radius(lat) + h)
        lon_dot = v_n[1] / ((earth.prime_vertical_radius(lat) + h) * math.cos(lat))
        dt = 1e-3
        C_en = lambda t: earth.dcm_en(lat + lat_dot * t, lon + lon_dot * t)  # noqa: E731
        omega_en_n = unskew(C_en(0).T @ (C_en(dt) - C_en(-dt)) / (2 * dt), tol=1e-9)
        np.testing.assert_allclose(earth.transport_rate_n(lat, h, v_n), omega_en_n, atol=1e-12)
        # and the ECEF velocity of that motion is the NED velocity rotated to ECEF
        p = lambda t: earth.ecef_from_geodetic(lat + lat_dot * t, lon + lon_dot * t, h)  # noqa: E731
        np.testing.assert_allclose((p(dt) - p(-dt)) / (2 * dt), C_en(0) @ v_n, atol=1e-5)


def test_gravity_decreases_with_height_at_free_air_gradient():
    gradient = (earth.normal_gravity(0.7, 100.0) - earth.normal_gravity(0.7, 0.0)) / 100.0
    assert -3.10e-6 < gradient < -3.07e-6  # the standard free-air gradient, 3.086e-6 s^-2
    np.testing.assert_array_equal(earth.gravity_n(0.7)[:2], [0.0, 0.0])


def test_bad_latitude_and_poles_are_refused():
    with pytest.raises(ValueError, match="latitude"):
        earth.meridian_radius(2.0)
    with pytest.raises(ValueError, match="latitude"):
        earth.normal_gravity(float("nan"))
    with pytest.raises(ValueError, match="poles"):
        earth.transport_rate_n(math.pi / 2, 0.0, np.array([1.0, 1.0, 0.0]))
