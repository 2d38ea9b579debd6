"""Closed-loop paper 3 experiments:
:class:`gimbal_control.platform_servo.PlatformServo` on gimbal_sim's four-gimbal platform on
a static base (docs/spec.md §3.3), alone (its figures from the one engine's loop,
:func:`gimbal_sim.core.core_loop.run_stages`, with an observer) and carrying the
rotation-modulated alignment: the Table 2 campaign is a declaration (:data:`CAMPAIGN`),
scenario ``rotational_ins_alignment``'s runs on the engine (each with its bag and
``alignment`` report) or in the node graph, its table read from the runs' reports::

    python -m gimbal_sim.experiments.platform_servo alignment --seeds 1 2 3 4 5 6
    python -m gimbal_sim.experiments.platform_servo servo --duration 320

Plant and sensors. gimbal_sim's platform (``VehicleConfig(plant='four_gimbal_platform')``)
is the four-gimbal chain, one DC-motor loop per joint, driven by the four gimbal motor
voltages; the servo reads the joint angles from the ``resolvers`` sensor (19-bit
converters, paper 3 §3). The graph runs the same pieces: ``vehicle_dynamics`` +
``sensor_models`` + the ``platform_servo`` node.

Sensors: the platform gyro triad of gimbal_sim's SensorSuite (``platform_imu``, paper 3
DTG grade: 0.03 °/h run-to-run bias, 0.003 °/√h ARW) at 1 kHz, with no drift
compensation.

Control errors (truth, radians):

* ``azimuth``: e_a = θ_a − φz(t), the azimuth gimbal angle (the platform azimuth on the
  level base at heading 0) minus the commanded modulation angle schedule;
* ``level``: the inner-roll and pitch gimbal angles θ_q and θ_p (the platform's tilts);
* the sensed error (the pickoff angles) is reported too.

Steady rotation means t >= ``settle_s`` and outside [t_k, t_k + ``transient_window_s``]
around every reversal t_k. The reversal transient is the largest |e_a| inside those windows.
Torque current: the azimuth motor armature current, effort/k_t.
"""
from __future__ import annotations

import argparse
import dataclasses
import math
import sys
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from gimbal_control.platform_servo import PlatformServo, PlatformServoParams
from gimbal_kinematics.maths.four_gimbal import gimbal_angles_from_dcm
from gimbal_kinematics.maths.rotations import dcm_from_rotation_vector, euler321_to_dcm
from gimbal_kinematics.maths.units import ARCSEC

from ..world.plant import paper3_axis_params
from ..world.sensor_suite import PAPER3_RESOLVER, SensorSuite, SensorSuiteConfig
from ..world.vehicle import VehicleConfig, VehicleCore
from ..core.core_loop import run_stages
from ..graph.scenario import load as load_scenario
from ..core.platform_stages import platform_sensor_stage, servo_stage
from ..reports.alignment import column_stats
from .engine_runs import run_on_engine
from ..campaign.spec import CampaignSpec
from ..campaign.experiment import ExperimentCampaign, GraphEquivalent, run_metrics
from ..campaign.runner_cli import add_engine_arguments, campaign_dir, run_for_cli

#: Paper 3 Table 2 mean initial misalignment (δφE0, δφN0, δφU0) [arcsec].
PAPER3_MISALIGNMENT_ARCSEC = (-25.0, -36.0, 17.0 * 60.0)

RATE_HZ = 1000.0  # paper 3's loop rate, also the simulation and sensor rate here


def _platform_sim(duration_s: float, seed: int, profile_params: dict, initial_joints_deg: tuple = (),
                  resolver=None, *, rate_hz: float = RATE_HZ, substeps: int | None = None, **sensors):
    """(VehicleCore, SensorSuite) of the static-base platform at ``rate_hz`` with the paper 3
    sensors (platform IMU and resolvers at that rate, defaults as in sensor_models;
    ``sensors`` overrides SensorSuiteConfig fields, e.g. ``platform_gyro``); ``substeps``: the
    plant's RK4 substeps per step (None: VehicleConfig's default)."""
    steps = {} if substeps is None else {"platform_substeps": int(substeps)}
    core = VehicleCore(VehicleConfig(profile="static", profile_params=profile_params, plant="four_gimbal_platform",
                                     sim_rate_hz=rate_hz, duration_s=duration_s,
                                     initial_joints_deg=tuple(initial_joints_deg), **steps))
    suite = SensorSuite(SensorSuiteConfig(sensors=("platform_imu", "resolvers"), sim_rate_hz=rate_hz, seed=seed,
                                          platform_imu_rate_hz=rate_hz, resolver_rate_hz=rate_hz,
                                          resolver=PAPER3_RESOLVER if resolver is None else resolver,
                                          **sensors))
    return core, suite


def run_platform_servo(duration_s: float = 320.0, seed: int = 0, *, params: PlatformServoParams | None = None,
                       settle_s: float = 2.0, transient_window_s: float = 2.0,
                       resolver=None, record_every: int = 10, rate_hz: float = RATE_HZ,
                       substeps: int | None = None) -> dict[str, Any]:
    """Run the servo on the simulated platform (static base at ``params.lat_deg``).

    Returns metrics (radians, amperes, volts; see the module docstring) and ``series``
    (every ``record_every``-th tick: t, φz, e_a, level errors, pickoffs, azimuth current,
    voltages), one entry per step 0..N. Figures in arc-seconds are added as ``*_arcsec``.
    ``resolver``: the resolver ``EncoderParams`` (default ``PAPER3_RESOLVER``). ``rate_hz``:
    simulation = IMU = resolver = control rate (the gains are ``params``'); ``substeps``:
    the plant's RK4 substeps per step (None: VehicleConfig's default).
    """
    params = params if params is not None else PlatformServoParams()
    core, suite = _platform_sim(duration_s, seed, {"lat_deg": params.lat_deg}, resolver=resolver, rate_hz=rate_hz,
                                substeps=substeps)
    kt_a = paper3_axis_params("a").torque_constant_nm_a  # the plant's azimuth motor
    servo = PlatformServo(params)
    n = core.config.n_steps + 1
    t = np.arange(n) / rate_hz
    phi = np.zeros(n)
    e_a = np.zeros(n)
    level = np.zeros((n, 2))
    pickoff = np.zeros((n, 3))
    current_a = np.zeros(n)
    volts = np.zeros((n, 4))
    last = [None]  # the servo's last (t, φz, φ̇z): a new one is a tick's output

    def observe(bus) -> None:
        k, truth, mod = bus.k, bus.truth, bus.modulation
        if mod is not None and mod is not last[0]:
            last[0] = mod
            phi[k] = mod[1]
            volts[k] = servo.command_voltages
        th_a, th_q, th_p, _ = truth.joint_position
        e_a[k] = th_a - phi[k]
        level[k] = th_q, th_p
        pickoff[k] = servo.pickoff
        current_a[k] = truth.joint_effort[0] / kt_a

    run_stages(core, [platform_sensor_stage(suite), servo_stage(servo)], observer=observe)

    reversals = servo.schedule.reversal_times(duration_s)
    in_window = np.zeros(n, dtype=bool)
    for tr in reversals:
        in_window |= (t >= tr) & (t < tr + transient_window_s)
    steady = (t >= settle_s) & ~in_window
    abs_e = np.abs(e_a)
    level_abs = np.max(np.abs(level), axis=1)
    metrics: dict[str, Any] = {
        "duration_s": duration_s,
        "seed": seed,
        "reversal_times_s": reversals.tolist(),
        "steady_max_error_rad": float(np.max(abs_e[steady])) if steady.any() else math.nan,
        "steady_rms_error_rad": float(np.sqrt(np.mean(e_a[steady] ** 2))) if steady.any() else math.nan,
        "steady_max_level_error_rad": float(np.max(level_abs[steady])) if steady.any() else math.nan,
        "steady_max_pickoff_rad": float(np.max(np.abs(pickoff[steady]))) if steady.any() else math.nan,
        "reversal_max_error_rad": float(np.max(abs_e[in_window])) if in_window.any() else math.nan,
        "reversal_max_level_error_rad": float(np.max(level_abs[in_window])) if in_window.any() else math.nan,
        "steady_mean_abs_current_a": float(np.mean(np.abs(current_a[steady]))) if steady.any() else math.nan,
        "steady_rms_current_a": float(np.sqrt(np.mean(current_a[steady] ** 2))) if steady.any() else math.nan,
        "peak_current_a": float(np.max(np.abs(current_a[t >= settle_s]))),
        "presets": servo.presets,
        "rejected_nonfinite": servo.rejected_nonfinite,
        "held_commands": servo.held_commands,
    }
    for key in [key for key in metrics if key.endswith("_rad")]:
        metrics[key[:-4] + "_arcsec"] = metrics[key] / ARCSEC
    sl = slice(None, None, max(1, int(record_every)))
    metrics["series"] = {"t": t[sl], "phi_z_rad": phi[sl], "azimuth_error_rad": e_a[sl],
                         "level_error_rad": level[sl], "pickoff_rad": pickoff[sl],
                         "azimuth_current_a": current_a[sl], "voltages_v": volts[sl]}
    return metrics


#: Sensor noise of the alignment scenario. Paper 3 states only the bias grades (0.03 °/h and
#: 100 µg), which put its INS in the navigation grade; that grade bounds a gyro's angle random
#: walk at 0.002 °/√h (docs/spec.md, toolkit notes: paper 3's noise, with the citation). No
#: source at hand gives its accelerometers' noise, so they keep sensor_models' 50 µg/√Hz. Table 2
#: is measured at these values, not fitted by them (docs/results/paper3.md: alignment noise budget).
ALIGNMENT_GYRO_ARW_DEG_RT_H = 0.002
ALIGNMENT_ACCEL_NOISE_UG_RT_HZ = 50.0


def alignment_setup(misalignment0_arcsec: Sequence[float] = PAPER3_MISALIGNMENT_ARCSEC
                    ) -> tuple[float, tuple[float, float, float, float]]:
    """(base heading [deg], initial gimbal angles (θ_a, θ_q, θ_p, θ_r) [deg]) that give the
    alignment (scenario ``rotational_ins_alignment``) the initial misalignment
    (δφE0, δφN0, δφU0) [arcsec]: the filter takes the base heading as 0, so with the
    azimuth gimbal at 0 it believes the platform at φz = 0 (where the servo starts it), while
    the base's true heading is −δφU0 and the platform is tilted by (δφE0, δφN0); the outer
    roll takes the roll tilt so the inner roll starts at null."""
    e, n, u = (float(v) * ARCSEC for v in misalignment0_arcsec)
    C_ns = dcm_from_rotation_vector(np.array([n, e, -u]))  # exp([φ×]) times the believed frame (I)
    C_nb = euler321_to_dcm(0.0, 0.0, -u)  # the base heading the filter does not know
    joints = gimbal_angles_from_dcm(C_ns.T @ C_nb)
    return -math.degrees(u), tuple(float(math.degrees(v)) for v in joints)  # type: ignore[return-value]


VARIANTS = {"rotate": True, "fixed": False}   # the platform turned (360° and back) or held


def alignment_translate(options: dict) -> tuple[float, tuple]:
    """The options of :data:`CAMPAIGN` as scenario ``rotational_ins_alignment``'s values: the
    latitude in its three nodes (the base heading kept: :func:`alignment_setup`), the gyro
    angle random walk in the sensors, the accelerometer noise in the sensors and the filter."""
    lat, heading = options["lat_deg"], alignment_setup()[0]
    noise = options["accel_noise_ug_rt_hz"]
    return options["duration_s"], (
        ("vehicle_dynamics.profile_params", f"{{lat_deg: {lat!r}, yaw_deg: {heading!r}}}"),
        ("platform_servo.lat_deg", lat), ("platform_alignment.lat_deg", lat),
        ("sensor_models.platform_gyro_arw_deg_rt_h", options["gyro_arw_deg_rt_h"]),
        ("sensor_models.platform_accel_noise_ug_rt_hz", noise), ("platform_alignment.accel_noise_ug_rt_hz", noise))


#: Table 2 style seeds as a campaign, a declaration: scenario ``rotational_ins_alignment``'s
#: variants on the one engine (``engine: core``, each run's bag and ``alignment`` report) or
#: in the node graph (``engine: graph``); the table reads the runs' reports.
CAMPAIGN = ExperimentCampaign(
    name="alignment", variants=tuple(VARIANTS),
    defaults={"duration_s": 600.0, "lat_deg": 40.0, "gyro_arw_deg_rt_h": ALIGNMENT_GYRO_ARW_DEG_RT_H,
              "accel_noise_ug_rt_hz": ALIGNMENT_ACCEL_NOISE_UG_RT_HZ},
    run=None,
    graph=GraphEquivalent("rotational_ins_alignment", {"rotate": "rotation_on", "fixed": "rotation_off"},
                          ("duration_s", "lat_deg", "gyro_arw_deg_rt_h", "accel_noise_ug_rt_hz"), alignment_translate))


#: ``servo``: the report's figure (its path in metrics.json) -> its printed label.
SERVO_ROWS = {("control_error_arcsec", "sensed", "steady", "rms"): "control error sensed, steady rms [″]",
              ("control_error_arcsec", "sensed", "steady", "max"): "control error sensed, steady max [″]",
              ("control_error_arcsec", "truth_drift_removed", "steady", "rms"): "control error truth, steady rms [″]",
              ("control_error_arcsec", "truth_drift_removed", "steady", "max"): "control error truth, steady max [″]",
              ("control_error_arcsec", "sensed", "reversal", "max"): "reversal transient sensed, max [″]",
              ("control_error_arcsec", "truth_drift_removed", "reversal", "max"): "reversal transient truth, max [″]",
              ("torque_current", "steady_mean_abs_ma"): "azimuth torque current, steady mean |i| [mA]",
              ("torque_current", "reversal_peak_ma"): "azimuth torque current, reversal peak [mA]"}


def servo_figures(duration_s: float, seed: int, run_dir: Path) -> dict[str, Any]:
    """Scenario ``rotational_platform_servo`` for ``duration_s`` [s] and ``seed`` on the one
    engine into ``run_dir`` (its bag), and its ``platform_servo`` report's metrics."""
    scenario = dataclasses.replace(load_scenario("rotational_platform_servo"), duration_s=duration_s, seed=seed)
    return run_on_engine(scenario, run_dir)


def _alignment_table(runs: list[tuple[int, dict]]) -> str:
    """Per seed ([(seed, figures)] as :func:`alignment_figures`) the Table 2 columns."""
    rows = [f"{'seed':>4} {'dphiE0 err':>11} {'dphiN0 err':>11} {'dphiU0 err':>11} {'epsN err':>10} "
            f"{'sigma E/N/U':>22}",
            f"{'':>4} {'[arcsec]':>11} {'[arcsec]':>11} {'[arcmin]':>11} {'[deg/h]':>10}"]
    for seed, r in runs:
        rows.append(f"{seed:>4} {r['tilt_error_arcsec']['east']:>11.2f} {r['tilt_error_arcsec']['north']:>11.2f} "
                    f"{r['azimuth_error_arcmin']:>11.3f} {r['north_drift_error_deg_h']:>10.5f} "
                    f"{r['tilt_sigma_arcsec']['east']:>7.2f}″{r['tilt_sigma_arcsec']['north']:>6.2f}″"
                    f"{r['azimuth_sigma_arcmin']:>6.2f}′")
    return "\n".join(rows)


def summarize_figures(runs: list[dict]) -> dict[str, dict[str, float]]:
    """Mean, std (ddof=1, as Table 2), RMS and max |·| over runs of the headline errors (each
    run's ``alignment`` report figures)."""
    cols = {
        "east_tilt_error_arcsec": [r["tilt_error_arcsec"]["east"] for r in runs],
        "north_tilt_error_arcsec": [r["tilt_error_arcsec"]["north"] for r in runs],
        "azimuth_error_arcmin": [r["azimuth_error_arcmin"] for r in runs],
        "north_drift_error_deg_h": [r["north_drift_error_deg_h"] for r in runs],
        "gyro_drift_x_error_deg_h": [r["gyro_drift_error_deg_h"][0] for r in runs],
        "gyro_drift_y_error_deg_h": [r["gyro_drift_error_deg_h"][1] for r in runs],
        "accel_bias_x_error_ug": [r["accel_bias_error_ug"][0] for r in runs],
        "accel_bias_y_error_ug": [r["accel_bias_error_ug"][1] for r in runs],
    }
    return column_stats(cols)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m gimbal_sim.experiments.platform_servo",
        description="Paper 3 closed-loop experiments in one process (the graph's cores without ROS): the "
                    "platform servo figures, or a Table 2 style alignment campaign over seeds.")
    sub = parser.add_subparsers(dest="what", required=True)
    servo = sub.add_parser("servo", help="servo figures (scenario rotational_platform_servo on the engine, its "
                                         "bag and report): control error, reversal transient, torque current")
    servo.add_argument("--duration", type=float, default=320.0, help="simulated seconds (default 320: one reversal)")
    servo.add_argument("--seed", type=int, default=0)
    servo.add_argument("--out", metavar="DIR", help="keep the run (bag, report) here; default: a temporary "
                                                    "directory, removed after the figures are printed")
    align = sub.add_parser("alignment", help="alignment errors over seeds, mean and std as paper 3 Table 2")
    align.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3, 4, 5, 6])
    align.add_argument("--duration", type=float, default=600.0, help="simulated seconds (default 600: 360° and back)")
    align.add_argument("--lat", type=float, default=40.0, help="latitude [deg]")
    align.add_argument("--no-rotation", action="store_true", help="hold the platform (paper 3 eq. 9 case)")
    align.add_argument("--gyro-arw", type=float, default=ALIGNMENT_GYRO_ARW_DEG_RT_H,
                       help="platform gyro angle random walk [deg/sqrt(h)]")
    align.add_argument("--accel-noise", type=float, default=ALIGNMENT_ACCEL_NOISE_UG_RT_HZ,
                       help="platform accelerometer noise density [micro-g/sqrt(Hz)]")
    add_engine_arguments(align, graph=True)
    args = parser.parse_args(argv)
    if args.what == "servo":
        with campaign_dir(args.out) as out:
            m = servo_figures(args.duration, args.seed, out)
        for path, label in SERVO_ROWS.items():
            value = m
            for key in path:
                value = value[key]
            print(f"{label:52s} {'-' if value is None else format(value, '.4g')}")  # None: no such span
        return 0
    variant = "fixed" if args.no_rotation else "rotate"
    options = {"duration_s": args.duration, "lat_deg": args.lat, "gyro_arw_deg_rt_h": args.gyro_arw,
               "accel_noise_ug_rt_hz": args.accel_noise}
    if len(set(args.seeds)) != len(args.seeds):
        align.error("--seeds must not repeat a seed")
    spec = CampaignSpec(scenario="", experiment=CAMPAIGN.name, seeds=tuple(args.seeds), variants=(variant,),
                        engine=args.engine, mode=args.mode, options=tuple(options.items()))
    with campaign_dir(args.out) as out:
        result = run_for_cli(align, args, spec, out, CAMPAIGN, run_on_engine)
        runs = [(seed, m["alignment"]) for seed, m in run_metrics(result)[variant]]
    for run in runs:  # each seed's line, as the runs finished before (now after the campaign)
        print(_alignment_table([run]).splitlines()[-1])
    print(_alignment_table(runs))
    summary = summarize_figures([r for _, r in runs])
    print(f"{'':>4} {'mean':>11} {'std':>11}   (ddof=1, as paper 3 Table 2)")
    for key, stats in summary.items():
        print(f"{key:28s} mean {stats['mean']:+.4g}  std {stats['std']:.4g}  rms {stats['rms']:.4g}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
