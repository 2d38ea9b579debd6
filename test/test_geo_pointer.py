"""geo_pointer's core (geo-pointing): the command against closed forms, a pointing
loop integrated here with scipy rotations, pymap3d's direction, limits and bad targets."""
import math

import numpy as np
import pymap3d as pm
import pytest
from scipy.spatial.transform import Rotation

from gimbal_control.geo_pointer import GeoPointer, GeoPointerParams
from gimbal_control.geo_pointer_params import PARAMS
from gimbal_kinematics.maths.earth import earth_rate_n
from gimbal_kinematics.maths.geo_pointing import GimbalLimits
from gimbal_kinematics.params.table import ParameterError, defaults

D = math.radians
VEHICLE = (D(39.9), D(32.8), 900.0)
TARGET = (D(39.913504), D(32.829234), 1050.7)  # 2.9 km, azimuth 59 deg, elevation 2.9 deg


def _los_ned_pymap3d(vehicle, target) -> np.ndarray:
    az, el, _ = pm.geodetic2aer(math.degrees(target[0]), math.degrees(target[1]), target[2],
                                math.degrees(vehicle[0]), math.degrees(vehicle[1]), vehicle[2])
    az, el = math.radians(az), math.radians(el)
    return np.array([math.cos(el) * math.cos(az), math.cos(el) * math.sin(az), -math.sin(el)])


def _C_nm_along(u: np.ndarray, roll: float = 0.3) -> np.ndarray:
    """A sight frame whose x axis is ``u`` (NED), rolled about it by ``roll``."""
    az, el = math.atan2(u[1], u[0]), math.atan2(-u[2], math.hypot(u[0], u[1]))
    return Rotation.from_euler("ZYX", [az, el, roll]).as_matrix()


def _run_loop(pointer: GeoPointer, C_nm: np.ndarray, C_nb, seconds: float, dt: float = 0.01,
              w_in_n: np.ndarray | None = None) -> tuple[np.ndarray, list]:
    """The rate loop ideal: the sight turns at exactly the commanded inertial rate (0, q, r)
    in m while NED turns at ``w_in_n`` under it: C_nm(t+dt) = exp(−[w dt]) C_nm exp([ω_m dt]).
    ``C_nb``: the INS attitude, fixed, or a function of the step's time t = i dt."""
    w = np.zeros(3) if w_in_n is None else w_in_n
    outs = []
    for i in range(int(round(seconds / dt))):
        out = pointer.step(Rotation.from_matrix(C_nm).as_quat(), C_nb(i * dt) if callable(C_nb) else C_nb, 0.0)
        outs.append(out)
        w_m = np.array([0.0, *out.command])
        C_nm = Rotation.from_rotvec(-w * dt).as_matrix() @ C_nm @ Rotation.from_rotvec(w_m * dt).as_matrix()
    return C_nm, outs


def _angle(a: np.ndarray, b: np.ndarray) -> float:
    return math.atan2(np.linalg.norm(np.cross(a, b)), a @ b)


def test_direction_to_the_target_is_pymap3d_and_on_target_the_command_is_the_earth_rate():
    pointer = GeoPointer(GeoPointerParams(TARGET, VEHICLE))
    u_ref = _los_ned_pymap3d(VEHICLE, TARGET)
    C_nm = _C_nm_along(u_ref)
    out = pointer.step(Rotation.from_matrix(C_nm).as_quat(), np.eye(3), 0.0)
    assert _angle(out.los_n, u_ref) < 1e-9
    assert max(map(abs, out.error)) < 1e-9
    w_m = C_nm.T @ earth_rate_n(VEHICLE[0])  # the target is fixed to the earth: its inertial rate
    assert out.command == pytest.approx(tuple(w_m[1:]), abs=1e-12)


def test_the_loop_acquires_the_target_and_holds_it_on_the_turning_earth():
    pointer = GeoPointer(GeoPointerParams(TARGET, VEHICLE, gain_1_s=2.0))
    u = _los_ned_pymap3d(VEHICLE, TARGET)
    C0 = Rotation.from_euler("ZY", [0.05, -0.03]).as_matrix() @ _C_nm_along(u)  # ~3 deg off
    C_end, outs = _run_loop(pointer, C0, np.eye(3), 12.0, w_in_n=earth_rate_n(VEHICLE[0]))
    assert _angle(C_end[:, 0], u) < 1e-7  # e^(-24) of 58 mrad, and no earth-rate lag
    assert outs[0].budget.range_m == pytest.approx(2919.324, abs=1e-3)


def test_without_the_earth_rate_feed_forward_the_los_lags_by_the_closed_form():
    k = 2.0
    pointer = GeoPointer(GeoPointerParams(TARGET, VEHICLE, gain_1_s=k, earth_rate=False))
    u = _los_ned_pymap3d(VEHICLE, TARGET)
    w = earth_rate_n(VEHICLE[0])
    C_end, _ = _run_loop(pointer, _C_nm_along(u), np.eye(3), 15.0, w_in_n=w)
    lag = np.linalg.norm(np.cross(u, w)) / k  # type-1 loop, ramp input: steady error rate / k
    assert _angle(C_end[:, 0], u) == pytest.approx(lag, rel=0.02)


def test_at_the_elevation_limit_it_stops_there_and_counts():
    high = pm.aer2geodetic(30.0, 75.0, 3000.0, 39.9, 32.8, 900.0)  # a target 75 deg up
    target = (D(high[0]), D(high[1]), high[2])
    limits = GimbalLimits(elevation_max_rad=D(60.0))
    pointer = GeoPointer(GeoPointerParams(target, VEHICLE, gain_1_s=2.0, limits=limits))
    C_end, outs = _run_loop(pointer, _C_nm_along(_los_ned_pymap3d(VEHICLE, TARGET)), np.eye(3), 22.0, 0.02,
                            earth_rate_n(VEHICLE[0]))
    assert pointer.counts["elevation_limited_steps"] == len(outs)
    el = math.atan2(-C_end[2, 0], math.hypot(C_end[0, 0], C_end[1, 0]))
    assert el == pytest.approx(D(60.0), abs=1e-6)
    assert outs[-1].solution.residual_rad == pytest.approx(D(15.0), abs=1e-6)


def _heading_deg(t: float) -> float:
    """A vehicle that turns away from the target and back: 50 deg, from 1 s down at 3 deg/s
    to -10 deg at 21 s, held, from 31 s back up at 3 deg/s to 50 deg at 51 s, held."""
    return 50.0 - 3.0 * (min(t, 21.0) - min(t, 1.0)) + 3.0 * (min(t, 51.0) - min(t, 31.0))


def test_at_the_azimuth_limit_it_stops_there_counts_and_resumes_inside():
    """The target's bearing relative to the vehicle's heading drives the gimbal azimuth
    (turret at 0) past its +30 deg limit and back. The limited steps are those where
    pymap3d's bearing minus the heading exceeds 30 deg; in the held turn the LOS stops at
    heading + 30 deg at the target's elevation; back inside, it is on the target again."""
    bearing, elevation, _ = pm.geodetic2aer(39.913504, 32.829234, 1050.7, 39.9, 32.8, 900.0)
    dt, limit = 0.02, 30.0
    limits = GimbalLimits(azimuth_min_rad=D(-limit), azimuth_max_rad=D(limit))
    relative = np.array([bearing - _heading_deg(i * dt) for i in range(round(61.0 / dt))])
    assert np.min(np.abs(relative - limit)) > 0.01  # no step near the limit: the expected set is sharp
    expected = np.flatnonzero(relative > limit)
    assert expected[0] == 400 and expected[-1] == 2200 and np.all(np.diff(expected) == 1)  # 8.00 s to 44.00 s

    def C_nb(t: float) -> np.ndarray:
        return Rotation.from_euler("Z", D(_heading_deg(t))).as_matrix()

    u = _los_ned_pymap3d(VEHICLE, TARGET)
    pointer = GeoPointer(GeoPointerParams(TARGET, VEHICLE, gain_1_s=2.0, limits=limits))
    w_e = earth_rate_n(VEHICLE[0])
    C_nm, outs = _run_loop(pointer, _C_nm_along(u), C_nb, 31.0, dt, w_e)  # to the end of the held turn
    stop_az, el = D(_heading_deg(31.0) + limit), D(elevation)
    at_limit = np.array([math.cos(el) * math.cos(stop_az), math.cos(el) * math.sin(stop_az), -math.sin(el)])
    assert _angle(C_nm[:, 0], at_limit) < 1e-7  # stopped at the limit, 10 s after the turn stopped
    excess = D(relative[len(outs) - 1] - limit)  # the miss: the azimuth excess at the target's elevation
    miss = math.acos(math.cos(el) ** 2 * math.cos(excess) + math.sin(el) ** 2)
    assert outs[-1].solution.residual_rad == pytest.approx(miss, abs=1e-9)
    assert outs[-1].solution.psi_m == pytest.approx(D(limit), abs=1e-12)

    C_nm, rest = _run_loop(pointer, C_nm, lambda t: C_nb(31.0 + t), 30.0, dt, w_e)  # the way back
    outs += rest
    limited = np.flatnonzero([o.solution.azimuth_limited for o in outs])
    assert np.array_equal(limited, expected)
    assert pointer.counts["azimuth_limited_steps"] == len(expected) == 1801
    assert pointer.counts["elevation_limited_steps"] == 0 and pointer.counts["singular_steps"] == 0
    assert _angle(C_nm[:, 0], u) < 1e-7  # back on the target, 17 s after it came inside the limits
    assert outs[-1].solution.psi_m == pytest.approx(D(relative[-1]), abs=1e-9)  # the joints point at it
    assert outs[-1].solution.residual_rad < 1e-12


def _values(**changes):
    v = defaults(PARAMS) | {"target_llh_deg": [39.913504, 32.829234, 1050.7], "vehicle_llh_deg": [39.9, 32.8, 900.0]}
    return v | changes


def test_bad_targets_are_refused_at_startup_naming_the_parameter():
    assert GeoPointerParams.from_values(_values()).target_llh == pytest.approx(TARGET)
    for bad in ([39.9, 32.8, 900.0], [float("nan"), 32.8, 900.0]):
        with pytest.raises(ParameterError, match="target_llh_deg"):
            GeoPointerParams.from_values(_values(target_llh_deg=bad))
    with pytest.raises(ParameterError, match="ins_attitude_sigma_deg"):
        GeoPointerParams.from_values(_values(ins_attitude_sigma_deg=[0.05, 0.05]))
    with pytest.raises(ParameterError, match="target_position_sigma_m"):
        GeoPointerParams.from_values(_values(target_position_sigma_m=[5.0]))


def test_a_bad_new_target_is_counted_and_the_old_one_kept():
    pointer = GeoPointer(GeoPointerParams(TARGET, VEHICLE))
    assert not pointer.set_target(VEHICLE)
    assert not pointer.set_target((float("nan"), 0.0, 0.0))
    assert pointer.counts["rejected_targets"] == 2 and pointer.target_llh == TARGET
    assert pointer.set_target((D(39.95), D(32.9), 1000.0)) and pointer.counts["rejected_targets"] == 2


def test_scenario_cores_with_ideal_sensors_point_within_50_urad_while_driving(tmp_path):
    """sighting_geo_pointing:ideal stepped by the core engine (the graph's torque commands to
    the bit): the true LOS against pymap3d's direction to the target, after the slew; and
    the core engine's geo_pointing figures (its collector) from the same run: the error
    against pymap3d's, the budgets against the core's own."""
    import dataclasses

    from gimbal_kinematics.maths.geo_pointing import radial_quantile
    from gimbal_sim.core.core_loop import run_core_loop
    from gimbal_sim.graph.scenario import load, variant
    from gimbal_sim.reports.core_metrics import GeoPointingCollector

    scenario = dataclasses.replace(variant(load("sighting_geo_pointing"), "ideal"), duration_s=11.0)
    u = _los_ned_pymap3d(VEHICLE, TARGET)
    errors, collector = [], GeoPointingCollector(scenario)

    def observe(bus) -> None:
        collector(bus)
        errors.append((bus.t, _angle(Rotation.from_quat(bus.truth.quat_nm).as_matrix()[:, 0], u)))

    run_core_loop(scenario, observer=observe)
    settled = np.array([e for t, e in errors if t >= 8.0])
    assert math.sqrt(np.mean(settled ** 2)) < 50e-6
    (tmp_path / "scenario.yaml").write_text(scenario.to_yaml())
    fig = collector.metrics(tmp_path)["geo_pointing"]
    after = np.array([e for t, e in errors if t >= 10.0])
    assert fig["error_rms_urad"] == pytest.approx(1e6 * math.sqrt(np.mean(after ** 2)), rel=1e-6)
    budgets = np.array(collector.budget)
    assert len(budgets) == 1101  # one per INS step (100 Hz), the last at 11 s
    r95 = [radial_quantile(a, b) for _, a, b in budgets[-101:]]  # 10.00 s on, each over its 10 steps (11 s: 1)
    assert fig["budget_95_mean_mrad"] == pytest.approx(1e3 * np.average(r95, weights=[10] * 100 + [1]), rel=1e-12)
    assert fig["within_budget_95_fraction"] == 1.0
