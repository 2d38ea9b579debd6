"""The ``sensor_models`` node's parameter table and --help text, readable without ROS (the
node declares them; the config generator and the scenario checks read them). The mapping to
the suite's config is :meth:`..world.sensor_suite.SensorSuiteConfig.from_values`.
"""
from __future__ import annotations

import math

from gimbal_kinematics.params import Param

from ..world.sensor_suite import SENSORS

DESCRIPTION = (
    "Sensor models: subscribes to the vehicle's truth topics and publishes the INS, the "
    "two-axis gimbal gyro, the encoders, the paper 5 LGUs, the paper 3 platform IMU and gimbal resolvers and "
    "the paper 4 free gyros, each at its own rate with the papers' error models, plus the error truth (biases, "
    "flexure, the ship's position)."
)
INF = math.inf

PARAMS = (
    Param("sensors", ["ins", "gimbal_gyro", "encoders"], f"enabled sensors, any of {list(SENSORS)}"),
    Param("sim_rate_hz", 1000.0, "simulation rate [Hz]; must equal vehicle_dynamics'", 1.0, 100000.0),
    Param("seed", 0, "seed of every sensor's random stream", 0, 2**31 - 1),
    Param("progress_every_steps", 10, "report on ~/progress (time of the next step needed) every N steps; "
          "vehicle_dynamics waits for and paces on it", 1, 10**6),
    Param("wait_for_subscribers", 0, "matched subscriptions each output needs before ~/progress reports ready",
          0, 1000),
    Param("subscriber_counts", [], "per-topic overrides of wait_for_subscribers, as '/topic=count' entries "
          "(a real-time scenario: its free-timing readers announce no readiness)", array_type="string_array"),
    Param("ins_rate_hz", 100.0, "INS output rate [Hz]", 1e-3, 100000.0),
    Param("gimbal_gyro_rate_hz", 1000.0, "gimbal gyro output rate [Hz]", 1e-3, 100000.0),
    Param("encoder_rate_hz", 1000.0, "encoder output rate [Hz]", 1e-3, 100000.0),
    Param("lgu_rate_hz", 100.0, "LGU output rate [Hz]", 1e-3, 100000.0),
    Param("platform_imu_rate_hz", 100.0, "platform IMU output rate [Hz]", 1e-3, 100000.0),
    Param("gimbal_gyro_bias_deg_h", [100.0, 100.0], "gimbal gyro fixed bias (q_m, r_m) [deg/h]"),
    Param("gimbal_gyro_bias_sigma_deg_h", 0.0, "gimbal gyro run-to-run bias 1-sigma [deg/h]", 0.0, INF),
    Param("gimbal_gyro_arw_deg_rt_h", 0.15, "gimbal gyro angle random walk [deg/sqrt(h)]", 0.0, INF),
    Param("gimbal_gyro_bi_deg_h", 30.0, "gimbal gyro Gauss-Markov bias instability RMS [deg/h]", 0.0, INF),
    Param("gimbal_gyro_bi_tau_s", 100.0, "its correlation time [s] (inf: random constant)", 1e-9, INF),
    Param("gimbal_gyro_rrw_deg_h_rt_h", 0.0, "gimbal gyro rate random walk [deg/h/sqrt(h)]", 0.0, INF),
    Param("gimbal_gyro_quantum_deg", 0.0, "gimbal gyro incremental-angle quantum (LSB) [deg] (0: none); IEEE 952 "
          "quantisation noise Q = quantum / sqrt(12)", 0.0, INF),
    Param("gimbal_gyro_scale_factor_ppm", [0.0, 0.0], "gimbal gyro scale-factor error (q_m, r_m) [ppm]"),
    Param("gimbal_gyro_range_deg_s", 0.0, "gimbal gyro measurement range +-[deg/s] (0: unlimited)", 0.0, INF),
    Param("ins_roll_pitch_rms_deg", 0.05, "INS roll/pitch error RMS [deg]", 0.0, INF),
    Param("ins_heading_rms_deg", 0.2, "INS heading error RMS [deg]", 0.0, INF),
    Param("ins_attitude_tau_s", 300.0, "INS attitude error correlation time [s]", 1e-9, INF),
    Param("ins_gyro_bias_sigma_deg_h", 1.0, "INS gyro run-to-run bias 1-sigma [deg/h]", 0.0, INF),
    Param("ins_gyro_bi_deg_h", 1.0, "INS gyro Gauss-Markov bias RMS [deg/h]", 0.0, INF),
    Param("ins_gyro_bi_tau_s", 60.0, "its correlation time [s]", 1e-9, INF),
    Param("ins_gyro_arw_deg_rt_h", 0.1, "INS gyro angle random walk [deg/sqrt(h)]", 0.0, INF),
    Param("ins_gyro_rrw_deg_h_rt_h", 0.0, "INS gyro rate random walk [deg/h/sqrt(h)]", 0.0, INF),
    Param("ins_gyro_quantum_deg", 0.0, "INS gyro incremental-angle quantum (LSB) [deg] (0: none); IEEE 952 "
          "quantisation noise Q = quantum / sqrt(12)", 0.0, INF),
    Param("encoder_noise_deg", 0.05, "encoder angle noise RMS [deg]", 0.0, INF),
    Param("encoder_lines_per_rev", 0, "encoder lines per revolution (0: no quantisation)", 0, 10**9),
    Param("encoder_quadrature", 1, "edges counted per line (1, 2 or 4)", 1, 4),
    Param("encoder_velocity_gate_s", 0.01, "pulse-counting gate time of the encoder rate [s]", 1e-9, INF),
    Param("lgu1_bias_deg_h", 0.05, "LGU1 fixed bias [deg/h]"),
    Param("lgu2_bias_deg_h", -0.05, "LGU2 fixed bias [deg/h]"),
    Param("lgu_arw_deg_rt_h", 0.001, "LGU angle random walk [deg/sqrt(h)]", 0.0, INF),
    Param("flexure_initial_deg", 0.1, "quasi-static flexure at t0, each axis [deg]"),
    Param("flexure_linear_rate_deg_h", 0.2, "quasi-static linear flexure rate [deg/h]"),
    Param("flexure_slow_amplitude_arcsec", 90.0, "slow sinusoidal flexure amplitude [arcsec]", 0.0, INF),
    Param("flexure_slow_period_s", 3600.0, "its period [s]", 1e-9, INF),
    Param("flexure_helm_amplitude_deg", 0.1, "helm-induced flexure amplitude [deg]", 0.0, INF),
    Param("flexure_helm_period_s", 200.0, "its period [s]", 1e-9, INF),
    Param("flexure_dynamic_rms_arcsec", [20.0, 60.0, 40.0], "dynamic flexure RMS (roll, pitch, yaw) [arcsec]"),
    Param("flexure_dynamic_beta_per_s", [0.2146, 0.2146, 0.2146], "dynamic flexure 2nd-order Markov decay "
          "rate beta (roll, pitch, yaw) [1/s], > 0; critically damped: 2.146 / (1/e correlation time), "
          "default 10 s; paper 5 gives none (docs/results/paper5.md: the dynamic-flexure band)"),
    Param("flexure_dynamic_freq_rad_s", [0.0, 0.0, 0.0], "dynamic flexure damped frequency lambda (roll, pitch, "
          "yaw) [rad/s], >= 0; 0 (default): the textbook critically damped 2nd-order Markov, > 0: a band "
          "peaked at lambda (sea waves)"),
    Param("platform_gyro_bias_sigma_deg_h", 0.03, "platform gyro run-to-run bias 1-sigma [deg/h]", 0.0, INF),
    Param("platform_gyro_arw_deg_rt_h", 0.003, "platform gyro angle random walk [deg/sqrt(h)]", 0.0, INF),
    Param("platform_accel_bias_sigma_ug", 100.0, "platform accelerometer bias 1-sigma [micro-g]", 0.0, INF),
    Param("platform_accel_noise_ug_rt_hz", 50.0, "platform accelerometer noise density [micro-g/sqrt(Hz)]", 0.0, INF),
    Param("free_gyro_rate_hz", 10.0, "free-gyro read-out rate (spin axes, triad, vertical reference) [Hz]",
          1e-3, 100000.0),
    Param("free_gyro_site_lat_deg", 35.0, "ship's true geodetic latitude [deg]; must equal vehicle_dynamics' "
          "profile_params lat_deg (the vehicle does not publish its position)", -90.0, 90.0),
    Param("free_gyro_site_lon_deg", 129.0, "ship's true longitude [deg]; must equal vehicle_dynamics' "
          "profile_params lon_deg", -180.0, 180.0),
    Param("free_gyro_nadir_deg", [60.0, 50.0], "nadir angles (gyro a, gyro b) the spin axes are set to at the "
          "ship's site at t = 0 [deg], each in (0, 180)"),
    Param("free_gyro_azimuth_deg", [-40.0, 50.0], "azimuths from north toward east (gyro a, gyro b) of the spin "
          "axes at the site at t = 0 [deg]; fix geometry FDOP = sqrt(2)/|sin(difference)|"),
    Param("free_gyro_pickoff_noise_arcsec", 5.0, "spin-axis pickoff white noise per axis, per sample [arcsec]",
          0.0, INF),
    Param("free_gyro_spin_drift_sigma_deg_h", 0.0, "spin-axis random-constant drift 1-sigma per axis [deg/h] "
          "(0: ideal free gyro)", 0.0, INF),
    Param("free_gyro_level_noise_arcsec", 0.0, "vertical reference roll/pitch white noise [arcsec]", 0.0, INF),
    Param("free_gyro_level_bias_arcsec", [0.0, 0.0], "vertical reference fixed (roll, pitch) error [arcsec]"),
    Param("free_gyro_triad_arw_deg_rt_h", 0.002, "body gyro triad angle random walk [deg/sqrt(h)]", 0.0, INF),
    Param("free_gyro_triad_bias_deg_h", [0.0, 0.0, 0.0], "body gyro triad fixed bias (x, y, z) [deg/h]"),
    Param("free_gyro_triad_bias_sigma_deg_h", 0.0, "body gyro triad run-to-run bias 1-sigma [deg/h]", 0.0, INF),
    Param("free_gyro_speed_m_s", 0.0, "ship's speed over ground [m/s]: it sails from the site at t = 0 on a rhumb "
          "line (0: stays at the site)", 0.0, 100.0),
    Param("free_gyro_course_deg", 0.0, "ship's course [deg from north toward east]", -360.0, 360.0),
    Param("free_gyro_publish_velocity", False, "publish the ship's NED ground velocity on /free_gyro/velocity "
          "(geometry_msgs/Vector3Stamped [m/s]) with each read-out"),
    Param("resolver_rate_hz", 1000.0, "platform gimbal resolver output rate [Hz]", 1e-3, 100000.0),
    Param("resolver_bits", 19, "resolver-to-digital converter resolution [bits per turn] (0: unquantised)", 0, 30),
    Param("resolver_noise_arcsec", 0.0, "resolver white readout noise RMS [arcsec]", 0.0, INF),
    Param("resolver_velocity_gate_s", 0.01, "gate of the resolver count-difference velocity [s]", 1e-9, INF),
)
