"""The ``sensor_models`` node's parameters and --help text, declared once in
:class:`SensorModelsNodeParams`. The mapping to the suite's config is
:meth:`..world.sensor_suite.SensorSuiteConfig.from_values`.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from gimbal_kinematics.params.table import SHARED, declaration, param, same_as

from ..world.sensor_suite import SENSORS
from ..world.sensors.ins import ATTITUDE_MODELS, SCHULER_PERIOD_S

INF = math.inf


# The axis errors of a three-axis IMU ("what": how --help names it), one declaration each for
# every IMU that has them (the gimbal's two-axis gyro names its own axes).
def _scale_factor(what: str):
    return param((0.0,), f"{what} scale-factor error s, given: one value (every axis) or one per axis (x, y, z)",
                 unit="ppm")


def _scale_factor_sigma(what: str):
    return param(0.0, f"{what} scale-factor error 1-sigma, drawn once per run per axis and added to s", 0.0, 1e6,
                 unit="ppm")


def _scale_asymmetry(what: str):
    return param((0.0,), f"{what} scale-factor asymmetry A = K+ - K-, given: one value (every axis) or one per axis "
                 "(x, y, z); the scale factor is 1 + s + A/2 for a positive input, 1 + s - A/2 for a negative one",
                 unit="ppm")


def _scale_asymmetry_sigma(what: str):
    return param(0.0, f"{what} scale-factor asymmetry 1-sigma, drawn once per run per axis and added to A", 0.0, 1e6,
                 unit="ppm")


def _misalignment(what: str):
    return param((0.0,) * 6, f"{what} axis misalignment and non-orthogonality, given: the off-diagonal elements of M "
                 "in measured = (I + S + M) true, row by row (M_xy, M_xz, M_yx, M_yz, M_zx, M_zy; M_ij: how much of "
                 "true axis j sensed axis i reads); all zero: none", unit="urad")


def _misalignment_sigma(what: str):
    return param(0.0, f"{what} misalignment 1-sigma, drawn once per run for each off-diagonal element of M and added",
                 0.0, 1e6, unit="urad")


@dataclass(frozen=True)
class SensorModelsNodeParams:
    """Sensor models: subscribes to the vehicle's truth topics and publishes the INS, the two-axis gimbal gyro, the
    encoders, the paper 5 LGUs, the paper 3 platform IMU and gimbal resolvers and the paper 4 free gyros, each
    at its own rate with the papers' error models, plus the error truth (biases, flexure, the ship's position).
    """

    sensors: tuple[str, ...] = param(("ins", "gimbal_gyro", "encoders"), f"enabled sensors, any of {list(SENSORS)}")
    sim_rate_hz: float = param(1000.0, "simulation rate; must equal vehicle_dynamics'", 1.0, 100000.0, unit="Hz")
    seed: int = param(0, "seed of every sensor's random stream", 0, 2**31 - 1)
    progress_every_steps: int = same_as(SHARED["progress_every_steps"])
    wait_for_subscribers: int = same_as(SHARED["wait_for_subscribers"])
    subscriber_counts: tuple[str, ...] = param((), "per-topic overrides of wait_for_subscribers, as '/topic=count' "
        "entries (a real-time scenario: its free-timing readers announce no readiness)", array_type="string_array")
    ins_rate_hz: float = param(100.0, "INS output rate", 1e-3, 100000.0, unit="Hz")
    gimbal_gyro_rate_hz: float = param(1000.0, "gimbal gyro output rate", 1e-3, 100000.0, unit="Hz")
    encoder_rate_hz: float = param(1000.0, "encoder output rate", 1e-3, 100000.0, unit="Hz")
    lgu_rate_hz: float = param(100.0, "LGU output rate", 1e-3, 100000.0, unit="Hz")
    platform_imu_rate_hz: float = param(100.0, "platform IMU output rate", 1e-3, 100000.0, unit="Hz")
    gimbal_gyro_bias_deg_h: tuple[float, ...] = param((100.0, 100.0), "gimbal gyro fixed bias (q_m, r_m)",
        unit="deg/h")
    gimbal_gyro_bias_sigma_deg_h: float = param(0.0, "gimbal gyro run-to-run bias 1-sigma", 0.0, INF, unit="deg/h")
    gimbal_gyro_arw_deg_rt_h: float = param(0.15, "gimbal gyro angle random walk", 0.0, INF, unit="deg/sqrt(h)")
    gimbal_gyro_bi_deg_h: float = param(30.0, "gimbal gyro Gauss-Markov bias instability RMS", 0.0, INF, unit="deg/h")
    gimbal_gyro_bi_tau_s: float = param(100.0, "its correlation time (inf: random constant)", 1e-9, INF, unit="s")
    gimbal_gyro_rrw_deg_h_rt_h: float = param(0.0, "gimbal gyro rate random walk", 0.0, INF, unit="deg/h/sqrt(h)")
    gimbal_gyro_quantum_deg: float = param(0.0, "gimbal gyro incremental-angle quantum (LSB) (0: none); IEEE 952 "
        "quantisation noise Q = quantum / sqrt(12)", 0.0, INF, unit="deg")
    gimbal_gyro_scale_factor_ppm: tuple[float, ...] = param((0.0, 0.0), "gimbal gyro scale-factor error s, given, "
        "one value (every axis) or one per axis (q_m, r_m)", unit="ppm")
    gimbal_gyro_range_deg_s: float = param(0.0, "gimbal gyro measurement range +- (0: unlimited)",
        0.0, INF, unit="deg/s")
    gimbal_gyro_scale_factor_sigma_ppm: float = param(0.0, "gimbal gyro scale-factor error 1-sigma, drawn once per "
        "run per axis and added to s", 0.0, 1e6, unit="ppm")
    gimbal_gyro_scale_asymmetry_ppm: tuple[float, ...] = param((0.0,), "gimbal gyro scale-factor asymmetry A = K+ - "
        "K-, given: one value (every axis) or one per axis (q_m, r_m); the scale factor is 1 + s + A/2 for a "
        "positive input, 1 + s - A/2 for a negative one", unit="ppm")
    gimbal_gyro_scale_asymmetry_sigma_ppm: float = param(0.0, "gimbal gyro scale-factor asymmetry 1-sigma, drawn "
        "once per run per axis and added to A", 0.0, 1e6, unit="ppm")
    gimbal_gyro_misalignment_urad: tuple[float, ...] = param((0.0, 0.0), "gimbal gyro axis misalignment and "
        "non-orthogonality, given: the off-diagonal elements of M in measured = (I + S + M) true, row by row (M_12, "
        "M_21; M_ij: how much of true axis j sensed axis i reads); all zero: none", unit="urad")
    gimbal_gyro_misalignment_sigma_urad: float = param(0.0, "gimbal gyro misalignment 1-sigma, drawn once per run "
        "for each off-diagonal element of M and added", 0.0, 1e6, unit="urad")
    ins_roll_pitch_rms_deg: float = param(0.05, "INS roll/pitch error RMS", 0.0, INF, unit="deg")
    ins_heading_rms_deg: float = param(0.2, "INS heading error RMS", 0.0, INF, unit="deg")
    ins_attitude_tau_s: float = param(300.0, "INS attitude error correlation time (the heading's alone with the "
                                      "schuler model)", 1e-9, INF, unit="s")
    ins_attitude_model: str = param("gauss_markov", "INS attitude errors: gauss_markov (first order per angle) or "
                                    "schuler (damped Schuler-period tilt oscillation, Gauss-Markov heading)",
                                    choices=ATTITUDE_MODELS)
    ins_schuler_period_s: float = param(SCHULER_PERIOD_S, "undamped Schuler period of the INS tilt errors, "
                                        "2 pi sqrt(R/g)", 60.0, 1e5, unit="s")
    ins_schuler_damping: float = param(0.1, "damping ratio of the INS tilt oscillation (aided INS)", 1e-3, 0.999,
                                       unit="-")
    ins_gyro_bias_sigma_deg_h: float = param(1.0, "INS gyro run-to-run bias 1-sigma", 0.0, INF, unit="deg/h")
    ins_gyro_bi_deg_h: float = param(1.0, "INS gyro Gauss-Markov bias RMS", 0.0, INF, unit="deg/h")
    ins_gyro_bi_tau_s: float = param(60.0, "its correlation time", 1e-9, INF, unit="s")
    ins_gyro_arw_deg_rt_h: float = param(0.1, "INS gyro angle random walk", 0.0, INF, unit="deg/sqrt(h)")
    ins_gyro_rrw_deg_h_rt_h: float = param(0.0, "INS gyro rate random walk", 0.0, INF, unit="deg/h/sqrt(h)")
    ins_gyro_quantum_deg: float = param(0.0, "INS gyro incremental-angle quantum (LSB) (0: none); IEEE 952 "
        "quantisation noise Q = quantum / sqrt(12)", 0.0, INF, unit="deg")
    ins_gyro_scale_factor_ppm: tuple[float, ...] = _scale_factor("INS gyro")
    ins_gyro_scale_factor_sigma_ppm: float = _scale_factor_sigma("INS gyro")
    ins_gyro_scale_asymmetry_ppm: tuple[float, ...] = _scale_asymmetry("INS gyro")
    ins_gyro_scale_asymmetry_sigma_ppm: float = _scale_asymmetry_sigma("INS gyro")
    ins_gyro_misalignment_urad: tuple[float, ...] = _misalignment("INS gyro")
    ins_gyro_misalignment_sigma_urad: float = _misalignment_sigma("INS gyro")
    encoder_noise_deg: float = param(0.05, "encoder angle noise RMS", 0.0, INF, unit="deg")
    encoder_lines_per_rev: int = param(0, "encoder lines per revolution (0: no quantisation)", 0, 10**9)
    encoder_quadrature: int = param(1, "edges counted per line (1, 2 or 4)", 1, 4)
    encoder_velocity_gate_s: float = param(0.01, "pulse-counting gate time of the encoder rate", 1e-9, INF, unit="s")
    lgu1_bias_deg_h: float = param(0.05, "LGU1 fixed bias", unit="deg/h")
    lgu2_bias_deg_h: float = param(-0.05, "LGU2 fixed bias", unit="deg/h")
    lgu_arw_deg_rt_h: float = param(0.001, "LGU angle random walk", 0.0, INF, unit="deg/sqrt(h)")
    lgu_scale_factor_ppm: tuple[float, ...] = _scale_factor("LGU gyro (each unit its own draw)")
    lgu_scale_factor_sigma_ppm: float = _scale_factor_sigma("LGU gyro (each unit its own draw)")
    lgu_scale_asymmetry_ppm: tuple[float, ...] = _scale_asymmetry("LGU gyro (each unit its own draw)")
    lgu_scale_asymmetry_sigma_ppm: float = _scale_asymmetry_sigma("LGU gyro (each unit its own draw)")
    lgu_misalignment_urad: tuple[float, ...] = _misalignment("LGU gyro (each unit its own draw)")
    lgu_misalignment_sigma_urad: float = _misalignment_sigma("LGU gyro (each unit its own draw)")
    flexure_initial_deg: float = param(0.1, "quasi-static flexure at t0, each axis", unit="deg")
    flexure_linear_rate_deg_h: float = param(0.2, "quasi-static linear flexure rate", unit="deg/h")
    flexure_slow_amplitude_arcsec: float = param(90.0, "slow sinusoidal flexure amplitude", 0.0, INF, unit="arcsec")
    flexure_slow_period_s: float = param(3600.0, "its period", 1e-9, INF, unit="s")
    flexure_helm_amplitude_deg: float = param(0.1, "helm-induced flexure amplitude", 0.0, INF, unit="deg")
    flexure_helm_period_s: float = param(200.0, "its period", 1e-9, INF, unit="s")
    flexure_dynamic_rms_arcsec: tuple[float, ...] = param((20.0, 60.0, 40.0), "dynamic flexure RMS (roll, pitch, yaw)",
        unit="arcsec")
    flexure_dynamic_beta_per_s: tuple[float, ...] = param((0.2146, 0.2146, 0.2146), "dynamic flexure 2nd-order "
        "Markov decay rate beta (roll, pitch, yaw), > 0; critically damped: 2.146 / (1/e correlation time), default "
        "10 s; paper 5 gives none (docs/results/paper5.md: the dynamic-flexure band)", unit="1/s")
    flexure_dynamic_freq_rad_s: tuple[float, ...] = param((0.0, 0.0, 0.0), "dynamic flexure damped frequency lambda "
        "(roll, pitch, yaw), >= 0; 0 (default): the textbook critically damped 2nd-order Markov, > 0: a band peaked "
        "at lambda (sea waves)", unit="rad/s")
    flexure_dynamic_model: str = param("band", "dynamic flexure truth: band (the filter's own 2nd-order Markov, "
        "the flexure_dynamic_* figures above) or hull (a frigate hull's first bending and torsion modes driven by a "
        "sea spectrum; docs/results/paper5.md: the hull under a sea)", choices=("band", "hull"))
    flexure_sea_state: int = param(4, "hull model: NATO sea state (open ocean North Atlantic) giving the "
        "significant wave height and modal period: 3 (0.88 m, 7.5 s), 4 (1.88 m, 8.8 s), 5 (3.25 m, 9.7 s), "
        "6 (5.0 m, 12.4 s)", 3, 6)
    flexure_wave_height_m: float = param(0.0, "hull model: significant wave height, 0 = the sea state's",
        0.0, INF, unit="m")
    flexure_wave_period_s: float = param(0.0, "hull model: modal (peak) wave period, 0 = the sea state's",
        0.0, INF, unit="s")
    flexure_ship_speed_m_s: float = param(7.72, "hull model: ship speed through the waves (7.72 m/s = 15 kn)",
        0.0, 30.0, unit="m/s")
    flexure_wave_heading_deg: float = param(150.0, "hull model: wave heading relative to the bow (180: head seas, "
        "90: beam seas, 0: following)", -360.0, 360.0, unit="deg")
    flexure_hull_mode_freq_hz: tuple[float, ...] = param((2.4, 1.2, 1.8), "hull model: first mode frequency "
        "(roll: torsion, pitch: 2-node vertical, yaw: 2-node horizontal bending)", unit="Hz")
    flexure_hull_damping_ratio: tuple[float, ...] = param((0.02, 0.02, 0.02), "hull model: modal damping ratio "
        "(roll, pitch, yaw), fraction of critical", unit="-")
    flexure_lgu_stations_m: tuple[float, ...] = param((0.0, 30.0), "hull model: LGU1 and LGU2 positions along the "
        "hull from amidships, forward positive (125 m hull)", unit="m")
    platform_gyro_bias_sigma_deg_h: float = param(0.03, "platform gyro run-to-run bias 1-sigma",
        0.0, INF, unit="deg/h")
    platform_gyro_arw_deg_rt_h: float = param(0.003, "platform gyro angle random walk", 0.0, INF, unit="deg/sqrt(h)")
    platform_gyro_bi_deg_h: float = param(0.0, "platform gyro in-run drift: Gauss-Markov bias instability RMS "
        "(0: the drift is the run-to-run bias alone)", 0.0, INF, unit="deg/h")
    platform_gyro_bi_tau_s: float = param(3600.0, "its correlation time (inf: random constant)", 1e-9, INF, unit="s")
    platform_gyro_scale_factor_ppm: tuple[float, ...] = _scale_factor("platform gyro")
    platform_gyro_scale_factor_sigma_ppm: float = _scale_factor_sigma("platform gyro")
    platform_gyro_scale_asymmetry_ppm: tuple[float, ...] = _scale_asymmetry("platform gyro")
    platform_gyro_scale_asymmetry_sigma_ppm: float = _scale_asymmetry_sigma("platform gyro")
    platform_gyro_misalignment_urad: tuple[float, ...] = _misalignment("platform gyro")
    platform_gyro_misalignment_sigma_urad: float = _misalignment_sigma("platform gyro")
    platform_accel_bias_sigma_ug: float = param(100.0, "platform accelerometer bias 1-sigma",
        0.0, INF, unit="micro-g")
    platform_accel_noise_ug_rt_hz: float = param(50.0, "platform accelerometer noise density",
        0.0, INF, unit="micro-g/sqrt(Hz)")
    platform_accel_scale_factor_ppm: tuple[float, ...] = _scale_factor("platform accelerometer")
    platform_accel_scale_factor_sigma_ppm: float = _scale_factor_sigma("platform accelerometer")
    platform_accel_scale_asymmetry_ppm: tuple[float, ...] = _scale_asymmetry("platform accelerometer")
    platform_accel_scale_asymmetry_sigma_ppm: float = _scale_asymmetry_sigma("platform accelerometer")
    platform_accel_misalignment_urad: tuple[float, ...] = _misalignment("platform accelerometer")
    platform_accel_misalignment_sigma_urad: float = _misalignment_sigma("platform accelerometer")
    free_gyro_rate_hz: float = param(10.0, "free-gyro read-out rate (spin axes, triad, vertical reference)",
        1e-3, 100000.0, unit="Hz")
    free_gyro_site_lat_deg: float = param(35.0, "ship's true geodetic latitude; must equal vehicle_dynamics' "
        "profile_params lat_deg (the vehicle does not publish its position)", -90.0, 90.0, unit="deg")
    free_gyro_site_lon_deg: float = param(129.0, "ship's true longitude; must equal vehicle_dynamics' profile_params "
        "lon_deg", -180.0, 180.0, unit="deg")
    free_gyro_nadir_deg: tuple[float, ...] = param((60.0, 50.0), "nadir angles (gyro a, gyro b) the spin axes are "
        "set to at the ship's site at t = 0, each in (0, 180)", unit="deg")
    free_gyro_azimuth_deg: tuple[float, ...] = param((-40.0, 50.0), "azimuths from north toward east (gyro a, gyro "
        "b) of the spin axes at the site at t = 0; fix geometry FDOP = sqrt(2)/|sin(difference)|", unit="deg")
    free_gyro_pickoff_noise_arcsec: float = param(5.0, "spin-axis pickoff white noise per axis, per sample",
        0.0, INF, unit="arcsec")
    free_gyro_spin_drift_sigma_deg_h: float = param(0.0, "spin-axis random-constant drift 1-sigma per axis (0: ideal "
        "free gyro)", 0.0, INF, unit="deg/h")
    free_gyro_caging_error_arcsec: float = param(0.0, "1-sigma per axis of each rotor's random-constant uncaging "
        "error: its spin axis released this far from where it was set (0: none)", 0.0, INF, unit="arcsec")
    free_gyro_gm_drift_sigma_deg_h: float = param(0.0, "1-sigma per axis of each spin axis's first-order "
        "Gauss-Markov drift rate, stationary from t = 0 (0: none)", 0.0, INF, unit="deg/h")
    free_gyro_gm_drift_tau_s: float = param(300.0, "correlation time of that Gauss-Markov drift",
        1e-6, INF, unit="s")
    free_gyro_lock_guard_deg: float = param(0.0, "gimbal-lock suppression: within this angle of the outer gimbal "
        "axis (the case's z) the spin axis is precessed away from it (0: no suppression)", 0.0, 89.999, unit="deg")
    free_gyro_lock_suppression_rate_deg_h: float = param(0.0, "precession rate of that suppression",
        0.0, INF, unit="deg/h")
    free_gyro_spin_rate_arw_deg_rt_h: float = param(0.0, "angle random walk of the spin-axis rate sensors whose "
        "outputs are integrated from t = 0, so the read-out random-walks (0: angle pickoffs)", 0.0, INF,
        unit="deg/sqrt(h)")
    free_gyro_level_noise_arcsec: float = param(0.0, "vertical reference roll/pitch white noise",
        0.0, INF, unit="arcsec")
    free_gyro_level_bias_arcsec: tuple[float, ...] = param((0.0, 0.0), "vertical reference fixed (roll, pitch) error",
        unit="arcsec")
    free_gyro_triad_arw_deg_rt_h: float = param(0.002, "body gyro triad angle random walk",
        0.0, INF, unit="deg/sqrt(h)")
    free_gyro_triad_bias_deg_h: tuple[float, ...] = param((0.0, 0.0, 0.0), "body gyro triad fixed bias (x, y, z)",
        unit="deg/h")
    free_gyro_triad_bias_sigma_deg_h: float = param(0.0, "body gyro triad run-to-run bias 1-sigma",
        0.0, INF, unit="deg/h")
    free_gyro_triad_scale_factor_ppm: tuple[float, ...] = _scale_factor("body gyro triad")
    free_gyro_triad_scale_factor_sigma_ppm: float = _scale_factor_sigma("body gyro triad")
    free_gyro_triad_scale_asymmetry_ppm: tuple[float, ...] = _scale_asymmetry("body gyro triad")
    free_gyro_triad_scale_asymmetry_sigma_ppm: float = _scale_asymmetry_sigma("body gyro triad")
    free_gyro_triad_misalignment_urad: tuple[float, ...] = _misalignment("body gyro triad")
    free_gyro_triad_misalignment_sigma_urad: float = _misalignment_sigma("body gyro triad")
    free_gyro_speed_m_s: float = param(0.0, "ship's speed over ground: it sails from the site at t = 0 on a rhumb "
        "line (0: stays at the site)", 0.0, 100.0, unit="m/s")
    free_gyro_course_deg: float = param(0.0, "ship's course, from north toward east", -360.0, 360.0, unit="deg")
    free_gyro_publish_velocity: bool = param(False, "publish the ship's NED ground velocity on /free_gyro/velocity "
        "(geometry_msgs/Vector3Stamped [m/s]) with each read-out")
    resolver_rate_hz: float = param(1000.0, "platform gimbal resolver output rate", 1e-3, 100000.0, unit="Hz")
    resolver_bits: int = param(19, "resolver-to-digital converter resolution (0: unquantised)",
        0, 30, unit="bits per turn")
    resolver_noise_arcsec: float = param(0.0, "resolver white readout noise RMS", 0.0, INF, unit="arcsec")
    resolver_velocity_gate_s: float = param(0.01, "gate of the resolver count-difference velocity",
        1e-9, INF, unit="s")
    resolver_cyclic_error_arcsec: float = param(0.0, "peak of the resolver converter's cyclic error, "
        "A sin(h theta + phase) per gimbal (paper 3's RDC: 10; 0: none)", 0.0, 3600.0, unit="arcsec")
    resolver_cyclic_harmonic: int = param(2, "harmonic h of the shaft angle that cyclic error repeats at "
        "(2: the windings' amplitude imbalance and quadrature error)", 1, 8)
    dtg_torquer_topic: str = param("/platform_servo/torquer_current", "dtg: the servo's torquer currents "
        "(JointState, effort [A] of dtg_torquer_x, _y, _z); each step waits for the currents stamped one step "
        "before, which the torquing electronics hold over the step")
    dtg_lat_deg: float = param(45.0, "dtg: the base's latitude, whose earth rate turns the n frame under the rotors; "
        "must equal vehicle_dynamics' profile_params lat_deg (the vehicle does not publish its position)",
        -89.999, 89.999, unit="deg")
    dtg_torquer_scale_deg_h_ma: float = param(72.0, "dtg: the torquers' true nominal scale factor (paper 3's own "
        "numbers: 4320 deg/h at 60 mA)", 1e-9, INF, unit="deg/h/mA")
    dtg_scale_error_ppm: tuple[float, ...] = param((0.0, 0.0, 0.0, 0.0), "dtg: torquer scale-factor error the "
        "servo does not know (lower x, y, upper x, y)", unit="ppm")
    dtg_drift_deg_h: tuple[float, ...] = param((0.0, 0.0, 0.0, 0.0), "dtg: fixed drift per sensitive axis (lower x, "
        "y, upper x, y)", unit="deg/h")
    dtg_drift_sigma_deg_h: float = param(0.03, "dtg: run-to-run drift 1-sigma per sensitive axis, drawn once per "
        "run and added (paper 3: 0.03)", 0.0, INF, unit="deg/h")
    dtg_arw_deg_rt_h: float = param(0.003, "dtg: the rotors' angle random walk", 0.0, INF, unit="deg/sqrt(h)")
    dtg_pickoff_noise_arcsec: float = param(0.0, "dtg: white pickoff read-out noise RMS", 0.0, INF, unit="arcsec")
    dtg_max_current_ma: float = param(200.0, "dtg: the torquing electronics' range +-", 1e-9, INF, unit="mA")


PARAMS, DESCRIPTION = declaration(SensorModelsNodeParams)
