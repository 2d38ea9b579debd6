"""The ``flexure_estimator`` node's parameters and --help text, declared once in
:class:`FlexureEstimatorNodeParams`. The mapping to the core's parameters is
:meth:`.flexure_kf.FlexureKfParams.from_values`.
"""
from __future__ import annotations

from dataclasses import dataclass

from gimbal_kinematics.params.table import CLOCK_JUMP_ALIASES, SHARED, TimedParams, declaration, param, same_as

from .flexure_kf import QS_MODELS

#: Attitude-matching methods (parameter ``model``): paper 5's simplified 18-state filter
#: (:mod:`.flexure_kf`) or the original eq. 1 filter it replaces (:mod:`.flexure_attitude_matching`).
METHODS = ("simplified", "original")

INF = float("inf")


@dataclass(frozen=True)
class FlexureEstimatorNodeParams(TimedParams):
    """Paper 5 ship angular-flexure Kalman filter: integrates the two LGUs' attitudes from their incremental
    angles, matches them (model simplified: Z = phi - A theta_d, 18 states; model original: paper 5 eq. 1, 27
    states with each unit's attitude error and bias) with a random-constant or random-walk-rate quasi-static
    model, second-order Markov dynamic flexure and the bias difference; publishes the total flexure, its
    quasi-static and dynamic parts and the bias difference with 1-sigma companions on private topics.
    """

    model: str = param("simplified", "attitude matching: simplified (paper 5 eq. 5, 18 states) or original (paper 5 "
        "eq. 1, 27 states)", choices=METHODS)
    quasi_static_model: str = param("random_walk_rate", "quasi-static flexure model: random_constant (conventional) "
        "or random_walk_rate (paper 5 eq. 10)", choices=QS_MODELS)
    lgu_rate_hz: float = param(10.0, "LGU sample rate; each sample's interval is 1/lgu_rate_hz",
        1e-3, 100000.0, unit="Hz")
    sim_rate_hz: float = param(1000.0, "simulation (lockstep) rate, for ~/progress; a multiple of lgu_rate_hz",
        1.0, 100000.0, unit="Hz")
    progress_every_steps: int = param(10, "report on ~/progress (time of the next sample needed) when it has moved "
        "this many simulation steps; vehicle_dynamics paces on it", 1, 10**6)
    wait_for_subscribers: int = same_as(SHARED["wait_for_subscribers"])
    diagnostics_period_s: float = param(1.0, "health, input counters and NIS on /diagnostics every this much stamp "
        "time (free timing; lockstep publishes no /diagnostics)", 1e-3, 1e6, unit="s")
    nis_window: int = param(100, "measurement updates in the NIS window on /diagnostics (free timing)", 1, 10**6)
    publish_period_s: float = param(0.0, "publish the estimate at most once per this period of stamps (0: every "
        "filter step)", 0.0, 1e6, unit="s")
    filter_period_s: float = param(0.1, "nominal Kalman step; the filter steps once at least this has elapsed",
        1e-4, 100.0, unit="s")
    qs_initial_sigma_deg: float = param(0.5, "prior 1-sigma of the quasi-static flexure", 1e-9, 90.0, unit="deg")
    qs_rate_initial_sigma_deg_h: float = param(10.0, "prior 1-sigma of its rate (random_walk_rate)",
        0.0, INF, unit="deg/h")
    qs_rate_rw_arcsec_s_rt_s: float = param(1.0, "random walk of the quasi-static flexure rate (random_walk_rate)",
        0.0, INF, unit="arcsec/s/sqrt(s)")
    qs_rw_arcsec_rt_s: float = param(0.001, "random walk of the quasi-static flexure (random_constant; small = "
        "constant)", 0.0, INF, unit="arcsec/sqrt(s)")
    dynamic_rms_arcsec: tuple[float, ...] = param((20.0, 60.0, 40.0), "dynamic flexure RMS (roll, pitch, yaw)",
        unit="arcsec")
    dynamic_beta_per_s: tuple[float, ...] = param((0.2146, 0.2146, 0.2146), "dynamic flexure decay rate beta (roll, "
        "pitch, yaw) (critically damped: 2.146 / correlation time)", unit="1/s")
    dynamic_freq_rad_s: tuple[float, ...] = param((0.0, 0.0, 0.0), "dynamic flexure damped frequency lambda (roll, "
        "pitch, yaw) (0: critically damped)", unit="rad/s")
    bias_diff_initial_sigma_deg_h: float = param(0.1, "prior 1-sigma of the bias difference",
        1e-12, INF, unit="deg/h")
    bias_diff_rw_deg_h_rt_h: float = param(0.001, "bias difference random walk", 0.0, INF, unit="deg/h/sqrt(h)")
    lgu_bias_initial_sigma_deg_h: float = param(0.0, "model original: prior 1-sigma of each LGU's bias (0: "
        "bias_diff_initial_sigma_deg_h / sqrt 2)", 0.0, INF, unit="deg/h")
    lgu_bias_rw_deg_h_rt_h: float = param(0.0, "model original: random walk of each LGU's bias (0: "
        "bias_diff_rw_deg_h_rt_h / sqrt 2)", 0.0, INF, unit="deg/h/sqrt(h)")
    lgu_arw_deg_rt_h: float = param(0.001, "angle random walk of each LGU", 0.0, INF, unit="deg/sqrt(h)")
    meas_noise_arcsec: float = param(1.0, "1-sigma of the attitude-matching measurement", 1e-9, INF, unit="arcsec")
    second_order_observation: bool = param(True, "predict Z to second order (BCH term) instead of the paper's H x")
    gate_probability: float = param(0.99999, "chi-square gate probability (3 dof); 0 disables the gate", 0.0, 1.0,
        unit="-")
    max_gate_rejections: int = param(200, "gated measurements in a row that re-anchor (then reset)", 1, 10**9)
    max_gap_s: float = param(5.0, "a data gap longer than this resets instead of re-anchoring", 1e-3, 1e6, unit="s")
    clock_jump_s: float = param(1.0, "a stamp this far behind the newest is a clock jump (reset)",
        1e-6, 1e9, unit="s", aliases=CLOCK_JUMP_ALIASES)


PARAMS, DESCRIPTION = declaration(FlexureEstimatorNodeParams)
