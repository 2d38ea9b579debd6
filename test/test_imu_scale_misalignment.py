"""The inertial sensors' scale-factor error, its asymmetry and the axis misalignment
(measured = (I + S + M) true + A/2 |true|), against closed forms and references written here:
a pure scale-factor error turning the platform at 1.2 °/s drifts its azimuth by SF × 1.2 °/s
(the compiled chain in closed loop, against its own truth); a misalignment couples a rate into
the wrong axis as sensed axes tilted by small rotations (scipy's rotation matrices) say; an
asymmetric scale factor reads a positive and a negative input with scale factors A apart and
leaves A θ over an out-and-back sweep; the per-run draws come from the sensor's own
substreams (the same seed gives the same biases and noise with or without them); the
sensor_models parameters reach the matrix in the documented order; and with every new term
zero the sensor gives the bits it gave before the terms existed (a digest stored from the
model before they were added)."""
import dataclasses
import hashlib
import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from gimbal_kinematics.maths.units import DEG
from gimbal_kinematics.params.table import ParameterError
from gimbal_kinematics.ros.messages import imu_from_cdr
from gimbal_sim.core import compiled_platform
from gimbal_sim.graph.scenario import apply_set, load, variant
from gimbal_sim.nodes.sensor_models_params import PARAMS
from gimbal_sim.world.sensor_suite import SensorSuite, SensorSuiteConfig
from gimbal_sim.world.sensors import AccelerometerModel, AccelerometerParams, GyroModel, GyroParams
from gimbal_sim.world.sensors import sensor_kernels as sk

RATE = 1.2 * DEG  # paper 3's modulation rate [rad/s]


def _gyro(n=3, seed=1, dt=0.01, **kw):
    return GyroModel(GyroParams(**kw), n, np.random.default_rng(seed), dt)


def test_a_scale_factor_error_turning_at_1_2_deg_s_drifts_the_azimuth_by_sf_times_the_rate():
    # paper 3's platform, closed loop through the compiled chain (5 Hz), turning at 1.2 °/s for
    # 250 s (inside the first 300 s leg), every other sensor error off: the servo makes the gyro
    # read the command, so the platform turns 1/(1 + SF) as fast and its azimuth falls behind by
    # SF/(1 + SF) × the angle the z gyro turned through
    base = dataclasses.replace(variant(load("rotational_ins_navigation"), "rotation_on_5hz"), duration_s=250.0)
    for a in ("platform_gyro_bias_sigma_deg_h=0.0", "platform_gyro_arw_deg_rt_h=0.0",
              "platform_accel_bias_sigma_ug=0.0", "platform_accel_noise_ug_rt_hz=0.0"):
        base = apply_set(base, "sensor_models." + a)

    def run(sf_ppm):
        scenario = apply_set(base, f"sensor_models.platform_gyro_scale_factor_ppm=[{sf_ppm}]")
        rates = []

        def record(node, messages):
            rates.extend(imu_from_cdr(bytes(d)).angular_velocity[2] for topic, _, d in messages
                         if topic == "/truth/platform/imu")
        chain = compiled_platform.build_chain(scenario)
        compiled_platform.run(scenario, record, chain=chain)
        return chain.x[0, 0], np.array(rates), chain.dt * chain.imu_every

    sf = 200e-6
    theta0, w0, dt = run(0.0)
    theta1, _, _ = run(sf * 1e6)
    T = 250.0
    assert theta0 / T == pytest.approx(RATE, rel=1e-3)  # it did turn at 1.2 °/s
    drift_rate = (theta1 - theta0) / T
    assert drift_rate == pytest.approx(-sf * RATE, rel=0.01)  # the closed form, within 1 %
    # and to 0.1 % against the chain's own truth: the z gyro's inertial angle (the earth rate in it)
    turned = float(np.sum(w0[:-1]) * dt)  # the rate held over each IMU interval, the last one not stepped
    assert theta1 - theta0 == pytest.approx(-sf / (1.0 + sf) * turned, rel=1e-3)


def test_a_pure_scale_factor_error_integrates_to_sf_times_the_angle_over_an_hour():
    # the model alone, with a bias and noise: same seed, so they cancel in the difference
    kw = dict(bias_sigma_deg_h=0.03, arw_deg_rt_h=0.003, quantisation_rad=1e-7)
    plain, scaled = _gyro(dt=0.1, **kw), _gyro(dt=0.1, scale_factor_ppm=50.0, **kw)
    u = [0.0, 0.0, RATE]
    d = np.zeros(3)
    for _ in range(36000):  # 1 h at 10 Hz
        d += np.array(scaled.step_increment(u)) - np.array(plain.step_increment(u))
    assert d[2] == pytest.approx(50e-6 * RATE * 3600.0, rel=1e-4)  # to the 0.1 µrad quantum
    assert d[0] == d[1] == 0.0


def _small_angle_M(rotvecs):
    """M of sensed axes e_i' = R(r_i) e_i to first order: row i = r_i × e_i (zero i-th element)."""
    return np.array([np.cross(r, e) for r, e in zip(rotvecs, np.eye(3))])


def test_a_misalignment_couples_a_rate_into_the_wrong_axis_as_the_tilted_axes_say():
    rng = np.random.default_rng(4)
    rotvecs = rng.normal(0.0, 200e-6, (3, 3))  # each sensed axis tilted by ~200 µrad
    M = _small_angle_M(rotvecs)
    gyro = _gyro(misalignment_rad=M.tolist(), dt=0.01)
    # the reference: each sensed axis is the rotated unit vector; it reads its projection
    axes = np.array([Rotation.from_rotvec(r).apply(e) for r, e in zip(rotvecs, np.eye(3))])
    for w in (np.array([0.0, RATE, 0.0]), np.array([RATE, 0.0, 0.0]), np.array([0.3, -0.2, RATE])):
        got = np.array(gyro.step_rate(w.tolist()))
        ref = axes @ w
        np.testing.assert_allclose(got, ref, rtol=0, atol=2e-7 * np.linalg.norm(w))  # O(angle²)
    # a pure y rate: the x and z gyros read exactly M_xy ω and M_zy ω (the small-angle matrix),
    # and the tilted axes' projections to first order
    got = np.array(gyro.step_rate([0.0, RATE, 0.0]))
    assert got[0] == pytest.approx(M[0, 1] * RATE, rel=1e-12)
    assert got[2] == pytest.approx(M[2, 1] * RATE, rel=1e-12)
    np.testing.assert_allclose(got[[0, 2]], axes[[0, 2], 1] * RATE, rtol=0, atol=1e-7 * RATE)
    # the same matrix on an accelerometer: gravity along z leaks into x and y
    acc = AccelerometerModel(AccelerometerParams(misalignment_rad=M.tolist()), 3, np.random.default_rng(5), 0.01)
    f = acc.step([0.0, 0.0, -9.8])
    np.testing.assert_allclose(f, axes @ [0.0, 0.0, -9.8], rtol=0, atol=2e-7 * 9.8)


def test_the_node_parameters_fill_the_matrix_row_by_row():
    v = {p.name: p.default for p in PARAMS}
    v.update(sensors=["platform_imu"], platform_gyro_misalignment_urad=[1.0, 2.0, 3.0, 4.0, 5.0, 6.0],
             platform_accel_misalignment_urad=[-1.0, 0.0, 0.0, 0.0, 0.0, 7.0],
             platform_gyro_scale_factor_ppm=[10.0, 20.0, 30.0], platform_accel_scale_asymmetry_ppm=[8.0])
    suite = SensorSuite(SensorSuiteConfig.from_values(v))
    np.testing.assert_array_equal(suite.platform_gyro.misalignment,
                                  1e-6 * np.array([[0, 1, 2], [3, 0, 4], [5, 6, 0]]))
    np.testing.assert_array_equal(suite.platform_accel.misalignment, 1e-6 * np.array([[0, -1, 0], [0, 0, 0],
                                                                                       [0, 7, 0]]))
    np.testing.assert_allclose(suite.platform_gyro.scale_factor_error, [10e-6, 20e-6, 30e-6], rtol=1e-9)
    np.testing.assert_allclose(suite.platform_accel.scale_asymmetry, [8e-6] * 3, rtol=1e-12)
    for bad in ([1.0, 2.0], [1.0] * 5):
        with pytest.raises(ParameterError, match="platform_gyro_misalignment_urad"):
            SensorSuiteConfig.from_values({**v, "platform_gyro_misalignment_urad": bad})
    with pytest.raises(ParameterError, match="platform_gyro_scale_factor_ppm"):
        SensorSuiteConfig.from_values({**v, "platform_gyro_scale_factor_ppm": [1.0, 2.0]})


@pytest.mark.parametrize("increment", [False, True])
def test_an_asymmetric_scale_factor_reads_positive_and_negative_inputs_a_apart(increment):
    s, A = 100e-6, 400e-6
    gyro = _gyro(n=1, scale_factor_ppm=100.0, scale_asymmetry_ppm=400.0, dt=0.01)
    step = gyro.step_increment if increment else gyro.step_rate
    k_plus = step([RATE])[0] / RATE
    k_minus = step([-RATE])[0] / -RATE
    if increment:
        k_plus, k_minus = k_plus / 0.01, k_minus / 0.01
    assert k_plus == pytest.approx(1.0 + s + A / 2.0, rel=1e-13)
    assert k_minus == pytest.approx(1.0 + s - A / 2.0, rel=1e-13)
    assert k_plus - k_minus == pytest.approx(A, rel=1e-8)  # IEEE Std 528: K+ − K−, relative to K
    assert step([0.0])[0] == 0.0


def test_over_an_out_and_back_sweep_the_scale_factor_cancels_and_the_asymmetry_is_left():
    # the rotation-modulation case: +θ then −θ at 1.2 °/s; a symmetric scale factor returns
    # to zero, the asymmetry leaves A θ (K+ θ − K− θ)
    leg = 300.0  # s: 360° at 1.2 °/s
    for sf, asym, expected in ((300.0, 0.0, 0.0), (0.0, 50.0, 50e-6 * RATE * leg), (300.0, 50.0, 50e-6 * RATE * leg)):
        gyro = _gyro(n=1, scale_factor_ppm=sf, scale_asymmetry_ppm=asym, dt=0.1)
        err = 0.0
        for u in [RATE] * 3000 + [-RATE] * 3000:
            err += gyro.step_increment([u])[0] - u * 0.1
        assert err == pytest.approx(expected, abs=1e-12), (sf, asym)


def test_the_per_run_draws_come_from_the_sensors_substreams_and_change_no_other_draw():
    kw = dict(bias_sigma_deg_h=1.0, bias_instability_deg_h=0.5, bias_instability_tau_s=30.0, arw_deg_rt_h=0.1)
    plain = _gyro(seed=9, **kw)
    drawn = _gyro(seed=9, scale_factor_sigma_ppm=100.0, scale_asymmetry_sigma_ppm=20.0, misalignment_sigma_urad=50.0,
                  **kw)
    np.testing.assert_array_equal(drawn.fixed_bias, plain.fixed_bias)
    np.testing.assert_array_equal(drawn.gm_bias, plain.gm_bias)
    # the draws: the three children of the sensor's stream, in order, σ times standard normals
    r_sf, r_asym, r_mis = np.random.default_rng(9).spawn(3)
    np.testing.assert_allclose(drawn.scale_factor_error, 100e-6 * r_sf.standard_normal(3), rtol=1e-9)
    np.testing.assert_allclose(drawn.scale_asymmetry, 20e-6 * r_asym.standard_normal(3), rtol=1e-12)
    M = np.zeros((3, 3))
    M[~np.eye(3, dtype=bool)] = 50e-6 * r_mis.standard_normal(6)
    np.testing.assert_allclose(drawn.misalignment, M, rtol=1e-12)  # σ = 50 × 1e-6, within an ulp of 50e-6
    # outputs: the same noise and biases, the difference is the drawn terms on the input alone
    for k in range(200):
        u = np.array([0.01 * math.sin(0.1 * k), -0.02, RATE * (1 if k < 100 else -1)])
        y0, y1 = np.array(plain.step_rate(u.tolist())), np.array(drawn.step_rate(u.tolist()))
        expected = (np.diag(drawn.scale_factor_error) + M) @ u + 0.5 * drawn.scale_asymmetry * np.abs(u)
        np.testing.assert_allclose(y1 - y0, expected, rtol=0, atol=1e-15)
    # another seed draws other values
    assert not np.array_equal(_gyro(seed=10, scale_factor_sigma_ppm=100.0).scale_factor_error,
                              drawn.scale_factor_error)


#: sha256 of :func:`_model_outputs` computed on the sensor models before the scale-factor
#: asymmetry and the drawn terms existed
DIGEST_BEFORE = "3bcf38816fcbcfe7d1b0d18a1c4e75429814571d47960ed04b05024279d9fd0a"


def _model_outputs(gyro_extra=None, accel_extra=None) -> str:
    h = hashlib.sha256()
    gyro = GyroModel(GyroParams(bias_deg_h=(1.0, 2.0, 3.0), bias_sigma_deg_h=5.0, bias_instability_deg_h=30.0,
                                bias_instability_tau_s=50.0, arw_deg_rt_h=0.5, rrw_deg_h_rt_h=20.0,
                                quantisation_rad=1e-6, **(gyro_extra or {})), 3, np.random.default_rng(7), 1e-2)
    acc = AccelerometerModel(AccelerometerParams(bias_sigma_ug=100.0, noise_ug_rt_hz=50.0, **(accel_extra or {})), 3,
                             np.random.default_rng(8), 1e-2)
    for k in range(500):
        u = [0.02 * math.sin(0.01 * k), -0.01 + 1e-4 * k, math.radians(1.2)]
        h.update(np.array(gyro.step_increment(u)).tobytes())
        h.update(np.array(acc.step([0.1 * math.cos(0.02 * k), -0.2, -9.8])).tobytes())
    return h.hexdigest()


def test_with_the_new_terms_zero_the_sensors_give_the_bits_they_gave_before():
    assert _model_outputs() == DIGEST_BEFORE
    zero = dict(scale_factor_sigma_ppm=0.0, scale_asymmetry_ppm=0.0, scale_asymmetry_sigma_ppm=0.0,
                misalignment_sigma_urad=0.0)
    assert _model_outputs(zero, zero) == DIGEST_BEFORE
    assert _model_outputs({"scale_asymmetry_ppm": 1.0}) != DIGEST_BEFORE  # the digest does see the terms
    # the node's defaults: nothing drawn, the asymmetry and off-diagonal terms switched off
    v = {p.name: p.default for p in PARAMS}
    v["sensors"] = ["ins", "gimbal_gyro", "lgu", "platform_imu", "free_gyro"]
    suite = SensorSuite(SensorSuiteConfig.from_values(v))
    for model in (suite.ins.gyro, suite.gimbal_gyro, suite.lgu.lgu1, suite.lgu.lgu2, suite.platform_gyro,
                  suite.platform_accel, suite.free_gyro.triad):
        assert model.constants[sk.I_HAS_K] == 0.0 and model.constants[sk.I_HAS_ASYM] == 0.0
        assert np.all(model.rows[sk.R_KDIAG] == 1.0) and np.all(model.rows[sk.R_ASYM] == 0.0)


def test_gimbal_allan_carries_the_data_sheets_scale_factor_and_misalignment_into_the_parameter_files(tmp_path):
    import yaml

    from gimbal_sim.allan import kalibr
    from gimbal_sim.allan.cli import main

    noise = tmp_path / "imu.yaml"
    noise.write_text("accelerometer_noise_density: 0.002\naccelerometer_random_walk: 3.0e-05\n"
                     "gyroscope_noise_density: 0.0002\ngyroscope_random_walk: 2.0e-06\nrostopic: /imu0\n"
                     "update_rate: 200.0\n")
    assert main(["--from-kalibr", str(noise), "--simulate-as", "ins_gyro", "--scale-factor-ppm", "300",
                 "--misalignment-urad", "150", "--out", str(tmp_path / "out")]) == 0
    sim = yaml.safe_load((tmp_path / "out" / "sensor_models.yaml").read_text())["sensor_models"]["ros__parameters"]
    assert sim["ins_gyro_scale_factor_sigma_ppm"] == 300.0 and sim["ins_gyro_misalignment_sigma_urad"] == 150.0
    assert "ins_gyro_scale_asymmetry_sigma_ppm" not in sim  # not given: a scenario keeps its own
    args = (tmp_path / "out" / "set_args.txt").read_text()
    assert "--set sensor_models.ins_gyro_scale_factor_sigma_ppm=300.0" in args
    # the file reaches the simulated sensor: sensor_models takes these parameters
    v = {p.name: p.default for p in PARAMS}
    v.update(sim, sensors=["ins"])
    suite = SensorSuite(SensorSuiteConfig.from_values(v))
    assert suite.ins.gyro.constants[sk.I_HAS_K] == 1.0 and np.any(suite.ins.gyro.scale_factor_error != 0.0)
    # Kalibr's noise file has no place for them: comments
    imu = kalibr.read_kalibr(noise, "--from-kalibr")
    text = kalibr.kalibr_yaml(imu, "test", {"scale_factor_sigma_ppm": 300.0, "misalignment_sigma_urad": None})
    assert "scale-factor error 1-sigma [ppm] 300" in text and yaml.safe_load(text)["gyroscope_noise_density"] == 0.0002
    assert main(["--from-kalibr", str(noise), "--scale-factor-ppm", "-1", "--out", str(tmp_path / "bad")]) == 2
