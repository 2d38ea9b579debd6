"""Geo-pointing against geodesy we did not write (pymap3d, EPSG's published WGS-84 examples),
the forward sighting chain, closed forms and Monte Carlo statistics."""
import math

import numpy as np
import pymap3d as pm
import pytest
from scipy.spatial.transform import Rotation

from gimbal_kinematics.maths.geo_pointing import (
    BUDGET_TERMS, GimbalLimits, PointingSigmas, geo_point, joint_angles_for_los, los_to_target,
    pointing_budget,
)
from gimbal_kinematics.maths.rotations import euler321_to_dcm
from gimbal_kinematics.maths.sighting_chain import dcm_bm

D = math.radians


def _angle(a, b):
    return math.atan2(float(np.linalg.norm(np.cross(a, b))), float(np.dot(a, b)))


def _llh_rad(lat_deg, lon_deg, h):
    return (D(lat_deg), D(lon_deg), h)


# EPSG Guidance Note 7-2 (IOGP Publication 373-7-2), WGS 84 examples: method 9602
# (geographic/geocentric) gives the North Sea point 53°48'33.820"N, 2°07'46.380"E, h = 73.0 m
# at X = 3771793.968, Y = 140253.342, Z = 5124304.349 m; method 9837 (geographic/topocentric)
# gives the same point, seen from the origin 55°N, 5°E, h = 200 m, at
# E = -189013.869, N = -128642.040, U = -4220.171 m.
EPSG_POINT_DEG = (53 + 48 / 60 + 33.820 / 3600, 2 + 7 / 60 + 46.380 / 3600, 73.0)
EPSG_ORIGIN_DEG = (55.0, 5.0, 200.0)
EPSG_ENU_M = (-189013.869, -128642.040, -4220.171)


def test_los_matches_the_published_epsg_topocentric_example():
    los = los_to_target(_llh_rad(*EPSG_ORIGIN_DEG), _llh_rad(*EPSG_POINT_DEG))
    e, n, u = EPSG_ENU_M
    ned = np.array([n, e, -u])
    print(f"EPSG 9837 example: direction {_angle(los.los_n, ned):.2g} rad, "
          f"range {los.range_m - np.linalg.norm(ned):+.2g} m")
    # published to the mm over 229 km: a direction to ~5e-9 rad, a range to ~1 mm
    assert _angle(los.los_n, ned) < 1e-8
    assert los.range_m == pytest.approx(np.linalg.norm(ned), abs=2e-3)


def test_los_matches_pymap3d_for_random_pairs():
    rng = np.random.default_rng(24)
    worst_dir = worst_az = worst_el = worst_range = 0.0
    for _ in range(500):
        lat0, lon0, h0 = rng.uniform(-89.0, 89.0), rng.uniform(-180.0, 180.0), rng.uniform(-100.0, 5000.0)
        # targets from 10 m to 50 km away in any direction, up to 3 km above or below
        dist = 10 ** rng.uniform(1.0, 4.7)
        n, e, d = dist * np.cos(b := rng.uniform(0, 2 * np.pi)), dist * np.sin(b), rng.uniform(-3000, 3000)
        lat1, lon1, h1 = pm.ned2geodetic(n, e, d, lat0, lon0, h0)
        los = los_to_target(_llh_rad(lat0, lon0, h0), _llh_rad(lat1, lon1, h1))
        ned = np.array(pm.geodetic2ned(lat1, lon1, h1, lat0, lon0, h0))
        az, el, srange = pm.geodetic2aer(lat1, lon1, h1, lat0, lon0, h0)
        worst_dir = max(worst_dir, _angle(los.los_n, ned))
        worst_az = max(worst_az, abs(math.remainder(los.azimuth_rad - D(az), 2 * math.pi)))
        worst_el = max(worst_el, abs(los.elevation_rad - D(el)))
        worst_range = max(worst_range, abs(los.range_m - srange) / srange)
    print(f"worst over 500 pairs: direction {worst_dir:.2g} rad, azimuth {worst_az:.2g} rad, "
          f"elevation {worst_el:.2g} rad, range {worst_range:.2g} (relative)")
    # double rounding of ~6.4e6 m ECEF coordinates (~1e-9 m) over a 10 m range is ~1e-10
    assert worst_dir < 1e-9 and worst_az < 1e-9 and worst_el < 1e-9 and worst_range < 1e-9


def _ned_at(origin_deg, from_deg, to_deg):
    """pymap3d: the vector from one geodetic point to another, resolved in NED at origin."""
    d = np.subtract(pm.geodetic2ecef(*to_deg), pm.geodetic2ecef(*from_deg))
    return np.array(pm.ecef2nedv(*d, *origin_deg[:2]))


def test_lever_arm_moves_the_los_origin_to_the_pivot():
    vehicle, target = (40.0, -3.0, 600.0), (40.0 + 0.02, -3.0 + 0.01, 650.0)
    euler, lever_b = (D(2.0), D(-3.0), D(70.0)), np.array([1.2, -0.4, -0.8])
    C_nb = euler321_to_dcm(*euler)
    pivot = pm.ned2geodetic(*(C_nb @ lever_b), *vehicle)
    ned = _ned_at(vehicle, pivot, target)
    los = los_to_target(_llh_rad(*vehicle), _llh_rad(*target), C_nb, lever_b)
    assert _angle(los.los_n, ned) < 1e-10
    assert los.range_m == pytest.approx(np.linalg.norm(ned), abs=1e-6)


def test_inverse_chain_points_the_m_x_axis_along_the_los():
    rng = np.random.default_rng(7)
    worst = 0.0
    for _ in range(2000):
        euler = (rng.uniform(-0.5, 0.5), rng.uniform(-1.4, 1.4), rng.uniform(-np.pi, np.pi))
        C_nb = euler321_to_dcm(*euler)
        u = rng.normal(size=3)
        u /= np.linalg.norm(u)
        sol = joint_angles_for_los(C_nb, u, rng.uniform(-np.pi, np.pi))
        # forward chain, composed independently with scipy: Rz(ψ)Ry(θ)Rx(φ) · Rz(ψt+ψm) · Ry(θm)
        C_nm = (Rotation.from_euler("ZYX", euler[::-1])
                * Rotation.from_euler("z", sol.psi_t + sol.psi_m) * Rotation.from_euler("y", sol.theta_m))
        worst = max(worst, _angle(C_nm.apply([1.0, 0.0, 0.0]), u))
        assert not (sol.azimuth_limited or sol.elevation_limited or sol.singular or sol.turret_handover)
        assert sol.residual_rad < 1e-9
    print(f"worst inverse-chain miss over 2000 draws: {worst:.2g} rad")
    assert worst < 1e-9


def _body_los(C_nb, az_b, el_b):
    return C_nb @ np.array([math.cos(el_b) * math.cos(az_b), math.cos(el_b) * math.sin(az_b), -math.sin(el_b)])


def test_elevation_limit_stops_and_reports_the_miss():
    C_nb = euler321_to_dcm(0.1, -0.05, 1.0)
    limits = GimbalLimits(elevation_min_rad=D(-20.0), elevation_max_rad=D(60.0))
    sol = joint_angles_for_los(C_nb, _body_los(C_nb, D(30.0), D(75.0)), 0.0, limits)
    assert sol.elevation_limited and not sol.azimuth_limited
    assert sol.theta_m == pytest.approx(D(60.0)) and sol.psi_m == pytest.approx(D(30.0))
    assert sol.residual_rad == pytest.approx(D(15.0), abs=1e-12)


@pytest.mark.parametrize("handover", ["stop", "turret"])
def test_azimuth_limit_stops_or_hands_over_to_the_turret(handover):
    C_nb = euler321_to_dcm(0.02, 0.03, -2.0)
    limits = GimbalLimits(azimuth_min_rad=D(-30.0), azimuth_max_rad=D(30.0), handover=handover)
    u = _body_los(C_nb, D(100.0), D(10.0))
    sol = joint_angles_for_los(C_nb, u, D(20.0), limits)
    achieved = C_nb @ dcm_bm(sol.psi_t, sol.psi_m, sol.theta_m)[:, 0]
    assert sol.azimuth_limited and sol.psi_m == pytest.approx(D(30.0))
    if handover == "stop":
        # the LOS stops 100 − 20 − 30 = 50° short in body azimuth, at 10° elevation
        assert not sol.turret_handover and sol.psi_t == pytest.approx(D(20.0))
        miss = math.acos(math.cos(D(10.0)) ** 2 * math.cos(D(50.0)) + math.sin(D(10.0)) ** 2)
        assert sol.residual_rad == pytest.approx(miss, abs=1e-12)
        assert _angle(achieved, u) == pytest.approx(miss, abs=1e-12)
    else:
        assert sol.turret_handover and sol.psi_t == pytest.approx(D(70.0))
        assert _angle(achieved, u) < 1e-12 and sol.residual_rad < 1e-12


def test_azimuth_clips_to_the_nearer_limit():
    limits = GimbalLimits(azimuth_min_rad=D(-30.0), azimuth_max_rad=D(30.0))
    C_nb = np.eye(3)
    assert joint_angles_for_los(C_nb, _body_los(C_nb, D(170.0), 0.0), 0.0, limits).psi_m == pytest.approx(D(30.0))
    assert joint_angles_for_los(C_nb, _body_los(C_nb, D(-170.0), 0.0), 0.0, limits).psi_m == pytest.approx(D(-30.0))


def test_zenith_holds_the_azimuth_and_flags_the_singularity():
    C_nb = euler321_to_dcm(0.1, 0.2, 0.3)
    sol = joint_angles_for_los(C_nb, C_nb @ np.array([0.0, 0.0, -1.0]), D(5.0), psi_m_hold=D(12.0))
    assert sol.singular and sol.psi_m == pytest.approx(D(12.0)) and sol.theta_m == pytest.approx(D(90.0))
    assert sol.residual_rad < 1e-9 and not sol.azimuth_limited


def test_budget_closed_forms_for_a_level_vehicle_looking_north():
    vehicle = _llh_rad(30.0, 10.0, 100.0)
    R = 3000.0
    target = _llh_rad(*pm.ned2geodetic(R, 0.0, 0.0, 30.0, 10.0, 100.0))
    sig = PointingSigmas(roll_rad=1e-3, pitch_rad=2e-3, heading_rad=3e-3, vehicle_horizontal_m=4.0,
                         vehicle_vertical_m=5.0, target_horizontal_m=6.0, target_vertical_m=7.0)
    b = pointing_budget(vehicle, np.eye(3), target, sig)
    t = b.terms
    assert tuple(t) == BUDGET_TERMS
    assert t["roll"] < 1e-12  # a roll error turns the sight about its own LOS
    assert t["pitch"] == pytest.approx(2e-3, rel=1e-9) and t["heading"] == pytest.approx(3e-3, rel=1e-9)
    # only the cross-LOS (east) horizontal axis counts; the vertical counts fully
    for name, sigma in (("vehicle_horizontal", 4.0), ("vehicle_vertical", 5.0),
                        ("target_horizontal", 6.0), ("target_vertical", 7.0)):
        assert t[name] == pytest.approx(sigma / R, rel=1e-6), name
    assert b.total_rad == pytest.approx(math.sqrt(sum(v * v for v in t.values())), rel=1e-12)
    assert b.range_m == pytest.approx(R, rel=1e-9)


CASES = {
    # name: vehicle (lat, lon, h), Euler (deg), target NED offset (m), lever arm (m), sigmas
    "paper1_ins_3km": ((39.9, 32.8, 900.0), (1.5, -1.0, 60.0), (1500.0, 2500.0, -150.0), (0.0, 0.0, 0.0),
                       PointingSigmas(D(0.05), D(0.05), D(0.2), 2.0, 4.0, 5.0, 5.0)),
    "positions_dominate_400m": ((-33.9, 151.2, 50.0), (-4.0, 6.0, -120.0), (-300.0, 250.0, -80.0),
                                (0.0, 0.0, 0.0), PointingSigmas(D(0.01), D(0.01), D(0.02), 3.0, 5.0, 4.0, 6.0)),
    # a 3 m mast 20 m from the target: the attitude error also moves the pivot (L/R ≈ 0.15)
    "lever_arm_20m_look_down": ((60.0, 25.0, 300.0), (3.0, 8.0, 200.0), (12.0, -8.0, 14.0),
                                (0.5, 1.0, -3.0), PointingSigmas(D(0.5), D(0.5), D(1.0), 0.02, 0.02, 0.02, 0.02)),
}


@pytest.mark.parametrize("case", list(CASES))
def test_budget_matches_monte_carlo(case):
    (lat0, lon0, h0), euler_deg, off_ned, lever, sig = CASES[case]
    rng = np.random.default_rng(list(CASES).index(case) + 100)
    euler = np.radians(euler_deg)
    C_nb, lever = euler321_to_dcm(*euler), np.array(lever)
    target = pm.ned2geodetic(*off_ned, lat0, lon0, h0)
    pivot = pm.ned2geodetic(*(C_nb @ lever), lat0, lon0, h0)
    true_los = _ned_at((lat0, lon0, h0), pivot, target)
    true_los /= np.linalg.norm(true_los)
    budget = pointing_budget(_llh_rad(lat0, lon0, h0), C_nb, _llh_rad(*target), sig, lever)
    n = 3000
    e_att = rng.normal(size=(n, 3)) * [sig.roll_rad, sig.pitch_rad, sig.heading_rad]
    dv = rng.normal(size=(n, 3)) * [sig.vehicle_horizontal_m, sig.vehicle_horizontal_m, sig.vehicle_vertical_m]
    dt = rng.normal(size=(n, 3)) * [sig.target_horizontal_m, sig.target_horizontal_m, sig.target_vertical_m]
    err = np.empty(n)
    for k in range(n):
        C_est = euler321_to_dcm(*(euler + e_att[k]))
        v_est = pm.ned2geodetic(*dv[k], lat0, lon0, h0)
        t_est = pm.ned2geodetic(*dt[k], *target)
        _, sol = geo_point(_llh_rad(*v_est), C_est, _llh_rad(*t_est), 0.0, lever_arm_b=lever)
        achieved = C_nb @ dcm_bm(sol.psi_t, sol.psi_m, sol.theta_m)[:, 0]
        err[k] = _angle(achieved, true_los)
    rms = math.sqrt(float(np.mean(err**2)))
    print(f"{case}: Monte Carlo RMS {rms * 1e3:.4f} mrad, budget {budget.total_rad * 1e3:.4f} mrad, "
          f"ratio {rms / budget.total_rad:.4f}, terms (mrad) "
          + ", ".join(f"{k} {v * 1e3:.4f}" for k, v in budget.terms.items()))
    assert rms == pytest.approx(budget.total_rad, rel=0.10)


@pytest.mark.parametrize("vehicle, target, match", [
    ((D(10.0), D(20.0), 5.0), (D(10.0), D(20.0), 5.0), "minimum range"),
    ((D(10.0), D(20.0), 5.0), (D(10.0), D(20.0), 5.5), "minimum range"),
    ((D(10.0), float("nan"), 5.0), (D(10.0), D(20.1), 5.0), "vehicle: position must be finite"),
    ((D(10.0), D(20.0), 5.0), (D(10.0), D(20.1), float("inf")), "target: position must be finite"),
    ((D(91.0), D(20.0), 5.0), (D(10.0), D(20.1), 5.0), "vehicle: latitude 91"),
    ((D(10.0), D(20.0), 5.0), (D(-95.0), D(20.1), 5.0), "target: latitude -95"),
    ((D(10.0), D(400.0), 5.0), (D(10.0), D(20.1), 5.0), "vehicle: longitude 400"),
])
def test_bad_positions_are_refused(vehicle, target, match):
    with pytest.raises(ValueError, match=match):
        geo_point(vehicle, np.eye(3), target, 0.0)
    with pytest.raises(ValueError, match=match):
        pointing_budget(vehicle, np.eye(3), target, PointingSigmas())


def test_bad_attitude_angles_and_sigmas_are_refused():
    vehicle, target = (D(10.0), D(20.0), 5.0), (D(10.01), D(20.0), 5.0)
    bad_C = np.eye(3)
    bad_C[0, 0] = float("nan")
    with pytest.raises(ValueError, match="C_nb"):
        geo_point(vehicle, bad_C, target, 0.0)
    with pytest.raises(ValueError, match="C_nb"):
        geo_point(vehicle, np.diag([1.0, 1.0, -1.0]), target, 0.0)
    with pytest.raises(ValueError, match="psi_t"):
        geo_point(vehicle, np.eye(3), target, float("nan"))
    with pytest.raises(ValueError, match="los_n"):
        joint_angles_for_los(np.eye(3), [0.0, float("inf"), 0.0], 0.0)
    with pytest.raises(ValueError, match="heading_rad"):
        PointingSigmas(heading_rad=-1e-3)
    with pytest.raises(ValueError, match="target_vertical_m"):
        PointingSigmas(target_vertical_m=float("nan"))
    with pytest.raises(ValueError, match="elevation limits"):
        GimbalLimits(elevation_max_rad=D(120.0))
    with pytest.raises(ValueError, match="handover"):
        GimbalLimits(handover="slew")


def test_budget_terms_match_numerical_derivatives_with_a_lever_arm():
    """Each term is σ·|∂d/∂x| for the realised LOS error d; central differences of the
    whole chain (pymap3d moves the positions) check the lever-arm coupling term exactly."""
    (lat0, lon0, h0), euler_deg, off_ned, lever, sig = CASES["lever_arm_20m_look_down"]
    euler, lever = np.radians(euler_deg), np.array(lever)
    C_nb = euler321_to_dcm(*euler)
    target = pm.ned2geodetic(*off_ned, lat0, lon0, h0)
    true_los = _ned_at((lat0, lon0, h0), pm.ned2geodetic(*(C_nb @ lever), lat0, lon0, h0), target)
    true_los /= np.linalg.norm(true_los)

    def realised(d_euler=np.zeros(3), d_vehicle=np.zeros(3), d_target=np.zeros(3)):
        vehicle = pm.ned2geodetic(*d_vehicle, lat0, lon0, h0)
        tgt = pm.ned2geodetic(*d_target, *target)
        _, sol = geo_point(_llh_rad(*vehicle), euler321_to_dcm(*(euler + d_euler)), _llh_rad(*tgt), 0.0,
                           lever_arm_b=lever)
        return C_nb @ dcm_bm(sol.psi_t, sol.psi_m, sol.theta_m)[:, 0] - true_los

    def slope(kw, axis, step):
        dx = np.zeros(3)
        dx[axis] = step
        return (realised(**{kw: dx}) - realised(**{kw: -dx})) / (2 * step)

    budget = pointing_budget(_llh_rad(lat0, lon0, h0), C_nb, _llh_rad(*target), sig, lever)
    expected = {
        "roll": sig.roll_rad * np.linalg.norm(slope("d_euler", 0, 1e-6)),
        "pitch": sig.pitch_rad * np.linalg.norm(slope("d_euler", 1, 1e-6)),
        "heading": sig.heading_rad * np.linalg.norm(slope("d_euler", 2, 1e-6)),
        "vehicle_horizontal": sig.vehicle_horizontal_m * math.hypot(
            np.linalg.norm(slope("d_vehicle", 0, 1e-3)), np.linalg.norm(slope("d_vehicle", 1, 1e-3))),
        "vehicle_vertical": sig.vehicle_vertical_m * np.linalg.norm(slope("d_vehicle", 2, 1e-3)),
        "target_horizontal": sig.target_horizontal_m * math.hypot(
            np.linalg.norm(slope("d_target", 0, 1e-3)), np.linalg.norm(slope("d_target", 1, 1e-3))),
        "target_vertical": sig.target_vertical_m * np.linalg.norm(slope("d_target", 2, 1e-3)),
    }
    for name, value in expected.items():
        assert budget.terms[name] == pytest.approx(value, rel=1e-5), name


def test_the_95_percent_radius_against_closed_forms_scipy_and_monte_carlo():
    """radial_quantile: the Rayleigh and normal closed forms at the two ends, and between them
    scipy's quadrature of P(|d| ≤ r) in Cartesian form with brentq, and a seeded Monte Carlo."""
    from scipy import integrate, optimize, stats

    from gimbal_kinematics.maths.geo_pointing import radial_quantile

    assert radial_quantile(2.0, 2.0) == pytest.approx(2.0 * math.sqrt(-2.0 * math.log(0.05)), rel=1e-12)
    assert radial_quantile(3.0, 0.0) == pytest.approx(3.0 * stats.norm.ppf(0.975), rel=1e-12)
    assert radial_quantile(0.0, 0.0) == 0.0

    def cdf(r, s1, s2):  # ∫ φ(x) P(|s2 z2| ≤ √(r² − s1² x²)) dx over |x| ≤ r / s1
        a = r / s1
        return integrate.quad(lambda x: stats.norm.pdf(x) * (2.0 * stats.norm.cdf(
            math.sqrt(max(r * r - (s1 * x) ** 2, 0.0)) / s2) - 1.0), -a, a, epsabs=1e-13, epsrel=1e-13)[0]

    rng = np.random.default_rng(24)
    for s1, s2 in ((3.9445, 2.3598), (1.0, 0.1), (1.0, 0.7)):
        ref = optimize.brentq(lambda r: cdf(r, s1, s2) - 0.95, 1.9 * s1, 2.5 * s1, xtol=1e-13)
        r95 = radial_quantile(s2, s1)  # either order
        assert r95 == pytest.approx(ref, rel=1e-9)
        d = rng.normal(size=(400_000, 2)) * (s1, s2)
        assert np.mean(np.hypot(d[:, 0], d[:, 1]) <= r95) == pytest.approx(0.95, abs=0.0015)  # 4.4 binomial σ
    with pytest.raises(ValueError):
        radial_quantile(math.nan, 1.0)
