"""The compiled platform chain: its kernels against the models they compile (the modulation
schedule against ``BidirectionalRotation``, the encoder kernel against its source and the
counting closed form, the inertial kernel against its source and the
error model's closed form, the block normals against
the stream's own takes), and the compiled block loop against the Python loop over the same
cores: the same messages, byte for byte, across a modulation reversal, with and without the
IMU's scale-factor, asymmetry and misalignment errors, and with the servo on paper 3's DTG
pair (the pair's kernel against its model, every drift term on); and the engine's
dispatch, which compiles only the chain it reproduces."""
import dataclasses
import math

import numpy as np
import pytest

from gimbal_control import servo_kernels as sk
from gimbal_kinematics.maths.four_gimbal import BidirectionalRotation
from gimbal_sim.core import compiled, compiled_platform
from gimbal_sim.core.core_loop import core_plan, node_values, run_core_loop, run_stages
from gimbal_sim.graph.scenario import apply_set, load, variant
from gimbal_sim.tools.engine_speed import paper_rate_navigation
from gimbal_sim.world.sensors import EncoderModel, EncoderParams, GyroModel, GyroParams
from gimbal_sim.world.sensors._normals import NormalStream
from gimbal_sim.world.sensors import dtg_kernels
from gimbal_sim.world.sensors.dtg import DtgOnPlatform, DtgPair, DtgPairParams
from gimbal_kinematics.maths.earth import earth_rate_n
from gimbal_kinematics.maths.rotations import quat_from_rotation_vector, quat_mul

RNG = np.random.default_rng(20261128)
from gimbal_sim.world.sensors import sensor_kernels as sk_
from gimbal_sim.world.sensors.sensor_kernels import encoder_step, inertial_step


@pytest.mark.parametrize("reversal_s", [0.0, 0.4])
def test_the_schedule_kernel_is_the_bidirectional_rotation(reversal_s):
    sched = BidirectionalRotation(rate_deg_s=1.2, sweep_deg=2.0, reversal_time_s=reversal_s)
    for t in np.linspace(-0.5, 7.0, 1501):
        phi, rate, _ = sched.state(float(t))
        assert sk.schedule_state(float(t), sched.rate_rad_s, math.radians(2.0), sched.leg_duration_s,
                                 0.5 * reversal_s) == (phi, rate)


def test_encoder_kernel_matches_its_source_and_the_counting_closed_form():
    quantum, noise, gate = 2.0 * math.pi / 2 ** 19, math.radians(0.01), 5
    state, src = np.zeros(2 + 8), np.zeros(2 + 8)
    angles, rates, a2, r2 = np.zeros(4), np.zeros(4), np.zeros(4), np.zeros(4)
    rng = np.random.default_rng(3)
    counts = []
    for k in range(40):
        truth = np.array([0.3 + 0.02 * k, -0.1 * k, 1e-6 * k, 2.0])
        z = rng.standard_normal(4)
        encoder_step(state, 4, truth, quantum, noise, gate, gate * 1e-3, z, angles, rates)
        encoder_step.py_func(src, 4, truth, quantum, noise, gate, gate * 1e-3, z, a2, r2)
        assert angles.tolist() == a2.tolist() and rates.tolist() == r2.tolist()
        c = np.floor(truth / quantum + 0.5)  # mid-tread count, then the readout noise
        np.testing.assert_allclose(angles, c * quantum + noise * z, rtol=0, atol=1e-15)
        counts.append(c)
        if k >= gate:  # the count difference over the last completed gate
            last = k - k % gate
            np.testing.assert_allclose(rates, (counts[last] - counts[last - gate]) * quantum / (gate * 1e-3), rtol=1e-14)


def test_the_encoder_model_draws_its_noise_as_the_block_normals():
    params = EncoderParams(noise_deg=0.01, lines_per_rev=2 ** 19, velocity_gate_s=0.005)
    model = EncoderModel(params, 4, np.random.default_rng(3), 1e-3)
    twin = NormalStream(np.random.default_rng(3))
    state, angles, rates = np.zeros(2 + 8), np.zeros(4), np.zeros(4)
    for z in twin.take_block(4, 40):
        truth = np.array([0.3, -0.1, 1e-6, 2.0]) * (1.0 + z[0])
        encoder_step(state, 4, truth, model.quantum_rad, math.radians(0.01), model._gate_steps, model.gate_time_s, z,
                     angles, rates)
        assert (angles.tolist(), rates.tolist()) == model.step(truth.tolist())


@pytest.mark.parametrize("increment", [False, True])
def test_inertial_kernel_matches_its_source_and_the_error_model_closed_form(increment):
    # every term: scale factors, misalignment, drawn and Gauss-Markov biases, random walk,
    # white noise, a quantum with its residual, saturation
    gyro = GyroModel(GyroParams(bias_deg_h=(1.0, 2.0, 3.0), bias_sigma_deg_h=5.0, bias_instability_deg_h=30.0,
                                bias_instability_tau_s=50.0, arw_deg_rt_h=0.5, rrw_deg_h_rt_h=20.0,
                                scale_factor_ppm=(300.0, -200.0, 0.0),
                                misalignment_rad=((0.0, 1e-3, 0.0), (-1e-3, 0.0, 2e-3), (0.0, 0.0, 0.0)),
                                quantisation_rad=1e-6, saturation_deg_s=1.0), 3, np.random.default_rng(11), 1e-3)
    rows, src_rows, out, src = gyro.rows.copy(), gyro.rows.copy(), np.zeros(3), np.zeros(3)
    c = gyro.constants
    for k in range(30):
        u = np.array([1e-3 * k, -2e-3, 0.03 * (k % 3)])  # the last axis beyond ±1 °/s at times
        z = RNG.standard_normal(9)
        gm0, rrw0, res0 = rows[sk_.R_GM].copy(), rows[sk_.R_RRW].copy(), rows[sk_.R_RESIDUAL].copy()
        inertial_step(u, rows, gyro.K, c, z, increment, out)
        inertial_step.py_func(u, src_rows, gyro.K, c, z, increment, src)
        assert out.tolist() == src.tolist() and np.array_equal(rows, src_rows)
        gm = c[sk_.I_PHI] * gm0 + c[sk_.I_GM_DRIVE] * z[0:3]
        rrw = rrw0 + c[sk_.I_RRW_DRIVE] * z[3:6]
        y = np.clip(gyro.K @ u + rows[sk_.R_FIXED] + gm + rrw + c[sk_.I_WHITE_SD] * z[6:9], -math.radians(1.0),
                    math.radians(1.0))
        inc = y * 1e-3 + res0
        q = 1e-6 * np.floor(inc / 1e-6 + 0.5)
        np.testing.assert_allclose(out, q if increment else q / 1e-3, rtol=1e-12, atol=1e-18)


def _messages(scenario, compiled_run: bool) -> dict:
    got: dict = {}

    def record(node, messages):
        for topic, _, data in messages:
            got.setdefault((node, topic), []).append(data)
    if compiled_run:
        compiled_platform.run(scenario, record)
    else:
        vehicle, controlled, stages = core_plan(scenario)
        run_stages(vehicle, stages, controlled=controlled, record=record)
    return got


def test_the_compiled_chain_publishes_the_python_loops_bytes_across_a_reversal():
    # a 1.2° sweep at 1.2 °/s with 0.2 s ramps: reversals at 1.1 s and 2.2 s, integrator presets
    scenario = paper_rate_navigation(2.5)
    for assignment in ("platform_servo.sweep_deg=1.2", "platform_servo.reversal_time_s=0.2"):
        scenario = apply_set(scenario, assignment)
    python, fast = _messages(scenario, False), _messages(scenario, True)
    assert python.keys() == fast.keys() and len(python) >= 18
    for key, data in python.items():
        assert data == fast[key], key


def test_the_compiled_chain_reads_the_resolvers_cyclic_error_as_the_python_loop_does():
    scenario = apply_set(paper_rate_navigation(1.0), "sensor_models.resolver_cyclic_error_arcsec=10.0")
    python, fast = _messages(scenario, False), _messages(scenario, True)
    assert python.keys() == fast.keys()
    for key, data in python.items():
        assert data == fast[key], key
    plain = _messages(paper_rate_navigation(1.0), True)
    key = next(k for k in python if k[1] == "/platform/resolvers")
    assert plain[key] != python[key]  # the error reaches the published angles


def test_the_compiled_chain_applies_the_imus_scale_and_misalignment_errors_as_the_python_loop_does():
    # given and drawn scale factors, asymmetries and misalignments on both triads, across a reversal
    scenario = apply_set(paper_rate_navigation(2.5), "platform_servo.sweep_deg=1.2")
    for assignment in ("platform_gyro_scale_factor_ppm=[200.0, -100.0, 300.0]",
                       "platform_gyro_scale_asymmetry_sigma_ppm=50.0", "platform_gyro_misalignment_sigma_urad=100.0",
                       "platform_accel_scale_factor_sigma_ppm=300.0",
                       "platform_accel_misalignment_urad=[10.0, -20.0, 30.0, 0.0, 5.0, -5.0]",
                       "platform_accel_scale_asymmetry_ppm=[40.0]"):
        scenario = apply_set(scenario, "sensor_models." + assignment)
    python, fast = _messages(scenario, False), _messages(scenario, True)
    assert python.keys() == fast.keys()
    for key, data in python.items():
        assert data == fast[key], key
    plain = _messages(apply_set(paper_rate_navigation(2.5), "platform_servo.sweep_deg=1.2"), True)
    key = next(k for k in python if k[1] == "/platform/imu")
    assert plain[key] != python[key]  # the errors reach the published IMU


def test_the_engine_compiles_the_chain_only():
    nav = variant(load("rotational_ins_navigation"), "rotation_off")
    runner = compiled.compiled_runner
    assert runner(node_values(nav)) is compiled._platform_run
    assert runner(node_values(nav), keep_commands=True) is None   # it keeps no command series
    # the servo's azimuth instead of the resolver's, another plant's node set: the Python loop
    assert runner(node_values(apply_set(nav, "platform_navigator.azimuth_source=servo"))) is None
    assert runner(node_values(load("rotational_platform_servo"))) is None
    assert runner(node_values(load("sighting_land_vehicle"))) is not compiled._platform_run
    short = dataclasses.replace(nav, duration_s=1.0)
    seen = []
    python = run_core_loop(short, observer=lambda bus: seen.append(bus.k))  # an observer keeps the Python loop
    fast = run_core_loop(short)
    assert seen == list(range(51)) and python.steps == fast.steps == 50 and fast.sim_s == python.sim_s


@pytest.mark.parametrize("v", ["ship_rotation_on", "ship_rotation_off"])
def test_the_compiled_chain_on_the_ship_publishes_the_python_loops_bytes(v, monkeypatch):
    """Paper 5's moored ship under the 1 kHz platform (the host's truth per step, the base
    torques −J ω̇_A, the navigator on the servo's φz a step ahead): the Python loop's every
    message, byte for byte, over 1.5 s in blocks of 400 steps (the host's step rotation
    across a block's edge)."""
    monkeypatch.setattr(compiled_platform, "BLOCK_STEPS", 400)
    scenario = dataclasses.replace(variant(load("rotational_ins_navigation"), v), duration_s=1.5)
    assert compiled.compiled_runner(node_values(scenario)) is compiled._platform_run
    python, fast = _messages(scenario, False), _messages(scenario, True)
    assert python.keys() == fast.keys()
    assert {"/truth/host/delta_angle", "~/modulation_next", "~/command_rate"} <= {t for _, t in python}
    for key, data in python.items():
        assert data == fast[key], key


def test_the_outer_member_rates_kernel_is_four_gimbals_to_the_bit():
    from gimbal_kinematics.maths.four_gimbal import outer_member_rates
    from gimbal_kinematics.maths.platform_kernels import outer_member_rates as kernel
    for _ in range(2000):
        w, ang, rate = RNG.normal(0.0, 0.2, 3), RNG.normal(0.0, 1.0, 4), RNG.normal(0.0, 0.1, 4)
        want = outer_member_rates(w.tolist(), ang.tolist(), rate.tolist())
        args = (*w.tolist(), *ang[1:].tolist(), *rate[1:].tolist())
        assert kernel(*args) == want == kernel.py_func(*args)


@pytest.mark.parametrize("v, assignments", [
    ("dtg_1khz", ()),
    ("dtg_1khz", ("sensor_models.dtg_pickoff_noise_arcsec=0.5",
                  "sensor_models.dtg_scale_error_ppm=[100.0, -200.0, 50.0, 300.0]",
                  "sensor_models.dtg_drift_deg_h=[0.1, -0.2, 0.05, 0.3]")),
    ("dtg_1khz", ("sensor_models.dtg_arw_deg_rt_h=0.0", "platform_servo.sweep_deg=1.2")),
    ("ship_rotation_on", ("sensor_models.sensors=[platform_imu, resolvers, dtg]", "platform_servo.gyro_source=dtg")),
])
def test_the_compiled_chain_on_the_dtgs_publishes_the_python_loops_bytes(v, assignments, monkeypatch):
    """Paper 3's servo closed on the DTG pickoffs, its torquer currents held over the next
    step: the pickoffs, the currents and every other message as the Python loop makes them,
    over 1.5 s in blocks of 400 steps (the pair's normals across a block's edge)."""
    monkeypatch.setattr(compiled_platform, "BLOCK_STEPS", 400)
    scenario = dataclasses.replace(variant(load("rotational_ins_navigation"), v), duration_s=1.5)
    for assignment in assignments:
        scenario = apply_set(scenario, assignment)
    assert compiled.compiled_runner(node_values(scenario)) is compiled._platform_run
    python, fast = _messages(scenario, False), _messages(scenario, True)
    assert python.keys() == fast.keys()
    assert {"/platform/dtg_pickoffs", "~/torquer_current"} <= {t for _, t in python}
    for key, data in python.items():
        assert data == fast[key], key


def test_the_dtg_pair_kernel_is_its_model_to_the_bit_with_every_drift_term():
    # g-sensitive drift (no node parameter sets it), scale errors, both noises, currents near the range
    params = DtgPairParams(scale_error_ppm=(300.0, -100.0, 50.0, 0.0), drift_deg_h=(0.2, -0.1, 0.0, 0.3),
                           drift_g_deg_h_g=((0.5, -0.2, 0.1), (0.0, 0.3, -0.4), (0.2, 0.2, 0.2), (-0.6, 0.0, 0.1)),
                           arw_deg_rt_h=0.01, pickoff_noise_arcsec=2.0)
    dt, w_earth = 1e-3, earth_rate_n(math.radians(40.0))
    model = DtgOnPlatform(DtgPair(params, np.random.default_rng(5)), w_earth, dt)
    twin = DtgPair(params, np.random.default_rng(5))  # the same drift draw, then the same stream
    s, g, mounts, q_earth = dtg_kernels.pack(twin, model._q_earth, (0.0, 0.0, 0.0))
    q, out = (0.0, 0.0, 0.0, 1.0), np.zeros(4)
    for k in range(300):
        f = (0.3 * math.sin(0.01 * k), -0.2, 9.8 + 0.01 * k)
        currents = (0.15 * math.cos(0.02 * k), -0.05, 0.17)
        want = model.update(q, f, currents)
        z = twin.rng.standard_normal(8) if k > 0 else np.zeros(0)
        s[dtg_kernels.S_I:dtg_kernels.S_I + 3] = currents
        dtg_kernels.dtg_update(s, g, mounts, q_earth, np.array(q), np.array(f), dt, twin._arw / math.sqrt(dt),
                               twin._pick_sigma, z, out)
        assert out.tolist() == list(want), k
        q = quat_mul(q, quat_from_rotation_vector(2e-3, -1e-3 * math.cos(0.05 * k), 2.1e-2))
