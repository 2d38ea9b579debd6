"""geo_pointer's core on a moving vehicle (geo-pointing from the INS position):
a vehicle at constant velocity passes a target; the direction the core aims at is
pymap3d's at every step, its feed-forward is the rate of pymap3d's direction by numerical
differentiation, and a loop on that feed-forward holds the target where one without the
velocity lags by the type-1 closed form."""
import math

import numpy as np
import pymap3d as pm
import pytest
from scipy.spatial.transform import Rotation

from gimbal_control.geo_pointer import GeoPointer, GeoPointerParams
from gimbal_kinematics.maths.earth import transport_rate_n

ORIGIN = (39.9, 32.8, 900.0)  # deg, deg, m: the local east-north-up origin of the pass
TARGET_ENU = (0.0, 400.0, 30.0)  # the target 400 m north of the road
START_ENU = np.array([-600.0, 0.0, 2.0])
VEL_ENU = np.array([20.0, 0.0, 0.0])  # 20 m/s east along the road, straight in the origin's tangent plane
TARGET_DEG = pm.enu2geodetic(*TARGET_ENU, *ORIGIN)
TARGET = (math.radians(TARGET_DEG[0]), math.radians(TARGET_DEG[1]), float(TARGET_DEG[2]))


def _vehicle(t: float) -> tuple[tuple[float, float, float], np.ndarray]:
    """The vehicle's (lat, lon [rad], h [m]) at t [s] and its velocity in its own NED [m/s],
    both from pymap3d (the origin's ENU velocity through ECEF into the vehicle's NED)."""
    lat, lon, h = pm.enu2geodetic(*(START_ENU + VEL_ENU * t), *ORIGIN)
    v_ecef = pm.enu2uvw(*VEL_ENU, ORIGIN[0], ORIGIN[1])
    v_ned = np.array(pm.ecef2nedv(*v_ecef, lat, lon))
    return (math.radians(lat), math.radians(lon), float(h)), v_ned


def _los_ned(t: float) -> np.ndarray:
    """pymap3d's direction to the target in the vehicle's NED at t (geodetic2ned)."""
    llh, _ = _vehicle(t)
    d = np.array(pm.geodetic2ned(*TARGET_DEG, math.degrees(llh[0]), math.degrees(llh[1]), llh[2]))
    return d / np.linalg.norm(d)


def _rate_ned(t: float, h: float = 1e-3) -> np.ndarray:
    """The direction's rate relative to the earth [rad/s] in the vehicle's NED at t: u × du/dt
    with u the earth-fixed (ECEF, pymap3d geodetic2ecef) direction, du/dt by central
    differences, rotated into NED by pymap3d's ecef2nedv."""
    def u_ecef(tt: float) -> np.ndarray:
        llh, _ = _vehicle(tt)
        d = np.subtract(pm.geodetic2ecef(*TARGET_DEG), pm.geodetic2ecef(math.degrees(llh[0]),
                                                                        math.degrees(llh[1]), llh[2]))
        return d / np.linalg.norm(d)

    u, du = u_ecef(t), (u_ecef(t + h) - u_ecef(t - h)) / (2.0 * h)
    llh, _ = _vehicle(t)
    return np.array(pm.ecef2nedv(*np.cross(u, du), math.degrees(llh[0]), math.degrees(llh[1])))


def _C_nm_along(u: np.ndarray, roll: float = 0.2) -> np.ndarray:
    az, el = math.atan2(u[1], u[0]), math.atan2(-u[2], math.hypot(u[0], u[1]))
    return Rotation.from_euler("ZYX", [az, el, roll]).as_matrix()


def _angle(a: np.ndarray, b: np.ndarray) -> float:
    return math.atan2(np.linalg.norm(np.cross(a, b)), a @ b)


def _pointer(**kw) -> GeoPointer:
    start, _ = _vehicle(0.0)
    return GeoPointer(GeoPointerParams(TARGET, start, **kw))


def test_the_aim_is_pymap3d_direction_and_the_feed_forward_its_rate_at_each_step_of_a_pass():
    pointer = _pointer(earth_rate=False, max_rate_rad_s=1.0)
    worst_dir, worst_rate, peak_rate = 0.0, 0.0, 0.0
    for t in np.arange(0.0, 60.5, 1.0):  # closest approach (400 m) at 30 s
        llh, v_n = _vehicle(t)
        assert pointer.set_vehicle(llh, v_n)
        u = _los_ned(t)
        C_nm = _C_nm_along(u)  # on target: the command is the feed-forward alone
        out = pointer.step(Rotation.from_matrix(C_nm).as_quat(), np.eye(3), 0.0)
        worst_dir = max(worst_dir, _angle(out.los_n, u))
        w_ref = C_nm.T @ _rate_ned(t)
        worst_rate = max(worst_rate, float(np.max(np.abs(np.subtract(out.command, w_ref[1:])))))
        peak_rate = max(peak_rate, float(np.linalg.norm(w_ref[1:])))
    assert worst_dir < 1e-9
    assert peak_rate == pytest.approx(20.0 / 400.0, rel=0.01)  # v/R at the closest approach
    assert worst_rate < 1e-8  # the central difference's own error is ~1e-10 rad/s here


def test_the_earth_rate_is_taken_at_the_vehicles_latitude():
    from gimbal_kinematics.maths.earth import earth_rate_n
    from gimbal_kinematics.maths.geo_pointing import los_to_target

    pointer = _pointer()
    south = pm.enu2geodetic(0.0, -3000.0, 0.0, *ORIGIN)  # 3 km south of the road
    llh = (math.radians(south[0]), math.radians(south[1]), float(south[2]))
    assert pointer.set_vehicle(llh)  # no velocity given: the vehicle's (zero) one stays
    ff = pointer.feed_forward_n(los_to_target(llh, TARGET))
    assert ff == pytest.approx(earth_rate_n(llh[0]), abs=1e-15)
    assert np.max(np.abs(earth_rate_n(llh[0]) - earth_rate_n(_vehicle(0.0)[0][0]))) > 1e-12  # it tells them apart


def _closed_loop(velocity: bool, k: float, dt: float, t0: float = 15.0, seconds: float = 30.0):
    """An ideal rate loop (the sight turns at the commanded inertial rate) on the pass, NED
    turning under it at the transport rate (earth rate off on both sides); the pointing
    error against pymap3d each 0.1 s."""
    pointer = _pointer(gain_1_s=k, earth_rate=False, max_rate_rad_s=1.0)
    C_nm = _C_nm_along(_los_ned(t0))
    errors = []
    for i in range(int(round(seconds / dt))):
        t = t0 + i * dt
        llh, v_n = _vehicle(t)
        assert pointer.set_vehicle(llh, v_n if velocity else np.zeros(3))
        out = pointer.step(Rotation.from_matrix(C_nm).as_quat(), np.eye(3), 0.0)
        if i % 5 == 0:
            errors.append((t, _angle(C_nm[:, 0], _los_ned(t))))
        w_n = transport_rate_n(llh[0], llh[2], v_n)
        C_nm = (Rotation.from_rotvec(-w_n * dt).as_matrix() @ C_nm
                @ Rotation.from_rotvec(np.array([0.0, *out.command]) * dt).as_matrix())
    return np.array(errors)


def test_with_the_velocity_fed_forward_the_loop_holds_the_target_without_it_lags_by_rate_over_k():
    k, dt, v, d = 2.0, 0.02, 20.0, 400.0
    with_ff, without = _closed_loop(True, k, dt), _closed_loop(False, k, dt)
    at_30 = int(np.argmin(np.abs(without[:, 0] - 30.0)))
    lag = (v / d) / k  # type-1 loop: steady error = LOS rate / k (the rate peaks here: no rate change)
    assert without[at_30, 1] == pytest.approx(lag, rel=0.03)
    # with it, what is left is the command held over a step while the rate changes: the
    # error ω̇·dt/(2k), largest where the pass's rate v·d/(d² + x²) changes fastest (x = d/√3:
    # ω̇ = 3√3/8 · v²/d² = 0.6495 v²/d²)
    hold = 0.6495 * (v / d) ** 2 * dt / (2.0 * k)
    assert np.max(with_ff[:, 1]) == pytest.approx(hold, rel=0.1)


def test_a_bad_fix_is_counted_and_the_old_position_kept():
    pointer = _pointer()
    start = pointer.vehicle_llh
    for bad in ((math.nan, 0.0, 0.0), TARGET, (math.radians(95.0), 0.0, 0.0)):
        assert not pointer.set_vehicle(bad)
    assert not pointer.set_vehicle(start, (math.inf, 0.0, 0.0))
    assert pointer.counts["rejected_fixes"] == 4 and pointer.vehicle_llh == start
    assert pointer.fix_error(TARGET) is not None and pointer.fix_error(start) is None
