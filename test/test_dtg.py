"""Paper 3's dynamically tuned gyros and the servo closed on their pickoffs, against closed
forms, scipy's rotations and scipy.signal's responses of the designed loops."""
import math

import numpy as np
import pytest
from scipy import signal
from scipy.spatial.transform import Rotation

from gimbal_control import control_kernels as ck
from gimbal_control.platform_loop_design import closed_loop, design_all, place
from gimbal_kinematics.maths import dtg
from gimbal_kinematics.maths.units import DEG, DEG_H
from gimbal_kinematics.maths.wgs84 import OMEGA_IE
from gimbal_sim.world.plant.platform_loops import PlatformAxis, paper3_axis_params
from gimbal_sim.world.sensors.dtg import DtgPair, DtgPairParams


@pytest.mark.parametrize("axis, error_ppm", [(0, 0.0), (1, 0.0), (0, 250.0), (1, -80.0)])
def test_constant_current_precesses_at_scale_factor_times_current(axis, error_ppm):
    gyro = dtg.DtgParams.from_units(72.0, scale_error_ppm=(error_ppm, error_ppm))
    current = 0.06 if axis == 0 else -0.045
    currents = (current, 0.0) if axis == 0 else (0.0, current)
    h, dt, n = (0.0, 0.0, 1.0), 1e-3, 2000
    for _ in range(n):
        h = dtg.step_spin_axis(gyro, h, (0.0, 0.0, 0.0), currents, (0.0, 0.0, -9.8), dt)
    expected = 72.0 * DEG_H * 1000.0 * (1.0 + error_ppm * 1e-6) * current * n * dt
    got = dtg.pickoff(h)[axis]
    assert got == pytest.approx(expected, rel=1e-6)
    assert dtg.pickoff(h)[1 - axis] == pytest.approx(0.0, abs=1e-15)


def test_case_turning_about_the_spin_axis_turns_the_tilt_as_scipy_rotates_a_fixed_vector():
    gyro = dtg.DtgParams.from_units(72.0)
    h0 = dtg.spin_axis(0.01, -0.004)
    omega = (0.002, -0.001, 0.3)  # case rate in c [rad/s], the rotor free
    h, dt, n = h0, 1e-3, 1500
    for _ in range(n):
        h = dtg.step_spin_axis(gyro, h, omega, (0.0, 0.0), (0.0, 0.0, 0.0), dt)
    # a fixed inertial vector seen from a case turned by exp(ω t): C_ci = exp(ω t)ᵀ
    expected = Rotation.from_rotvec(np.array(omega) * n * dt).inv().apply(h0)
    np.testing.assert_allclose(h, expected, atol=1e-12)


def test_pickoff_inverts_spin_axis_and_reads_a_pure_precession_exactly():
    for tx, ty in [(0.0, 0.0), (0.3, -0.2), (-1.0, 0.5)]:
        assert dtg.pickoff(dtg.spin_axis(tx, ty)) == pytest.approx((tx, ty), abs=1e-14)
    h = dtg.rotate((0.0, 0.0, 1.0), (0.7, 0.0, 0.0), 1.0)
    assert dtg.pickoff(h) == pytest.approx((0.7, 0.0), abs=1e-14)


def test_drift_integrates_into_the_pickoff_and_the_mounting_gives_three_axes():
    pair = DtgPair(DtgPairParams(drift_deg_h=(0.02, -0.01, 0.03, 0.05), drift_sigma_deg_h=0.0, arw_deg_rt_h=0.0),
                   np.random.default_rng(0))
    for _ in range(1000):
        out = pair.step((0.0, 0.0, 0.0), (0.0, 0.0, -9.8), (0.0, 0.0, 0.0), 1e-3)
    np.testing.assert_allclose(out, np.array([0.02, -0.01, 0.03, 0.05]) * DEG_H * 1.0, rtol=1e-9)
    # a platform rate about z_s shows on the upper gyro's y_c only; about x_s on both x pickoffs
    for w, seen in [((0.0, 0.0, 1e-3), (0, 0, 0, 1)), ((1e-3, 0.0, 0.0), (1, 0, 1, 0)), ((0.0, 1e-3, 0.0), (0, 1, 0, 0))]:
        p = DtgPair(DtgPairParams(drift_sigma_deg_h=0.0, arw_deg_rt_h=0.0), np.random.default_rng(0))
        out = np.array(p.step(w, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), 1.0))
        np.testing.assert_allclose(out != 0.0, np.array(seen, dtype=bool))
        assert np.all(out[np.array(seen, dtype=bool)] == pytest.approx(-1e-3, rel=1e-6))


def test_seeded_pair_is_reproducible_and_the_random_walk_has_its_density():
    params = DtgPairParams(drift_sigma_deg_h=0.0, arw_deg_rt_h=0.003)
    runs = []
    for _ in range(2):
        p = DtgPair(params, np.random.default_rng([7, 3]))
        runs.append([p.step((0.0,) * 3, (0.0,) * 3, (0.0,) * 3, 1e-2) for _ in range(400)])
    assert runs[0] == runs[1]
    ends = np.array([DtgPair(params, np.random.default_rng(s)).step((0.0,) * 3, (0.0,) * 3, (0.0,) * 3, 100.0)
                     for s in range(400)])
    sigma = 0.003 * DEG / 60.0 * math.sqrt(100.0)
    assert np.std(ends) == pytest.approx(sigma, rel=0.1)  # 1600 samples: σ within ~3.5 % (1σ)


def test_discrete_design_places_the_triple_pole_at_the_control_rate():
    for d in design_all(1000.0):
        zp = math.exp(-2.0 * math.pi * d.bandwidth_hz / 1000.0)
        poles = closed_loop(d).poles
        assert np.sum(np.abs(poles - zp) < 1e-3) == 3
        assert np.all(np.abs(poles) < 1.0)
        assert d.phase_margin_deg > 30.0 and d.gain_margin_db > 6.0


def test_pid_kernel_on_the_motor_plant_steps_as_scipy_says():
    """The PID kernel (differenced derivative) on the RK4 DC-motor axis (friction off),
    against scipy.signal.dstep of the designed closed loop."""
    d = place("a", 12.0, 1000.0)
    axis = PlatformAxis(paper3_axis_params("a", coulomb_friction_nm=0.0))
    g = np.array([d.pid.kp, d.pid.ki, d.pid.kd, d.pid.derivative_tau_s, d.pid.output_limit, d.pid.integrator_limit])
    s = np.zeros(ck.N_STATE)
    s[ck.S_FIRST] = 1.0
    x, n, ref = (0.0, 0.0, 0.0), 400, 1e-3  # 1 mrad step: the 27 V limit stays far
    theta = []
    for _ in range(n):
        theta.append(x[0])
        u = ck.pid_step(s, g, ref - x[0], 1e-3, 0.0, False)
        x = axis.step(x, u, 1e-3, substeps=8)
    _, (y,) = signal.dstep(closed_loop(d), n=n)
    np.testing.assert_allclose(np.array(theta) / ref, y[:, 0], atol=2e-3)
    assert max(y[:, 0]) > 1.0  # the integrator's overshoot: the response is not trivially flat


def test_servo_on_dtgs_torques_the_azimuth_gyro_and_its_scale_error_turns_the_platform_faster():
    """The processor's current is the command over the nominal scale factor, whatever the
    true one; a torquer scale-factor error e on the azimuth gyro turns the platform at
    (1 + e)·1.2 °/s, so the azimuth error θ_a − φz grows at e·1.2 °/s."""
    from gimbal_sim.experiments.dtg_torquer import run_dtg_servo
    error = 0.01
    gyros = DtgPairParams(scale_error_ppm=(0.0, 0.0, 0.0, error * 1e6))
    r = run_dtg_servo(3.0, 2, lat_deg=45.0, gyros=gyros, settle_s=1.0, sample_s=0.1)
    scale = dtg.PAPER_TORQUER_SCALE_DEG_H_MA * dtg.DEG_H_PER_MA
    expected = (1.2 * DEG - OMEGA_IE * math.sin(45.0 * DEG)) / scale  # z_s down: the earth rate is −Ω sin L
    assert r["azimuth_current_mean_abs_ma"] == pytest.approx(expected * 1e3, rel=1e-9)
    t, e = r["series"]["t"], r["series"]["azimuth_error_rad"]
    late = t >= 1.0
    slope = np.polyfit(t[late], e[late], 1)[0]
    assert slope == pytest.approx(error * expected * scale, rel=0.01)
    assert r["steady_max_level_error_arcsec"] < 40.0
