"""Paper 2 closed-loop experiment (docs/spec.md §3.2): :class:`gimbal_control.encoder_fusion.EncoderFusionController`
stabilizing the simulated small UAV gimbal in each feedback mode (encoder, gyro, fused), without
ROS; the ``gimbal_encoder_fusion`` scenario runs the same cores through the graph.

The plant, base motion and sensors of the experiment are defined here (:data:`UAV_GIMBAL`,
:data:`UAV_PROFILE`, :data:`UAV_INITIAL_JOINTS_DEG`, :data:`MEMS_GYRO`); the scenario's YAML
carries the same values (a test keeps them in step).
"""
from __future__ import annotations

from typing import Any

import numpy as np

from gimbal_control.encoder_fusion import MODES, EncoderFusionController, EncoderFusionParams
from gimbal_kinematics.gimbal.gimbal_params import UAV_SMALL_GIMBAL

from ..world.sensor_suite import EncoderSample, GimbalGyroSample, SensorSuite, SensorSuiteConfig
from ..world.sensors import PAPER2_ENCODER, EncoderParams, GyroParams
from ..world.plant.dc_motor import SMALL_GIMBAL_MOTOR, DcMotorParams
from ..world.vehicle import VehicleConfig, VehicleCore
from ..core.core_loop import run_stages

#: The simulated plant is gimbal_sim's ``uav_small`` preset (the ``gimbal_model`` of the
#: vehicle node); this name stays for the experiment and the tests.
UAV_GIMBAL = UAV_SMALL_GIMBAL

#: MEMS gyro (consumer/industrial grade, e.g. a BMI088/ADXRS-class part): a turn-on bias of
#: 0.1 °/s and −0.07 °/s (360 and −250 °/h, given so every run shows the same drift), in-run
#: bias drift as a Gauss-Markov process of 0.02 °/s (72 °/h) RMS with τ = 60 s, ARW
#: 0.2 °/√h, scale-factor error 0.3 % and −0.2 %, range ±300 °/s.
MEMS_GYRO = GyroParams(
    bias_deg_h=(360.0, -250.0),
    bias_instability_deg_h=72.0,
    bias_instability_tau_s=60.0,
    arw_deg_rt_h=0.2,
    scale_factor_ppm=(3000.0, -2000.0),
    saturation_deg_s=300.0,
)

#: UAV angular motion (degrees; [amplitude_deg, frequency_rad_s, phase_rad]): attitude
#: oscillations of a small fixed-wing/multirotor in light turbulence (roll ±4° at 0.35 Hz,
#: ±1.5° at 1.2 Hz; pitch ±2.5° at 0.25 Hz, ±1° at 0.9 Hz; yaw ±3° at 0.1 Hz, ±1° at
#: 0.6 Hz: peak body rates ≈ 20 °/s) plus airframe/propeller vibration of a few
#: hundredths of a degree at 9–15 Hz, and ±0.5 m/s² pivot accelerations at 2–5 Hz (these
#: act on the mass imbalance).
UAV_PROFILE: dict[str, Any] = {
    "roll": [[4.0, 2.2, 0.0], [1.5, 7.5, 0.4], [0.05, 75.4, 1.1]],
    "pitch": [[2.5, 1.6, 0.7], [1.0, 5.7, 2.1], [0.04, 94.2, 0.2]],
    "yaw": [[3.0, 0.63, 1.3], [1.0, 3.8, 0.9], [0.03, 56.5, 2.6]],
    "accel_x_m_s2": [[0.5, 12.6, 0.0]],
    "accel_y_m_s2": [[0.5, 18.8, 1.0]],
    "accel_z_m_s2": [[0.5, 31.4, 2.0]],
}

#: Initial joints (ψm, θm) [deg]: camera 20° below the horizon, straight ahead.
UAV_INITIAL_JOINTS_DEG = (0.0, -20.0)


def _los_n(quat_nm: np.ndarray) -> tuple[float, float, float]:
    """LOS (m-frame x axis) resolved in n from the quaternion (x, y, z, w) of C_nm."""
    x, y, z, w = (float(v) for v in quat_nm)
    return 1.0 - 2.0 * (y * y + z * z), 2.0 * (x * y + z * w), 2.0 * (x * z - y * w)


def _angle_between(vecs: np.ndarray, ref: np.ndarray) -> np.ndarray:
    """Angles [rad] between the rows of ``vecs`` (n, 3) and ``ref`` (3,) (atan2 form)."""
    cross = np.cross(vecs, ref)
    return np.arctan2(np.linalg.norm(cross, axis=1), vecs @ ref)


def run_encoder_fusion(mode: str, duration_s: float = 60.0, seed: int = 0, *,
                       params: EncoderFusionParams | None = None,
                       settle_s: float = 5.0, gyro: GyroParams = MEMS_GYRO,
                       encoder: EncoderParams = PAPER2_ENCODER,
                       profile_params: dict[str, Any] | None = None,
                       record_every: int = 10, actuator: str = "torque",
                       motor: DcMotorParams = SMALL_GIMBAL_MOTOR) -> dict[str, Any]:
    """Closed-loop paper 2 experiment on the small UAV gimbal; returns metrics + series.

    The UAV base follows ``profile_params`` (default :data:`UAV_PROFILE`) with NED treated
    as inertial (``earth_rate=False``); the gimbal is :data:`UAV_GIMBAL` at 1 kHz; sensors
    are the 1024-line encoders (:data:`gimbal_sim.world.sensors.PAPER2_ENCODER`) and the MEMS
    gyro ``gyro`` on the inner gimbal; the autopilot's body rates are the truth.

    Stabilization error: the angle between the LOS (m-frame x axis, from
    ``truth.quat_nm``) and its inertial direction at t = 0 [rad]. Metrics (SI):

    * ``rms_error_rad`` / ``peak_error_rad``: RMS and peak of that angle over
      t >= ``settle_s`` (the filter has converged);
    * ``rms_error_all_rad``: the same over the whole run;
    * ``rms_error_held_rad``: RMS angle from the LOS direction *at* ``settle_s``. This is
      the pure stabilization jitter and wander, without the one-off offset the fused loop
      picks up while the filter converges and the encoder reference settles (±δ/2 of one
      count at most);
    * ``velocity_bias_rad_s``: mean(ω_fb − ω_true) per axis (q, r) over the second half;
      ``gyro_bias_rad_s``: the mean true gyro bias over the same span;
      ``velocity_error_rms_rad_s``;
    * ``correction_rad_s``: the filter's final drift corrections E (q, r);
      ``rms_torque_nm``; ``kf_updates``; the rejection counters.

    ``series`` holds every ``record_every``-th sample of t, both errors, the feedback and
    true rates, the true gyro bias and the torques (numpy arrays).
    """
    if mode not in MODES:
        raise ValueError(f"mode must be one of {MODES}, got {mode!r}")
    if params is None:
        params = EncoderFusionParams(mode=mode)
    elif params.mode != mode:
        raise ValueError(f"params.mode {params.mode!r} differs from mode {mode!r}")
    rate = 1000.0
    core = VehicleCore(VehicleConfig(
        profile="sinusoids", profile_params=profile_params or UAV_PROFILE, plant="two_axis_gimbal",
        sim_rate_hz=rate, duration_s=duration_s, earth_rate=False,
        initial_joints_deg=UAV_INITIAL_JOINTS_DEG, gimbal_actuator=actuator, motor=motor), gimbal_params=UAV_GIMBAL)
    suite = SensorSuite(SensorSuiteConfig(sensors=("gimbal_gyro", "encoders"), sim_rate_hz=rate, seed=seed,
                                          gimbal_gyro=gyro, encoder=encoder,
                                          gimbal_gyro_rate_hz=rate, encoder_rate_hz=rate))
    ctl = EncoderFusionController(params)
    return _metrics(mode, duration_s, seed, settle_s, record_every, ctl, _fly(core, suite, ctl, rate), rate)


def _fly(core: VehicleCore, suite: SensorSuite, ctl: EncoderFusionController, rate: float) -> dict[str, np.ndarray]:
    """Close the loop to the end of the run on the one engine's loop
    (:func:`..core.core_loop.run_stages`, this controller's stage); every step's LOS direction
    (n, 3), feedback and true rates, true gyro bias and torques (n, 2)."""
    n = core.config.n_steps
    rec = {"los": np.zeros((n, 3)), "fb": np.zeros((n, 2)), "true_rate": np.zeros((n, 2)),
           "bias": np.zeros((n, 2)), "torque": np.zeros((n, 2))}
    cmd = [(0.0, 0.0)]

    def stage(bus) -> None:
        k, truth = bus.k, bus.truth
        if k == n:  # the final truth: no step follows it
            return
        rec["los"][k] = _los_n(truth.quat_nm)
        ctl.on_base_rates(truth.t, truth.omega_ib_b)
        samples = suite.update(truth)
        # the encoders of this step before its gyro tick, as the lockstep node feeds them
        for s in samples:
            if isinstance(s, EncoderSample):
                ctl.on_encoders(s.t, s.angles[1], s.angles[2])
        for s in samples:
            if isinstance(s, GimbalGyroSample):
                out = ctl.on_gyro(s.t, s.q_m, s.r_m)
                if out is not None:
                    cmd[0] = (out.torque_azimuth, out.torque_elevation)
                rec["bias"][k] = s.true_bias
        rec["fb"][k] = ctl.feedback
        rec["true_rate"][k] = truth.omega_im_m[1], truth.omega_im_m[2]
        rec["torque"][k] = cmd[0]
        bus.command = cmd[0]

    run_stages(core, [stage])
    return rec


def _metrics(mode: str, duration_s: float, seed: int, settle_s: float, record_every: int,
             ctl: EncoderFusionController, rec: dict[str, np.ndarray], rate: float) -> dict[str, Any]:
    """:func:`run_encoder_fusion`'s metrics and series from the run's records ``rec``."""
    los, fb, true_rate, bias, torque = (rec[k] for k in ("los", "fb", "true_rate", "bias", "torque"))
    n = len(los)
    t = np.arange(n) / rate
    k_ref = min(int(round(settle_s * rate)), n // 2)
    after = slice(k_ref, None)
    err_ref = _angle_between(los, los[k_ref])
    err_0 = _angle_between(los, los[0])
    half = t >= 0.5 * duration_s
    sl = slice(None, None, max(1, int(record_every)))
    return {
        "mode": mode,
        "duration_s": duration_s,
        "seed": seed,
        "rms_error_rad": float(np.sqrt(np.mean(err_0[after] ** 2))),
        "peak_error_rad": float(np.max(err_0[after])),
        "rms_error_all_rad": float(np.sqrt(np.mean(err_0 ** 2))),
        "rms_error_held_rad": float(np.sqrt(np.mean(err_ref[after] ** 2))),
        "velocity_bias_rad_s": tuple(float(v) for v in np.mean(fb[half] - true_rate[half], axis=0)),
        "velocity_error_rms_rad_s": tuple(float(v) for v in np.sqrt(np.mean((fb[half] - true_rate[half]) ** 2, axis=0))),
        "gyro_bias_rad_s": tuple(float(v) for v in np.mean(bias[half], axis=0)),
        "correction_rad_s": ctl.corrections,
        "rms_torque_nm": tuple(float(v) for v in np.sqrt(np.mean(torque ** 2, axis=0))),
        "kf_updates": ctl.kf_q.updates,
        "rejected_nonfinite": ctl.rejected_nonfinite,
        "series": {"t": t[sl], "error_rad": err_0[sl], "error_held_rad": err_ref[sl], "feedback_rad_s": fb[sl],
                   "true_rate_rad_s": true_rate[sl], "gyro_bias_rad_s": bias[sl], "torque_nm": torque[sl]},
    }
