"""Paper 3 experiment 3 (§4.3): the rotational INS navigates on a static base, no ROS.

The four-gimbal platform (``VehicleCore``, plant ``four_gimbal_platform``), its IMU and
resolvers (``SensorSuite``), :class:`gimbal_estimators.platform_navigator.PlatformNavigator`
and :class:`gimbal_control.platform_servo.PlatformServo` following the navigator's command
rate (``command_source="navigator"``) step in lockstep on the one no-ROS engine
(:func:`gimbal_sim.core.core_loop.run_stages` with :mod:`gimbal_sim.core.platform_stages`).
The Schuler loop closes through the platform: a velocity error changes the command, the
servo turns the stable element, the accelerometers sense the tilt.

Rate. Everything runs at ``rate_hz`` (default :data:`NAV_RATE_HZ` = 5 Hz: IMU, resolvers,
servo and navigator), with the servo's loops placed at rate/40 (0.125 Hz; the outer roll at
a third of it) and the plant stepped by
:meth:`~gimbal_sim.world.plant.platform_loops.PlatformAxis.step_quasi_static` (quasi-static
armature, implicit rate: RK4 needs a substep per 2 ms whatever the control rate, which
made a 3-hour run take many minutes). Why 5 Hz is enough: on a static base the servo only
has to follow the command rate (earth + transport rate, ~1e-4 rad/s, and the 1.2 °/s turn),
and its error (``control_*_arcsec``: the pickoff δ, measured per run and reported) stays at
arc-seconds, while a 100 µg accelerometer bias alone is 20″ of tilt; the Schuler period
(84 min) is 25,000 samples, a leg of the modulation (300 s) 1,500. The paper's 1 kHz loops
are the servo experiment's (:mod:`.platform_servo`), not needed for navigation. Below ~2 Hz
the sampled rotation itself leaks: at 1 Hz a north gyro drift leaves 28× more position
error after an hour with rotation on than at 2 Hz.

Start. ``rotation_on`` and ``rotation_off`` start perfectly aligned: platform level at
azimuth 0 over a base at heading 0, navigator at the site at rest with no estimates, so the
errors are those of the sensors alone. ``original_system`` and ``upgraded`` are paper 3's two
systems, each aligned by its own method (the static gyrocompass; the rotating alignment) in a
1 kHz prelude that the scenario chains (:mod:`.engine_runs`), then navigating from the plant
state, sensors and estimate it leaves, at paper 3's 1 kHz (the campaign's default systems) or
at the graph's :data:`HAND_OFF_RATE_HZ` (``*_50hz``).

The CEP campaign (:data:`CAMPAIGN`) is a declaration: its runs are scenario
``rotational_ins_navigation``'s (:data:`SCENARIO_VARIANTS`; this module's 5 Hz system is its
variants ``rotation_on_5hz`` and ``rotation_off_5hz``, ``platform_integrator: quasi_static``),
run on the one engine with their bags, and its table reads the runs' ``navigation`` reports.
Paper 5's moored ship is the scenario's ``ship_rotation_on`` / ``ship_rotation_off`` (1 kHz,
run only when named); :func:`run_navigation` keeps its own ship (``--ship``, 400 Hz) for the
rate studies.

Errors (truth is the site: a static base): north and east position error [m] from the
navigated latitude and longitude through the WGS-84 radii, radial = their norm; velocity
error = the navigated NED velocity. CEP rate: radial error at the end / duration, in n mile/h.

    python -m gimbal_sim.experiments.navigation run --duration 10800 --seed 1 --no-rotation
    gimbal-campaign rotational_ins_navigation --seeds 1-20 --out DIR      # the three systems' CEP50 table
    gimbal-campaign rotational_ins_navigation --variant rotation_on --variant rotation_off --seeds 1-20 --out DIR
    gimbal-campaign rotational_ins_navigation --variant ship_rotation_on --variant ship_rotation_off --seeds 1-10 --out DIR
    python -m gimbal_sim.experiments.navigation cep DIR [DIR...] --per-seed  # the table again, campaigns merged
    python -m gimbal_sim.experiments.navigation cep DIR --against BASE_DIR...  # each seed against its baseline run
    python -m gimbal_sim.experiments.navigation closed-forms            # the 3-hour closed-form figures
    python -m gimbal_sim.experiments.navigation servo-rate              # the servo at 1 kHz and at the graph's 50 Hz
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import math
import sys
from pathlib import Path
from typing import Any, NamedTuple, Sequence

import numpy as np
import yaml

from gimbal_control.platform_servo import BANDWIDTH_RATE_DIVISOR, PlatformServo, PlatformServoParams, \
    platform_pid_gains
from gimbal_control.platform_servo_params import PARAMS as SERVO_NODE_PARAMS
from gimbal_estimators.platform_navigator import HandOff, PlatformNavigator
from gimbal_estimators.platform_navigator_params import PlatformNavigatorParams
from gimbal_kinematics.maths.earth import meridian_radius, prime_vertical_radius
from gimbal_kinematics.maths.four_gimbal import platform_misalignment_enu
from gimbal_kinematics.maths.rotations import quat_to_dcm
from gimbal_kinematics.maths.units import ARCSEC, NMI_M, UG

from ..campaign.experiment import ExperimentCampaign, GraphEquivalent
from ..campaign.order_stats import quantile_interval
from ..campaign.parsing import parse_seeds
from ..campaign.results import read_results
from ..graph.scenario import load as load_scenario
from ..core.core_loop import node_values, run_stages
from ..core.platform_stages import navigator_stage, platform_sensor_stage, servo_stage
from ..world.sensor_suite import PAPER3_RESOLVER, SensorSuite, SensorSuiteConfig
from ..world.sensors import AccelerometerParams, EncoderParams, GyroParams
from ..world.vehicle import VehicleConfig, VehicleCore
from .platform_servo import ALIGNMENT_ACCEL_NOISE_UG_RT_HZ, ALIGNMENT_GYRO_ARW_DEG_RT_H, RATE_HZ as SERVO_RATE_HZ, \
    run_platform_servo

#: The navigation rate after a hand-off [Hz] (the graph scenario's): at 5 Hz
#: the servo's 0.125 Hz loops ring for minutes after the torque-out pulse (1000″ of azimuth
#: still 553″ at 30 s, then swinging ±800″ with a ~90 s period; spreading the pulse over
#: 300 s still leaves 66″ after 600 s), at 50 Hz the pulse leaves 0.3″ and 1″ after 20 s.
HAND_OFF_RATE_HZ = 50.0
#: IMU = resolver = servo = navigator rate of the navigation runs [Hz] (module docstring).
NAV_RATE_HZ = 5.0
#: :func:`run_navigation`'s moored ship (``--ship``): IMU, resolvers, servo and
#: plant at 400 Hz (the servo's loops at 10 Hz hold the platform against the ship's 6–15 s
#: motion to arc-seconds; at 200 Hz the pickoff rms is 29× larger), the navigator at 50 Hz on
#: the mean specific force of 8 samples and its azimuth from the servo's φz (module docstring).
SHIP_RATE_HZ = 400.0
SHIP_NAV_RATE_HZ = 50.0
#: Paper 3's sensor grades (run-to-run bias, 1σ per axis) and the white noise the alignment
#: experiment uses (:mod:`.platform_servo`: ``ALIGNMENT_*``).
PAPER3_NAV_GYRO = GyroParams(bias_sigma_deg_h=0.03, arw_deg_rt_h=ALIGNMENT_GYRO_ARW_DEG_RT_H)
PAPER3_NAV_ACCEL = AccelerometerParams(bias_sigma_ug=100.0, noise_ug_rt_hz=ALIGNMENT_ACCEL_NOISE_UG_RT_HZ)


class PlatformStart(NamedTuple):
    """Where a navigation run starts: the base heading [deg] and gimbal angles
    (θ_a, θ_q, θ_p, θ_r) [deg] the plant starts at (() = all zero), the navigator's hand-off
    (None: at the site, at rest, no estimates) and the base heading it adds to the azimuth
    resolver [deg] (after an alignment its −δφU)."""

    base_heading_deg: float = 0.0
    joints_deg: tuple[float, ...] = ()
    hand_off: HandOff | None = None
    heading_estimate_deg: float = 0.0
    torque_out_s: float = PlatformNavigatorParams().torque_out_s


def navigation_servo_params(lat_deg: float, rotate: bool, rate_hz: float = NAV_RATE_HZ,
                            nav_rate_hz: float | None = None) -> PlatformServoParams:
    """The servo at ``rate_hz`` following the navigator at ``nav_rate_hz`` (default the same):
    the Table 1 loops placed at rate/:data:`BANDWIDTH_RATE_DIVISOR` (the outer roll at a third,
    its D filtered over 5 samples, as the 1 kHz defaults), the gap limit at 2.5 samples, the
    stale-command limit at 2.5 navigator samples."""
    bw = rate_hz / BANDWIDTH_RATE_DIVISOR
    nav_rate_hz = rate_hz if nav_rate_hz is None else nav_rate_hz
    return PlatformServoParams(
        lat_deg=lat_deg, rotate=rotate, azimuth_pid=platform_pid_gains("a", bw),
        inner_roll_pid=platform_pid_gains("q", bw), pitch_pid=platform_pid_gains("p", bw),
        outer_roll_pid=platform_pid_gains("r", bw / 3.0, 5.0 / rate_hz), max_gap_s=2.5 / rate_hz,
        command_source="navigator", command_max_age_s=2.5 / nav_rate_hz)


def _samples_per_step(rate_hz: float, nav_rate_hz: float | None) -> int:
    """IMU samples per navigator step: ``rate_hz`` / ``nav_rate_hz`` (None: 1), an integer."""
    every = 1 if nav_rate_hz is None else int(round(rate_hz / nav_rate_hz))
    if nav_rate_hz is not None and (every < 1 or abs(every * nav_rate_hz - rate_hz) > 1e-9 * rate_hz):
        raise ValueError(f"nav_rate_hz {nav_rate_hz} must divide rate_hz {rate_hz}")
    return every


def run_navigation(duration_s: float = 10800.0, seed: int = 0, *, rotate: bool = True, rate_hz: float = NAV_RATE_HZ,
                   lat_deg: float = 40.0, gyro: GyroParams = PAPER3_NAV_GYRO, accel: AccelerometerParams = PAPER3_NAV_ACCEL,
                   resolver: EncoderParams = PAPER3_RESOLVER, record_every_s: float = 10.0,
                   ship: bool = False, start: PlatformStart | None = None, nav_rate_hz: float | None = None,
                   azimuth_source: str = "resolver") -> dict[str, Any]:
    """One navigation run (module docstring), on a static base or (``ship``) on paper 5's
    moored ship (roll 5° / 10 s, pitch 3° / 6 s, heading 3° / 15 s) whose motion enters each
    gimbal loop (``platform_base_motion``); ``start``: the platform and navigator after an
    alignment (static base only; default perfectly aligned). The navigator steps at
    ``nav_rate_hz`` (default ``rate_hz``, which it divides) on the mean specific force since its
    last step, its azimuth from ``azimuth_source`` (``resolver``; ``servo``: φz, a moving base).
    Returns its metrics and ``series`` (at the first navigator step from each multiple of
    ``record_every_s``: t, north/east/radial error [m], NED velocity [m/s], platform tilt (E, N)
    [rad] and azimuth from north about down [rad] from the truth, servo pickoff [rad], ψ̂ [rad])."""
    start = start if start is not None else PlatformStart()
    profile_params = {"lat_deg": lat_deg, **({"yaw_deg": start.base_heading_deg} if start.base_heading_deg else {})}
    core = VehicleCore(VehicleConfig(profile="paper5_ship" if ship else "static", profile_params=profile_params,
                                     plant="four_gimbal_platform", sim_rate_hz=rate_hz, duration_s=duration_s,
                                     platform_integrator="quasi_static", platform_base_motion=ship,
                                     initial_joints_deg=start.joints_deg))
    suite = SensorSuite(SensorSuiteConfig(sensors=("platform_imu", "resolvers"), sim_rate_hz=rate_hz, seed=seed,
                                          platform_imu_rate_hz=rate_hz, resolver_rate_hz=rate_hz,
                                          platform_gyro=gyro, platform_accel=accel, resolver=resolver))
    site = core.profile.site
    nav = PlatformNavigator(PlatformNavigatorParams(lat_deg=lat_deg, lon_deg=math.degrees(site.lon_rad),
                                                    height_m=site.height_m, base_heading_deg=start.heading_estimate_deg,
                                                    torque_out_s=start.torque_out_s, azimuth_source=azimuth_source))
    if start.hand_off is not None:
        nav.hand_off(start.hand_off)
    nav_every = _samples_per_step(rate_hz, nav_rate_hz)
    servo = PlatformServo(navigation_servo_params(lat_deg, rotate, rate_hz, nav_rate_hz))
    every = max(1, int(round(record_every_s * rate_hz)))
    rows: list[tuple[float, ...]] = []
    level = {"pickoff_sq": 0.0, "pickoff_max": 0.0, "inner_roll_max": 0.0, "n": 0, "biases": None, "next": 0}
    r_m = meridian_radius(site.lat_rad) + site.height_m
    r_n = (prime_vertical_radius(site.lat_rad) + site.height_m) * math.cos(site.lat_rad)

    def observe(bus) -> None:
        d = servo.pickoff
        p = math.hypot(d[0], d[1])
        level["pickoff_sq"] += p * p
        level["pickoff_max"] = max(level["pickoff_max"], p)
        level["inner_roll_max"] = max(level["inner_roll_max"], abs(bus.truth.joint_position[1]))
        level["n"] += 1
        if level["biases"] is None and bus.platform_imu is not None:
            level["biases"] = (bus.platform_imu.true_gyro_bias, bus.platform_imu.true_accel_bias)
        if bus.k >= level["next"] and bus.nav is not None:
            level["next"] += every
            C_ns = quat_to_dcm(bus.truth.quat_nm)
            tilt = platform_misalignment_enu(C_ns, bus.nav.azimuth)
            north = (nav.lat - site.lat_rad) * r_m
            east = math.remainder(nav.lon - site.lon_rad, math.tau) * r_n
            rows.append((bus.t, north, east, math.hypot(north, east), *bus.nav.velocity_n, tilt[0], tilt[1], p,
                         math.atan2(C_ns[1, 0], C_ns[0, 0]), bus.nav.azimuth))

    result = run_stages(core, [platform_sensor_stage(suite), navigator_stage(nav, rate_hz, nav_every), servo_stage(servo)],
                        observer=observe)
    s = np.array(rows)
    gyro_bias, accel_bias = level["biases"]
    return {
        "duration_s": duration_s, "seed": seed, "rotate": rotate, "rate_hz": rate_hz, "wall_s": result.wall_s,
        "cpu_s": result.cpu_s, "nav_rate_hz": rate_hz / nav_every, "azimuth_source": azimuth_source,
        "radial_error_m": float(s[-1, 3]), "north_error_m": float(s[-1, 1]), "east_error_m": float(s[-1, 2]),
        "max_radial_error_m": float(np.max(s[:, 3])),
        "azimuth_error_max_arcsec": float(np.max(np.abs(np.remainder(s[:, 11] - s[:, 10] + math.pi, math.tau)
                                                        - math.pi))) / ARCSEC,
        "max_horizontal_velocity_error_m_s": float(np.max(np.hypot(s[:, 4], s[:, 5]))),
        "radial_rate_nmi_h": float(s[-1, 3]) / NMI_M / (duration_s / 3600.0),
        "control_rms_arcsec": math.sqrt(level["pickoff_sq"] / level["n"]) / ARCSEC,
        "control_max_arcsec": level["pickoff_max"] / ARCSEC,
        "inner_roll_null_max_arcsec": level["inner_roll_max"] / ARCSEC,
        "gimbal_lock_events": servo.rejected_gimbal_lock, "held_commands": servo.held_commands,
        "stale_command_ticks": servo.stale_command_ticks, "ticks_without_command": servo.ticks_without_command,
        "navigator_rejected": nav.rejected_nonfinite + nav.rejected_no_resolver,
        "true_gyro_bias_deg_h": [math.degrees(v) * 3600.0 for v in gyro_bias],
        "true_accel_bias_ug": [v / UG for v in accel_bias],
        "series": {"t": s[:, 0], "north_m": s[:, 1], "east_m": s[:, 2], "radial_m": s[:, 3],
                   "velocity_ned_m_s": s[:, 4:7], "tilt_en_rad": s[:, 7:9], "pickoff_level_rad": s[:, 9],
                   "azimuth_true_rad": s[:, 10], "azimuth_estimate_rad": s[:, 11]},
    }


# ------------------------------------------------------------------------------ campaign
#: The CEP campaign's variants -> scenario ``rotational_ins_navigation``'s: paper 3's two systems
#: (each aligned by its own method in a 1 kHz prelude, then navigating at paper 3's 1 kHz) and
#: the upgraded one perfectly aligned (the default campaign); the same three at the graph's
#: 50 Hz (``*_50hz``), the same three with the servo on the DTG pair (``*_dtg``), the 5 Hz
#: stand-in system and the 50 Hz loop without rotation, when named.
SCENARIO_VARIANTS = {"original_system": "original_system_1khz", "upgraded": "upgraded_1khz",
                     "perfectly_aligned": "rotation_on_1khz",
                     "original_system_dtg": "original_system_dtg", "upgraded_dtg": "upgraded_dtg",
                     "perfectly_aligned_dtg": "dtg_1khz",
                     "original_system_50hz": "original_system", "upgraded_50hz": "upgraded",
                     "perfectly_aligned_50hz": "rotation_on",
                     "rotation_on": "rotation_on_5hz", "rotation_off": "rotation_off_5hz",
                     "rotation_off_50hz": "rotation_off",
                     "ship_rotation_on": "ship_rotation_on", "ship_rotation_off": "ship_rotation_off"}
#: Each variant -> whether its platform rotates.
VARIANTS = {"original_system": False, "upgraded": True, "perfectly_aligned": True,
            "original_system_dtg": False, "upgraded_dtg": True, "perfectly_aligned_dtg": True,
            "original_system_50hz": False, "upgraded_50hz": True, "perfectly_aligned_50hz": True, "rotation_on": True,
            "rotation_off": False, "rotation_off_50hz": False, "ship_rotation_on": True, "ship_rotation_off": False}


def navigation_translate(options: dict[str, Any]) -> tuple[float, tuple[tuple[str, Any], ...]]:
    """A :attr:`GraphEquivalent.translate`: the duration, and the latitude in the scenario's three nodes."""
    lat = options["lat_deg"]
    return options["duration_s"], (("vehicle_dynamics.profile_params", f"{{lat_deg: {lat!r}, lon_deg: 0.0}}"),
                                   ("platform_servo.lat_deg", lat), ("platform_navigator.lat_deg", lat))


def median_interval(values: Sequence[float], confidence: float = 0.95) -> tuple[float, float, float]:
    """(median, low, high): the sample median and the distribution-free interval of the true
    median from order statistics, [x_(j), x_(n+1−j)] (:func:`~..campaign.order_stats.quantile_interval`)."""
    med, lo, hi = quantile_interval(values, 0.5, confidence)
    if not (math.isfinite(lo) and math.isfinite(hi)):
        return med, -math.inf, math.inf
    return med, lo, hi


def cep_summary(runs: dict[str, list[dict]]) -> dict[str, Any]:
    """Per variant the CEP50 rate [n mile/h] at the runs' end (the median radial error over
    the duration) with its 95 % interval; for the variants a prelude aligned, the residual
    misalignment at hand-off (rms, and the azimuth's std as Table 2 gives it); the ratios
    original_system / upgraded and rotation_off / rotation_on (and the ship's). ``runs``:
    each variant's ``navigation`` metrics, of core runs (:func:`run_navigation`) or of graph
    runs (the ``navigation`` report: ``final_radial_rate_nmi_h``, no servo figures: None)."""
    out: dict[str, Any] = {}
    for variant, metrics in runs.items():
        med, lo, hi = median_interval([_rate(m) for m in metrics])
        core = all("control_rms_arcsec" in m for m in metrics)
        out[variant] = {"runs": len(metrics), "cep50_nmi_h": med, "cep50_ci95_nmi_h": [lo, hi],
                        "control_rms_arcsec_median": float(np.median([m["control_rms_arcsec"] for m in metrics]))
                        if core else None,
                        "control_max_arcsec": float(max(m["control_max_arcsec"] for m in metrics)) if core else None,
                        "inner_roll_null_max_arcsec": float(max(m["inner_roll_null_max_arcsec"] for m in metrics))
                        if core else None,
                        "gimbal_lock_events": int(sum(m["gimbal_lock_events"] for m in metrics)) if core else None}
        out[variant].update(experiment3_figures(metrics))
        if all("hand_off" in m for m in metrics):
            res = np.array([m["hand_off"]["residual_misalignment_arcsec"] for m in metrics])
            out[variant]["azimuth_under_1_arcmin"] = int(np.sum(np.abs(res[:, 2]) < 60.0))
            out[variant]["level_under_5_arcsec"] = int(np.sum(np.all(np.abs(res[:, :2]) < 5.0, axis=1)))
            out[variant]["hand_off_residual_rms_arcsec"] = [float(v) for v in np.sqrt(np.mean(res ** 2, axis=0))]
            out[variant]["azimuth_alignment_std_arcmin"] = float(np.std(res[:, 2], ddof=1)) / 60.0 \
                if len(res) > 1 else None
    for num, den, key in RATIOS:
        if num in out and den in out:
            out[key] = out[num]["cep50_nmi_h"] / out[den]["cep50_nmi_h"]
    return out


def experiment3_figures(metrics: Sequence[dict]) -> dict[str, Any]:
    """Paper 3's Experiment 3 figures over a variant's runs (graph-run ``navigation`` reports;
    none for the hand-built runs): the largest radial error of each run (median, least,
    largest, and how many stay under the paper's 2,200 m) and the largest horizontal velocity
    error of each run, the larger of north and east (median; the paper: about 0.6 m/s)."""
    if not all("max_radial_error_m" in m and "max_velocity_error_m_s" in m for m in metrics):
        return {}
    radial = np.array([m["max_radial_error_m"] for m in metrics])
    velocity = [max(m["max_velocity_error_m_s"]["north"], m["max_velocity_error_m_s"]["east"]) for m in metrics]
    return {"max_radial_error_m": [float(np.median(radial)), float(radial.min()), float(radial.max())],
            "max_radial_under_2200_m": int(np.sum(radial < 2200.0)),
            "max_velocity_error_m_s_median": float(np.median(velocity))}


#: The CEP ratios a summary carries when both variants ran: (numerator, denominator, key); the
#: scenario's own variant names are the ones a campaign run from its file records.
RATIOS = (("rotation_off", "rotation_on", "ratio_off_on"),
          ("original_system", "upgraded", "ratio_original_upgraded"),
          ("original_system_dtg", "upgraded_dtg", "ratio_original_upgraded_dtg"),
          ("original_system_50hz", "upgraded_50hz", "ratio_original_upgraded_50hz"),
          ("ship_rotation_off", "ship_rotation_on", "ship_ratio_off_on"),
          ("rotation_off_1khz", "rotation_on_1khz", "ratio_off_on_1khz"),
          ("original_system_1khz", "upgraded_1khz", "ratio_original_upgraded_1khz"),
          ("rotation_off_5hz", "rotation_on_5hz", "ratio_off_on_5hz"))


def ordered_variants(names) -> list[str]:
    """The variants among ``names``: :data:`VARIANTS`' first, in its order, then any other
    (a campaign run from the scenario's file records the scenario's variant names), sorted."""
    names = set(names)
    return [v for v in VARIANTS if v in names] + sorted(names - set(VARIANTS))


# ------------------------------------------------------------------------------ commands
#: The closed-form cases at 3 h (test_navigation_closed_forms checks shorter windows): one
#: error source each, no noise.
CLOSED_FORM_CASES = {"north_gyro_0.03deg_h": {"gyro": GyroParams(bias_deg_h=(0.03, 0.0, 0.0))},
                     "north_accel_100ug": {"accel": AccelerometerParams(bias_ug=(100.0, 0.0, 0.0))},
                     "vertical_gyro_0.03deg_h": {"gyro": GyroParams(bias_deg_h=(0.0, 0.0, 0.03))}}


def closed_form_figures(duration_s: float = 10800.0, rate_hz: float = NAV_RATE_HZ) -> dict[str, dict[str, float]]:
    """Per :data:`CLOSED_FORM_CASES` case the radial error at the end [m] with rotation off
    and on, and their ratio."""
    out = {}
    for name, sensors in CLOSED_FORM_CASES.items():
        r = {}
        for rotate in (False, True):
            kw = {"gyro": GyroParams(), "accel": AccelerometerParams(), **sensors}
            r[rotate] = run_navigation(duration_s, 0, rotate=rotate, rate_hz=rate_hz, resolver=EncoderParams(),
                                       record_every_s=60.0, **kw)["radial_error_m"]
        out[name] = {"rotation_off_m": r[False], "rotation_on_m": r[True], "off_over_on": r[False] / r[True]}
    return out


def cep_table(runs: dict[str, list[dict]]) -> str:
    """:data:`CAMPAIGN`'s own table, which ``gimbal-campaign`` prints and its report carries:
    :func:`cep_summary` of each variant's runs' ``metrics.json`` (core or graph runs)."""
    return _campaign_table(cep_summary({v: [run_navigation_metrics(m) for m in ms] for v, ms in runs.items()}))


def run_navigation_metrics(metrics: dict) -> dict:
    """A run's ``navigation`` metrics, with its report's ``hand_off`` figures when a prelude
    aligned it."""
    return {**metrics["navigation"], **({"hand_off": metrics["hand_off"]} if "hand_off" in metrics else {})}


def _cell(value: float | int | None, width: int, spec: str) -> str:
    return f"{'-':>{width}}" if value is None else f"{value:>{width}{spec}}"


#: ``servo-rate``: run_platform_servo's figure -> its row in the table.
SERVO_RATE_ROWS = {"steady_rms_error_arcsec": "azimuth error e_a, steady rms [″]",
                   "steady_max_error_arcsec": "azimuth error e_a, steady max [″]",
                   "reversal_max_error_arcsec": "azimuth error at the reversal, max [″]",
                   "steady_max_level_error_arcsec": "level error (truth tilts), steady max [″]",
                   "steady_max_pickoff_arcsec": "gyro pickoff, steady max [″]"}


def servo_rate_figures(duration_s: float = 320.0, seed: int = 1,
                       scenario: str = "rotational_ins_navigation") -> dict[str, dict[str, float]]:
    """The servo alone on the static base (rotation on, its internal earth-rate command), at
    paper 3's 1 kHz with the ``platform_servo`` node's default loops and the plant's default
    substeps, and at the rate, loop bandwidths and plant substeps the graph ``scenario`` sets
    (read from it); the same seed, sensors and latitude. Per case (label) the
    :data:`SERVO_RATE_ROWS` figures of :func:`~.platform_servo.run_platform_servo`."""
    values = node_values(load_scenario(scenario))
    servo = next(v for exe, v in values.values() if exe == "platform_servo")
    vehicle = next(v for exe, v in values.values() if exe == "vehicle_dynamics")
    defaults = {p.name: p.default for p in SERVO_NODE_PARAMS}
    cases = ((SERVO_RATE_HZ, None, {**defaults, "lat_deg": servo["lat_deg"]}),
             (vehicle["sim_rate_hz"], vehicle["platform_substeps"], servo))
    out = {}
    for rate, substeps, v in cases:
        v = {**v, "command_source": "internal", "rotation": "bidirectional"}
        m = run_platform_servo(duration_s, seed, params=PlatformServoParams.from_values(v), rate_hz=rate,
                               substeps=substeps, record_every=10**9)
        label = (f"{rate:g} Hz, {v['azimuth_bandwidth_hz']:g}/{v['level_bandwidth_hz']:g}/"
                 f"{v['outer_roll_bandwidth_hz']:g} Hz, {substeps or VehicleConfig.platform_substeps} substeps")
        out[label] = {key: float(m[key]) for key in SERVO_RATE_ROWS}
    return out


#: The paper's azimuth alignment accuracy beside each aligned variant's.
PAPER_AZIMUTH = {"original_system": "paper 3: 9′, the original system", "upgraded": "paper 3: 1.5′ Table 2, < 1′ Exp. 3"}
PAPER_AZIMUTH.update({f"{v}_50hz": text for v, text in PAPER_AZIMUTH.items()})


def _hand_off_row(v: str, s: dict[str, Any]) -> str:
    e, n, u = s["hand_off_residual_rms_arcsec"]
    return (f"{v}: residual misalignment at hand-off (truth − estimate), rms over runs: "
            f"E {e:.2f}″, N {n:.2f}″, U {u:.1f}″ = {u / 60.0:.2f}′ "
            f"(std {_cell(s['azimuth_alignment_std_arcmin'], 0, '.2f').strip()}′; "
            f"{PAPER_AZIMUTH.get(v, 'paper 3: -')}); azimuth under 1′ in {s['azimuth_under_1_arcmin']} "
            f"of {s['runs']} runs, both level angles under 5″ in {s['level_under_5_arcsec']} "
            f"(paper 3, Exp. 3: < 1′ and < 5″)")


def _experiment3_row(v: str, s: dict[str, Any]) -> str:
    med, lo, hi = s["max_radial_error_m"]
    return (f"{v}: largest radial error of a run, median {med:.0f} m [{lo:.0f}, {hi:.0f}], under "
            f"2,200 m in {s['max_radial_under_2200_m']} of {s['runs']} runs; largest horizontal velocity "
            f"error, median {s['max_velocity_error_m_s_median']:.2f} m/s (paper 3, Exp. 3: < 2,200 m, about 0.6 m/s)")


def _campaign_table(summary: dict[str, Any]) -> str:
    rows = ["CEP50 at the end of the runs: the median radial error / duration, with the 95 % interval of the "
            "median (paper 3: 0.38 n mile/h rotating, 2 n mile/h not)",
            f"{'variant':<19} {'runs':>4} {'CEP50 [n mile/h]':>17} {'95 % interval':>20} {'control rms [″]':>16} "
            f"{'control max [″]':>16} {'null max [″]':>13} {'lock':>5}"]
    variants = ordered_variants(v for v, s in summary.items() if isinstance(s, dict))
    for v in variants:
        s = summary[v]
        lo, hi = s["cep50_ci95_nmi_h"]
        interval = f"[{lo:.3f}, {hi:.3f}]" if math.isfinite(lo) else "none under 6 runs"
        rows.append(f"{v:<19} {s['runs']:>4} {s['cep50_nmi_h']:>17.3f} {interval:>20} "
                    f"{_cell(s['control_rms_arcsec_median'], 16, '.2f')} {_cell(s['control_max_arcsec'], 16, '.2f')} "
                    f"{_cell(s['inner_roll_null_max_arcsec'], 13, '.1f')} {_cell(s['gimbal_lock_events'], 5, 'd')}")
    rows += [_hand_off_row(v, summary[v]) for v in variants if "hand_off_residual_rms_arcsec" in summary[v]]
    rows += [_experiment3_row(v, summary[v]) for v in variants if "max_radial_error_m" in summary[v]]
    for num, den, key in RATIOS:
        if key in summary:
            paper = "'improved by almost 5 times'" if num.startswith("original_system") else "about 5×"
            rows.append(f"ratio {num} / {den}: {summary[key]:.2f}   (paper 3: 2 / 0.38 = 5.3, {paper})")
    return "\n".join(rows)


#: ``gimbal-campaign rotational_ins_navigation --seeds 1-20``, a declaration: scenario
#: ``rotational_ins_navigation``'s variants (:data:`SCENARIO_VARIANTS`) on the one engine (each
#: run's bag and ``navigation`` report) or in the node graph (``--engine graph``); the CEP table
#: reads the runs' reports.
CAMPAIGN = ExperimentCampaign(
    name="rotational_ins_navigation", variants=tuple(SCENARIO_VARIANTS),
    default_variants=("original_system", "upgraded", "perfectly_aligned"),
    defaults={"duration_s": 10800.0, "lat_deg": 40.0}, run=None,
    graph=GraphEquivalent("rotational_ins_navigation", SCENARIO_VARIANTS, ("duration_s", "lat_deg"),
                          navigation_translate),
    table=cep_table)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m gimbal_sim.experiments.navigation",
                                     description="Paper 3 navigation on a static base, no ROS (module docstring).")
    sub = parser.add_subparsers(dest="what", required=True)
    one = sub.add_parser("run", help="one run's figures")
    one.add_argument("--duration", type=float, default=10800.0)
    one.add_argument("--seed", type=int, default=1)
    one.add_argument("--rate", type=float, default=NAV_RATE_HZ, help="IMU/servo/navigator rate [Hz]")
    one.add_argument("--no-rotation", action="store_true")
    one.add_argument("--ship", action="store_true", help="paper 5's moored ship instead of the static base")
    one.add_argument("--nav-rate", type=float, default=None, help="navigator rate [Hz], dividing --rate (default: --rate)")
    one.add_argument("--azimuth-source", choices=("resolver", "servo"), default="resolver",
                     help="the navigator's azimuth: resolver + fixed base heading, or the servo's phi_z (moving base)")
    one.add_argument("--gyro-arw", type=float, default=ALIGNMENT_GYRO_ARW_DEG_RT_H,
                     help="platform gyro angle random walk [deg/sqrt(h)] (default: the scenarios')")
    one.add_argument("--accel-noise", type=float, default=ALIGNMENT_ACCEL_NOISE_UG_RT_HZ,
                     help="platform accelerometer noise density [micro-g/sqrt(Hz)] (default: the scenarios')")
    cep = sub.add_parser("cep", help="the CEP table of a finished campaign directory (gimbal-campaign "
                                     "rotational_ins_navigation --seeds 1-20 --out DIR)")
    cep.add_argument("campaign_dir", nargs="+", help="one or more campaign directories, their runs merged")
    cep.add_argument("--per-seed", action="store_true",
                     help="also each seed's radial rate per variant (seeds pair runs: same sensor biases)")
    cep.add_argument("--seeds", help="only these seeds' runs, e.g. 1-10 or 1,3,5 (default: every run)")
    cep.add_argument("--against", nargs="+", metavar="BASE_DIR",
                     help="baseline campaign directories: each run's change against the baseline run of the same "
                          "scenario variant and seed (a study that changes one setting)")
    cf = sub.add_parser("closed-forms", help="one error source at a time, rotation off and on, radial error at the end")
    cf.add_argument("--duration", type=float, default=10800.0)
    cf.add_argument("--rate", type=float, default=NAV_RATE_HZ)
    rates = sub.add_parser("servo-rate", help="the servo alone at 1 kHz and at the graph scenario's rate, gains and "
                                              "plant substeps: control-error table")
    rates.add_argument("--duration", type=float, default=320.0, help="simulated seconds (default 320: one reversal)")
    rates.add_argument("--seed", type=int, default=1)
    args = parser.parse_args(argv)
    if args.what == "servo-rate":
        figures = servo_rate_figures(args.duration, args.seed)
        print(f"{'':42s}" + "".join(f"{label:>38s}" for label in figures))
        for key, row in SERVO_RATE_ROWS.items():
            print(f"{row:42s}" + "".join(f"{f[key]:>38.2f}" for f in figures.values()))
        return 0
    if args.what == "run":
        try:
            gyro = dataclasses.replace(PAPER3_NAV_GYRO, arw_deg_rt_h=args.gyro_arw)
            accel = dataclasses.replace(PAPER3_NAV_ACCEL, noise_ug_rt_hz=args.accel_noise)
        except ValueError as exc:
            parser.error(f"--gyro-arw/--accel-noise: {exc}")
        m = run_navigation(args.duration, args.seed, rotate=not args.no_rotation, rate_hz=args.rate, ship=args.ship,
                           nav_rate_hz=args.nav_rate, azimuth_source=args.azimuth_source, gyro=gyro, accel=accel)
        for key, value in m.items():
            if key != "series":
                print(f"{key:36s} {value}")
        return 0
    if args.what == "closed-forms":
        for name, r in closed_form_figures(args.duration, args.rate).items():
            print(f"{name:26s} off {r['rotation_off_m']:10.1f} m   on {r['rotation_on_m']:10.1f} m   "
                  f"off/on {r['off_over_on']:8.2f}")
        return 0
    return _cep_command(args.campaign_dir, args.per_seed, args.against or (), args.seeds)


def _cep_command(campaign_dirs: Sequence[str], per_seed: bool, against: Sequence[str] = (),
                 seeds: str | None = None) -> int:
    try:
        runs, base = _campaign_runs(campaign_dirs), (_campaign_runs(against) if against else {})
        if seeds is not None:
            chosen = set(parse_seeds(seeds))
            runs = {v: kept for v, ms in runs.items() if (kept := [m for m in ms if m["seed"] in chosen])}
    except ValueError as exc:  # a CampaignError too: a malformed --seeds
        print(f"navigation cep: {exc}", file=sys.stderr)
        return 2
    if not runs or (against and not base):
        dirs = ", ".join(campaign_dirs if not runs else against)
        print(f"navigation cep: {dirs}: no finished run with a navigation report", file=sys.stderr)
        return 1
    print(_campaign_table(cep_summary(runs)))
    if per_seed:
        variants = ordered_variants(runs)
        rates = {v: {m["seed"]: _rate(m) for m in runs[v]} for v in variants}
        print("radial rate at the end [n mile/h] per seed\nseed " + " ".join(f"{v:>19}" for v in variants))
        for seed in sorted({seed for r in rates.values() for seed in r}):
            print(f"{seed:>4} " + " ".join(f"{rates[v][seed]:>19.3f}" if seed in rates[v] else f"{'-':>19}"
                                           for v in variants))
    if against:
        print(change_table(runs, base))
    return 0


def _rate(m: dict) -> float:
    return m.get("radial_rate_nmi_h", m.get("final_radial_rate_nmi_h"))


def _campaign_runs(campaign_dirs: Sequence[str]) -> dict[str, list[dict]]:
    """Each variant's finished runs' ``navigation`` metrics (with the seed and the scenario
    variant they ran: an experiment campaign's names mapped by :data:`SCENARIO_VARIANTS`),
    the campaigns merged. ValueError names a directory that is not a finished campaign."""
    runs: dict[str, list[dict]] = {}
    for campaign_dir in map(Path, campaign_dirs):
        try:
            rows = read_results(campaign_dir)
            asked = (yaml.safe_load((campaign_dir / "campaign.yaml").read_text()) or {}).get("campaign", {})
        except (OSError, ValueError, yaml.YAMLError) as exc:
            raise ValueError(f"{campaign_dir}: not a finished campaign directory ({exc})") from None
        names = SCENARIO_VARIANTS if asked.get("experiment") else {}
        for row in rows:
            path = campaign_dir / "runs" / row["run_id"] / "report" / "metrics.json"
            if row["status"] == "ok" and path.is_file():
                m = run_navigation_metrics(json.loads(path.read_text()))
                scenario_variant = names.get(row["variant"], row["variant"])
                runs.setdefault(row["variant"], []).append({**m, "seed": int(row["seed"]),
                                                            "scenario_variant": scenario_variant})
    return runs


def change_table(runs: dict[str, list[dict]], base: dict[str, list[dict]]) -> str:
    """Each variant's per-seed change of the radial rate against the baseline run of the same
    scenario variant and seed (a paired design: the same sensors, one setting changed): the
    median change, the median of its size and how many seeds got worse."""
    by_key = {(m["scenario_variant"], m["seed"]): _rate(m) for ms in base.values() for m in ms}
    rows = ["per-seed change of the radial rate against the baseline's run of the same scenario variant and seed",
            f"{'variant':<19} {'pairs':>5} {'median change':>14} {'median size':>12} {'worse':>6}"]
    for v in ordered_variants(runs):
        d = np.array([_rate(m) - by_key[(m["scenario_variant"], m["seed"])] for m in runs[v]
                      if (m["scenario_variant"], m["seed"]) in by_key])
        if d.size:
            rows.append(f"{v:<19} {d.size:>5} {np.median(d):>+14.3f} {np.median(np.abs(d)):>12.3f} "
                        f"{int(np.sum(d > 0)):>3}/{d.size:<2}")
        else:
            rows.append(f"{v:<19} {0:>5}  no baseline run of its scenario variant and seeds")
    return "\n".join(rows)


if __name__ == "__main__":
    sys.exit(main())
