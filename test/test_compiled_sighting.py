"""Paper 1's compiled sighting chain: each per-sample kernel against the model class whose
maths it carries (the class fed the same normals, to the bit), the EKF's matrix kernels
against numpy and the model's closed forms, a block of normals against the draws one at a
time, and the compiled engine run against the per-step Python loop (the same commands, to
the bit), for which scenarios it is chosen."""
import dataclasses
import math

import numpy as np
import pytest

from gimbal_control import los_rate_kernels as lk
from gimbal_control.los_rate_controller import LosRateController, LosRateControllerParams
from gimbal_estimators import gyro_bias_ekf_kernels as ek
from gimbal_kinematics.maths import kalman
from gimbal_estimators.gyro_bias_ekf_model import discretize_error_model, roll_rate_matrix
from gimbal_kinematics.maths.rotations import quat_to_dcm
from gimbal_sim.core.compiled import compiled_runner
from gimbal_sim.core.core_loop import node_values, run_core_loop
from gimbal_sim.graph.scenario import load, variant
from gimbal_sim.world.sensors import EncoderModel, EncoderParams, GyroModel, GyroParams, InsModel, InsParams
from gimbal_sim.world.sensors import sensor_kernels as sk
from gimbal_sim.world.sensors._normals import NormalStream
from gimbal_sim.world.sensors.markov import FirstOrderGaussMarkov
from gimbal_kinematics.maths.units import DEG

RNG = np.random.default_rng(20261128)


def test_a_block_of_normals_is_the_draws_one_sample_at_a_time():
    a, b = NormalStream(np.random.default_rng(5)), NormalStream(np.random.default_rng(5))
    a.take(2)
    b.take(2)
    block = a.take_block(7, 1500)  # crosses two 4096 refills, each dropping its tail
    one = np.array([[buf[j + i] for i in range(7)] for buf, j in (b.take(7) for _ in range(1500))])
    assert np.array_equal(block, one)
    assert a.one() == b.one()


def test_the_ins_attitude_kernel_is_the_first_order_gauss_markov_class_to_the_bit():
    """The INS model steps its errors through the kernel; the Gauss-Markov model's errors are
    :class:`FirstOrderGaussMarkov`'s (the pure-Python class) on the same stream, to the bit."""
    model = InsModel(InsParams(attitude_tau_s=0.5), np.random.default_rng(4), 0.01)
    rp = InsParams().roll_pitch_rms_deg * DEG
    gm = FirstOrderGaussMarkov((rp, rp, InsParams().heading_rms_deg * DEG), 0.5,
                               np.random.default_rng(4).spawn(2)[0], 0.01)
    for _ in range(300):
        true = (0.1, -0.2, math.pi * (1.0 - 2.0 * RNG.random()))
        e = gm.step()
        expected = (true[0] + e[0], true[1] + e[1], sk.wrap_pi(true[2] + e[2]))
        assert tuple(model.step(true, (0.0, 0.0, 0.0))[0]) == expected


@pytest.mark.parametrize("anti_windup", ["clamp", "conditional", "none"])
def test_the_controller_kernel_is_its_source_run_as_python_to_the_bit(anti_windup):
    """The controller (which calls the compiled kernel on its state) against the kernel's
    source interpreted, on a copy of that state; the counters as the class reports them."""
    params = LosRateControllerParams(anti_windup=anti_windup, feedback=True, omega_n_hz=25.0)
    core, twin = LosRateController(params), LosRateController(params)
    s, g = lk.controller_arrays(twin)
    core.set_bias_estimate(0.0, (0.0, 1e-4, -2e-4))
    s[lk.S_BIAS_Q], s[lk.S_BIAS_R] = 1e-4, -2e-4
    t = 0.0
    for k in range(2000):
        t += 1e-3 if k % 97 else 0.05  # gaps (stamps come ordered: the input policy's)
        x = tuple(RNG.normal(0.0, 0.002 if k % 400 else 30.0, 13))  # every 400th saturates
        if k % 301 == 0:
            x = (math.nan,) + x[1:]
        args = (t, *x[:11], x[11] * 0.01, x[12] * 0.01)
        expect = core.step(t, x[0:2], x[2:5], x[5:8], x[8:11], (args[12], args[13]))
        assert lk.los_rate_step.py_func(s, g, *args) == expect
    counts = (core.rejected_inputs, core.saturated_steps)
    assert (s[lk.S_REJECTED_INPUTS], s[lk.S_SATURATED]) == counts
    assert all(c > 0 for c in counts) and core.saturated_steps < 1900, counts


def _spd(n):
    a = RNG.normal(size=(n, n))
    return a @ a.T + n * np.eye(n)


@pytest.mark.parametrize("n", [6, 9])
def test_the_ekf_kernels_are_the_filter_maths(n):
    q = RNG.normal(size=4)
    q /= np.linalg.norm(q)
    theta = 0.3
    A = ek.a_matrix(tuple(q), math.cos(theta), math.sin(theta))
    np.testing.assert_allclose(A, quat_to_dcm(q) @ roll_rate_matrix(theta), rtol=1e-13, atol=1e-15)
    P, w = _spd(n) * 1e-6, np.array([1e-5, -3e-5, 7e-5])
    n_psd, qb_psd, pe_var = np.array([1e-8, 2e-8, 3e-8]), np.array([1e-12, 2e-12, 3e-12]), np.array([1e-6, 1e-6, 4e-6])
    F, Q = discretize_error_model(A, 0.01, w, n_psd, qb_psd, pe_var if n == 9 else None, 300.0)
    P1, f_e = ek.propagate(P, A, 0.01, w, n_psd, qb_psd, pe_var, 300.0)
    np.testing.assert_allclose(P1, kalman.symmetrize(F @ P @ F.T + Q), rtol=1e-12, atol=1e-20)
    assert f_e == (F[6, 6] if n == 9 else 1.0)
    H, R, x, z = RNG.normal(size=(3, n)), _spd(3) * 1e-6, RNG.normal(size=n) * 1e-3, RNG.normal(size=3) * 1e-3
    ok, x1, P2, y, d2 = ek.joseph_update3(x, P, z, H, R, 1e9)
    up = kalman.joseph_update(x, P, z, H, R, 1e9)
    assert ok and up.accepted
    np.testing.assert_allclose(x1, up.x, rtol=1e-11, atol=1e-18)
    np.testing.assert_allclose(P2, up.P, rtol=1e-10, atol=1e-20)
    assert d2 == pytest.approx(up.d2, rel=1e-12)
    rejected = ek.joseph_update3(x, P, z, H, R, 0.1 * d2)
    assert not rejected[0] and np.array_equal(rejected[1], x) and np.array_equal(rejected[2], P)


def _short(name, v="", duration_s=0.35):
    s = variant(load(name), v) if v else load(name)
    return dataclasses.replace(s, duration_s=duration_s)


SCALE_ERRORS = {"gimbal_gyro_scale_factor_ppm": [3000.0, -2000.0], "gimbal_gyro_scale_asymmetry_sigma_ppm": 500.0,
                "gimbal_gyro_misalignment_urad": [800.0, -300.0], "ins_gyro_scale_factor_sigma_ppm": 300.0,
                "ins_gyro_misalignment_sigma_urad": 200.0, "ins_gyro_scale_asymmetry_ppm": [50.0]}


@pytest.mark.parametrize("name,v,errors", [("sighting_land_vehicle", "ekf_on", False), ("los_stabilization", "", False),
                                           ("sighting_land_vehicle", "ekf_on", True)])
def test_the_compiled_run_gives_the_python_loops_commands_to_the_bit(name, v, errors):
    # errors: the gyros' scale factors, asymmetries and misalignments, given and drawn
    scenario = _short(name, v)
    if errors:
        scenario.nodes["sensor_models"]["params"].update(SCALE_ERRORS)
    python = run_core_loop(scenario, keep_commands=True, compiled=False)
    fast = run_core_loop(scenario, keep_commands=True)
    assert fast.steps == python.steps == 350
    assert fast.commands == python.commands
    assert any(c != (0.0, 0.0) for c in fast.commands)


def test_the_compiled_runner_takes_the_sighting_chain_only():
    assert compiled_runner(node_values(_short("sim_open_loop"))) is not None
    assert compiled_runner(node_values(_short("sighting_operator"))) is None  # an operator node: per-step Python
    ins_slow = dataclasses.replace(_short("sighting_land_vehicle"))
    ins_slow.nodes["sensor_models"]["params"]["ins_rate_hz"] = 10.0  # gyro waits 99 ms > the EKF's 50 ms
    assert compiled_runner(node_values(ins_slow)) is None
