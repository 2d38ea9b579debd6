"""The ``flexure_estimator`` node's parameter table and --help text, readable without ROS
(the node declares them; the config generator and the scenario checks read them). The
mapping to the core's parameters is :meth:`.flexure_kf.FlexureKfParams.from_values`.
"""
from __future__ import annotations

from gimbal_kinematics.params import CLOCK_JUMP_ALIASES, TIMING_PARAM, Param

from .flexure_kf import QS_MODELS

#: Attitude-matching methods (parameter ``model``): paper 5's simplified 18-state filter
#: (:mod:`.flexure_kf`) or the original eq. 1 filter it replaces (:mod:`.flexure_attitude_matching`).
METHODS = ("simplified", "original")

DESCRIPTION = (
    "Paper 5 ship angular-flexure Kalman filter: integrates the two LGUs' attitudes from "
    "their incremental angles, matches them (model simplified: Z = phi - A theta_d, 18 states; "
    "model original: paper 5 eq. 1, 27 states with each unit's attitude error and bias) "
    "with a random-constant or random-walk-rate quasi-static model, second-order Markov "
    "dynamic flexure and the bias difference; publishes the total flexure, its quasi-static "
    "and dynamic parts and the bias difference with 1-sigma companions on private topics."
)
INF = float("inf")

PARAMS = (
    TIMING_PARAM,
    Param("model", "simplified", "attitude matching: simplified (paper 5 eq. 5, 18 states) or original "
          "(paper 5 eq. 1, 27 states)", choices=METHODS),
    Param("quasi_static_model", "random_walk_rate", "quasi-static flexure model: random_constant (conventional) "
          "or random_walk_rate (paper 5 eq. 10)", choices=QS_MODELS),
    Param("lgu_rate_hz", 10.0, "LGU sample rate [Hz]; each sample's interval is 1/lgu_rate_hz", 1e-3, 100000.0),
    Param("sim_rate_hz", 1000.0, "simulation (lockstep) rate [Hz], for ~/progress; a multiple of lgu_rate_hz",
          1.0, 100000.0),
    Param("progress_every_steps", 10, "report on ~/progress (time of the next sample needed) when it has moved "
          "this many simulation steps; vehicle_dynamics paces on it", 1, 10**6),
    Param("wait_for_subscribers", 0, "matched subscriptions each output needs before ~/progress reports ready",
          0, 1000),
    Param("diagnostics_period_s", 1.0, "health, input counters and NIS on /diagnostics every this much stamp "
          "time [s] (free timing; lockstep publishes no /diagnostics)", 1e-3, 1e6),
    Param("nis_window", 100, "measurement updates in the NIS window on /diagnostics (free timing)", 1, 10**6),
    Param("publish_period_s", 0.0, "publish the estimate at most once per this period of stamps [s] "
          "(0: every filter step)", 0.0, 1e6),
    Param("filter_period_s", 0.1, "nominal Kalman step [s]; the filter steps once at least this has elapsed",
          1e-4, 100.0),
    Param("qs_initial_sigma_deg", 0.5, "prior 1-sigma of the quasi-static flexure [deg]", 1e-9, 90.0),
    Param("qs_rate_initial_sigma_deg_h", 10.0, "prior 1-sigma of its rate [deg/h] (random_walk_rate)", 0.0, INF),
    Param("qs_rate_rw_arcsec_s_rt_s", 1.0, "random walk of the quasi-static flexure rate [arcsec/s/sqrt(s)] "
          "(random_walk_rate)", 0.0, INF),
    Param("qs_rw_arcsec_rt_s", 0.001, "random walk of the quasi-static flexure [arcsec/sqrt(s)] "
          "(random_constant; small = constant)", 0.0, INF),
    Param("dynamic_rms_arcsec", [20.0, 60.0, 40.0], "dynamic flexure RMS (roll, pitch, yaw) [arcsec]"),
    Param("dynamic_beta_per_s", [0.2146, 0.2146, 0.2146], "dynamic flexure decay rate beta (roll, pitch, yaw) "
          "[1/s] (critically damped: 2.146 / correlation time)"),
    Param("dynamic_freq_rad_s", [0.0, 0.0, 0.0], "dynamic flexure damped frequency lambda (roll, pitch, yaw) "
          "[rad/s] (0: critically damped)"),
    Param("bias_diff_initial_sigma_deg_h", 0.1, "prior 1-sigma of the bias difference [deg/h]", 1e-12, INF),
    Param("bias_diff_rw_deg_h_rt_h", 0.001, "bias difference random walk [deg/h/sqrt(h)]", 0.0, INF),
    Param("lgu_bias_initial_sigma_deg_h", 0.0, "model original: prior 1-sigma of each LGU's bias [deg/h] "
          "(0: bias_diff_initial_sigma_deg_h / sqrt 2)", 0.0, INF),
    Param("lgu_bias_rw_deg_h_rt_h", 0.0, "model original: random walk of each LGU's bias [deg/h/sqrt(h)] "
          "(0: bias_diff_rw_deg_h_rt_h / sqrt 2)", 0.0, INF),
    Param("lgu_arw_deg_rt_h", 0.001, "angle random walk of each LGU [deg/sqrt(h)]", 0.0, INF),
    Param("meas_noise_arcsec", 1.0, "1-sigma of the attitude-matching measurement [arcsec]", 1e-9, INF),
    Param("second_order_observation", True, "predict Z to second order (BCH term) instead of the paper's H x"),
    Param("gate_probability", 0.99999, "chi-square gate probability (3 dof); 0 disables the gate", 0.0, 1.0),
    Param("max_gate_rejections", 200, "gated measurements in a row that re-anchor (then reset)", 1, 10**9),
    Param("max_gap_s", 5.0, "a data gap longer than this resets instead of re-anchoring [s]", 1e-3, 1e6),
    Param("clock_jump_s", 1.0, "a stamp this far behind the newest is a clock jump (reset) [s]", 1e-6, 1e9,
          aliases=CLOCK_JUMP_ALIASES),
)
