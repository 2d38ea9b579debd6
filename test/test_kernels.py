"""The compiled per-sample kernels: each compiled kernel against its own source run as plain
Python (numba's ``py_func``: the same arithmetic, interpreted), so compiled results differ
in the last bits at most; the geometry kernels against scipy's rotations; the vehicle core
stepping all four platform axes in one kernel call against each axis stepped alone; the
remainder kernel against ``math.remainder``; the PID kernel's state vector against the
``Pid`` object that holds it."""
import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from gimbal_control import control_kernels as ck
from gimbal_control.pid import Pid, PidParams
from gimbal_estimators import navigator_kernels as nk
from gimbal_kinematics.gimbal import gimbal_kernels as gk, host_kernels as hk
from gimbal_kinematics.gimbal.gimbal_dynamics import TwoAxisGimbal
from gimbal_kinematics.maths import four_gimbal, platform_kernels as fk
from gimbal_sim.world.plant import make_profile, platform_kernels as pk, profile_kernels as prk
from gimbal_sim.world.plant.platform_loops import PlatformAxis, paper3_axis_params
from gimbal_sim.world.vehicle import VehicleConfig, VehicleCore

RNG = np.random.default_rng(20261128)


def close(a, b, rel=4e-16, abs_=1e-300):
    """Every float of two (nested) tuples/arrays equal to within a few ulps."""
    fa = np.asarray(np.hstack([np.ravel(np.asarray(v, dtype=float)) for v in _flat(a)]))
    fb = np.asarray(np.hstack([np.ravel(np.asarray(v, dtype=float)) for v in _flat(b)]))
    assert fa.shape == fb.shape
    np.testing.assert_allclose(fa, fb, rtol=rel * 8, atol=abs_)


def _flat(x):
    if isinstance(x, (tuple, list)):
        for v in x:
            yield from _flat(v)
    else:
        yield x


def test_platform_axis_kernels_match_their_python_source():
    p = PlatformAxis(paper3_axis_params("q")).kernel_params
    for _ in range(20):
        th, w, i, v = RNG.normal(size=4) * (0.3, 2.0, 0.5, 20.0)
        wa, td = tuple(RNG.normal(size=3) * 0.1), tuple(RNG.normal(size=3) * 0.01)
        for sub in (1, 4):
            close(pk.axis_rk4(th, w, i, v, wa, td, 1e-3, sub, p), pk.axis_rk4.py_func(th, w, i, v, wa, td, 1e-3, sub, p))
        close(pk.axis_quasi_static(th, w, v, wa[0], td[0], 0.2, p),
              pk.axis_quasi_static.py_func(th, w, v, wa[0], td[0], 0.2, p))


def test_vehicle_core_steps_the_four_axes_as_each_axis_alone():
    core = VehicleCore(VehicleConfig(profile="static", plant="four_gimbal_platform", duration_s=1.0,
                                     initial_joints_deg=(10.0, 0.5, -0.3, 0.2)))
    axes = [PlatformAxis(paper3_axis_params(a)) for a in "aqpr"]
    x = [(math.radians(d), 0.0, 0.0) for d in (10.0, 0.5, -0.3, 0.2)]
    for k in range(50):
        volts = tuple(RNG.normal(size=4) * 30.0)  # some beyond the 27 V limit
        core.step(volts)
        x = [ax.step(xi, v, core.config.dt, substeps=core.config.platform_substeps) for ax, xi, v in zip(axes, x, volts)]
    truth = core.truth()
    assert truth.joint_position == tuple(xi[0] for xi in x)
    assert truth.joint_velocity == tuple(xi[1] for xi in x)


def test_gimbal_kernels_match_their_python_source():
    p = TwoAxisGimbal().kernel_params
    for _ in range(20):
        x = tuple(RNG.normal(size=4) * (1.0, 0.5, 1.0, 1.0))
        bases = [tuple(RNG.normal(size=9)) for _ in range(3)]
        ta, te = RNG.normal(size=2) * 5.0
        close(gk.rk4_step(x, ta, te, *bases, 1e-3, p), gk.rk4_step.py_func(x, ta, te, *bases, 1e-3, p))
        close(gk.inverse_dynamics(*x, ta, te, bases[0], p), gk.inverse_dynamics.py_func(*x, ta, te, bases[0], p))


def test_profile_sample_matches_its_python_source_and_differentiates():
    profile = make_profile("paper1_land_vehicle")
    lines, terms, starts = profile._packed
    for t in RNG.uniform(0.0, 100.0, size=10):
        close(prk.sample(lines, terms, starts, t), prk.sample.py_func(lines, terms, starts, t))
        # roll rate and yaw acceleration against central differences of the sample
        h = 1e-6  # truncation A ω³ h²/6 of the 258 rad/s mode: ~1e-9
        a, b = profile.sample(t - h), profile.sample(t + h)
        s = profile.sample(t)
        assert s.roll_dot == pytest.approx((b.roll - a.roll) / (2 * h), rel=1e-5, abs=1e-8)
        assert s.yaw_ddot == pytest.approx((b.yaw_dot - a.yaw_dot) / (2 * h), rel=1e-5, abs=1e-7)
    args = tuple(RNG.normal(size=16))
    close(hk.host_fields(*args), hk.host_fields.py_func(*args))


def test_platform_truth_against_scipy_and_the_numpy_closed_forms():
    for _ in range(30):
        euler = RNG.uniform(-3.0, 3.0, size=3) * (1.0, 0.45, 1.0)
        angles = RNG.uniform(-3.0, 3.0, size=4) * (1.0, 0.3, 0.3, 0.3)
        rates, omega_b, f_b = RNG.normal(size=4), RNG.normal(size=3), RNG.normal(size=3) * 9.8
        q, w, f = fk.platform_truth(euler, angles, rates, omega_b, f_b)
        C_nb = Rotation.from_euler("ZYX", euler[::-1]).as_matrix()
        C_sb = four_gimbal.dcm_sb(angles)
        ref = Rotation.from_matrix(C_nb @ C_sb.T).as_quat()
        ref = -ref if ref[3] < 0 else ref
        np.testing.assert_allclose(q, ref, atol=2e-15)
        np.testing.assert_allclose(w, four_gimbal.platform_rate_s(omega_b, angles, rates), rtol=1e-14, atol=1e-15)
        np.testing.assert_allclose(f, C_sb @ f_b, rtol=1e-14, atol=1e-13)


@pytest.mark.parametrize("branch", range(4))
def test_shepperd_quaternion_every_branch_against_scipy(branch):
    """A rotation by ~π about x, y or z (or a small one) selects each of the four branches."""
    axis = [(0.0, 0.0, 1.0), (1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)][branch]
    angle = 0.3 if branch == 0 else 3.0
    r = Rotation.from_rotvec(np.array(axis) * angle) * Rotation.from_rotvec(RNG.normal(size=3) * 0.05)
    q = fk.dcm_to_quat(r.as_matrix())
    ref = r.as_quat()
    np.testing.assert_allclose(q, -ref if ref[3] < 0 else ref, atol=2e-15)


def test_pid_kernel_state_is_the_objects():
    params = PidParams(kp=2.0, ki=5.0, kd=0.3, derivative_tau_s=0.01, output_limit=1.5, integrator_limit=1.0)
    state = np.zeros((2, ck.N_STATE))
    pid = Pid(params, state[1])
    ref = state[1].copy()
    for k in range(200):
        e, r = math.sin(0.05 * k), math.cos(0.05 * k)
        u = pid.step(e, 1e-3, error_rate=r if k % 3 else None)
        u_ref = ck.pid_step.py_func(ref, pid.gains, e, 1e-3, r if k % 3 else 0.0, bool(k % 3))
        assert u == u_ref
    np.testing.assert_array_equal(state[1], ref)
    assert not state[0].any()
    assert pid.output == ref[ck.S_OUTPUT] and pid.integral == ref[ck.S_INTEGRAL]


def test_navigator_kernels_match_their_python_source_and_the_remainder():
    for _ in range(20):
        args = (0.7, 0.1, 50.0, *RNG.normal(size=3), 1e-3, 0.2, *RNG.normal(size=3) * 0.01, 3e-3, 3e-5, 1e-8, 45.0)
        close(nk.integrate(*args), nk.integrate.py_func(*args))
    values = np.concatenate([RNG.uniform(-40.0, 40.0, size=200), np.array([math.pi, -math.pi, 3 * math.pi, 0.0])])
    for v in values:
        assert nk._remainder_tau(v) == pytest.approx(math.remainder(v, math.tau), abs=4e-15)
    small = RNG.uniform(-3.0, 3.0, size=50)
    assert all(nk._remainder_tau(v) == v for v in small)  # inside (−π, π]: unchanged, bit for bit


def test_fused_gimbal_step_is_the_separate_kernels_and_turret_base_its_source():
    """GimbalSimulator's one-call step equals sampling the host, building the bases and the
    RK4 step separately; the turret-base kernel equals its own source interpreted."""
    from gimbal_sim.world.plant.gimbal_simulator import GimbalSimulator
    from gimbal_kinematics.gimbal.turret_base import turret_base_from_host
    sim = GimbalSimulator(make_profile("paper1_land_vehicle"), 1e-3, x0=(0.1, -0.05, 0.0, 0.0))
    x, t, dt = sim.x, sim.t, sim.dt
    for k in range(30):
        tau = tuple(RNG.normal(size=2) * 20.0)
        base0 = sim.base
        x1 = sim.step(tau)
        env = sim.env
        mid = turret_base_from_host(sim.profile.sample(t + 0.5 * dt), env.gravity_m_s2, env.omega_in_n)
        end = turret_base_from_host(sim.profile.sample((k + 1) * dt), env.gravity_m_s2, env.omega_in_n)
        assert x1 == sim.dynamics.step(x, tau, base0, mid, end, dt)
        assert sim.base == end
        x, t = x1, sim.t
    host = tuple(sim.host)
    close(hk.turret_base(host, 9.8, 1e-5, 2e-5, -3e-5), hk.turret_base.py_func(host, 9.8, 1e-5, 2e-5, -3e-5))


def test_a_constant_host_keeps_its_delta_angle_the_earth_rate_over_a_step():
    """On a static base every step's δ is the same: the earth's rotation over dt resolved in b,
    C_bn ω_ie^n dt (here from scipy's Euler angles), to rounding."""
    core = VehicleCore(VehicleConfig(profile="static", plant="four_gimbal_platform", duration_s=1.0,
                                     profile_params={"lat_deg": 40.0, "roll_deg": 1.0, "pitch_deg": -2.0, "yaw_deg": 30.0}))
    assert core.profile.constant and not make_profile("paper1_land_vehicle").constant
    deltas = []
    for _ in range(4):
        core.step((0.0, 0.0, 0.0, 0.0))
        deltas.append(tuple(core.truth().delta_angle_b))
    assert deltas[1:] == deltas[:-1]
    C_nb = Rotation.from_euler("ZYX", np.radians([30.0, -2.0, 1.0])).as_matrix()
    expected = C_nb.T @ np.asarray(core.env.omega_in_n) * core.config.dt
    np.testing.assert_allclose(deltas[-1], expected, rtol=1e-9, atol=1e-22)


def test_a_moving_hosts_rows_and_base_torques_are_the_vehicle_cores_to_the_bit():
    """Paper 5's ship with the base motion on (what the compiled platform chain computes per
    block and per step): the host's rows (Euler angles, ω_ib^b, f_b) are ``VehicleCore.truth``'s
    and ``base_torques`` gives the torques ``VehicleCore`` steps the plant under, float for
    float, compiled and interpreted, over 300 steps of driven loops."""
    vehicle = VehicleCore(VehicleConfig(profile="paper5_ship", profile_params={"lat_deg": 40.0},
                                        plant="four_gimbal_platform", platform_base_motion=True))
    env = (*(float(v) for v in vehicle.env.omega_in_n), float(vehicle.env.gravity_m_s2))
    rows, src = np.empty((300, 9)), np.empty((300, 9))
    prk.host_truth_rows(*vehicle.profile.packed, 0, 300, vehicle.config.dt, *env, rows)
    prk.host_truth_rows.py_func(*vehicle.profile.packed, 0, 300, vehicle.config.dt, *env, src)
    assert np.array_equal(rows, src)
    last, last_src, out, out_src = np.zeros(5), np.zeros(5), np.zeros(4), np.zeros(4)
    stepped = []
    core_torques = VehicleCore._base_torques
    vehicle._base_torques = lambda: stepped.append(core_torques(vehicle)) or stepped[-1]
    for k in range(300):
        tr = vehicle.truth()
        assert rows[k].tolist() == [*tr.euler, *tr.omega_ib_b, *tr.specific_force_b], k
        x = vehicle._platform_x.copy()
        pk.base_torques(*rows[k, 3:6], x, last, vehicle._platform_params, vehicle.config.dt, out)
        pk.base_torques.py_func(*rows[k, 3:6], x, last_src, vehicle._platform_params, vehicle.config.dt, out_src)
        vehicle.step(tuple(2.0 * math.sin(0.05 * k + j) for j in range(4)))
        assert out.tolist() == out_src.tolist() == list(stepped[-1]), k
    assert any(abs(t) > 1e-6 for t in stepped[-1])  # the ship torques the gimbals
