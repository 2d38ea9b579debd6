"""Paper 3's platform servo on its two DTGs, with the torquer current it commands (§2.1.1,
§4.1, Fig. 6b)::

    python -m gimbal_sim.experiments.dtg_torquer --duration-s 300 --seed 1

The world: gimbal_sim's four-gimbal platform on a static base at 1 kHz, its resolvers
(sensor_models' ``resolvers``), and the DTG pair of :mod:`..world.sensors.dtg` (drift drawn
per seed, rotor random walk, torquer scale-factor error). The processor:
:class:`gimbal_control.dtg_servo.DtgPlatformServo` (loops closed on the pickoffs, placed in
discrete time at 1 kHz; the command rate ω_c becomes torquer currents with the nominal scale
factor). The engine's loop (:func:`..core.core_loop.run_stages`) with the stages of
:mod:`..core.dtg_stages`: each step the gyros integrate the platform's exact inertial
rotation over the last step under the currents held from its start, the servo ticks on the
pickoffs and resolvers of t_k, the plant integrates to t_{k+1} under its voltages.

Figures. The azimuth torquer current i_z while the platform turns one leg at 1.2 °/s, sampled
at 1 s as paper 3's 6½-digit voltmeter did: its mean magnitude [mA] and its relative standard
deviation (paper: 60 mA, 4.52e-5). The control errors: azimuth (θ_a − φz) and level (θ_q, θ_p)
in steady rotation, and the pickoffs.
"""
from __future__ import annotations

import argparse
import math
from typing import Any

import numpy as np

from gimbal_control.dtg_servo import DtgPlatformServo, dtg_servo_params
from gimbal_control.platform_servo import PlatformServoParams
from gimbal_kinematics.maths.units import ARCSEC

from ..core.core_loop import run_stages
from ..core.dtg_stages import dtg_servo_stage, dtg_stage
from ..core.platform_stages import platform_sensor_stage
from ..world.sensor_suite import PAPER3_RESOLVER, SensorSuite, SensorSuiteConfig
from ..world.sensors.dtg import DtgPair, DtgPairParams
from ..world.vehicle import VehicleConfig, VehicleCore

RATE_HZ = 1000.0


def run_dtg_servo(duration_s: float = 300.0, seed: int = 1, *, lat_deg: float = 45.0,
                  gyros: DtgPairParams | None = None, rate_hz: float = RATE_HZ, settle_s: float = 5.0,
                  sample_s: float = 1.0, servo_params: PlatformServoParams | None = None) -> dict[str, Any]:
    """One closed-loop run (module docstring); figures in SI and the series sampled at
    ``sample_s``. ``servo_params``: the base servo parameters (gains are replaced by the
    discrete design at ``rate_hz``)."""
    gyros = gyros or DtgPairParams()
    core = VehicleCore(VehicleConfig(profile="static", profile_params={"lat_deg": lat_deg},
                                     plant="four_gimbal_platform", sim_rate_hz=rate_hz, duration_s=duration_s))
    suite = SensorSuite(SensorSuiteConfig(sensors=("resolvers",), sim_rate_hz=rate_hz, seed=seed,
                                          resolver_rate_hz=rate_hz, resolver=PAPER3_RESOLVER))
    pair = DtgPair(gyros, np.random.default_rng([seed, 3]))
    base = servo_params or PlatformServoParams(lat_deg=lat_deg)
    servo = DtgPlatformServo(dtg_servo_params(base, rate_hz), scale_deg_h_ma=gyros.scale_deg_h_ma,
                             max_current_ma=gyros.max_current_ma)
    n = core.config.n_steps + 1
    current = np.zeros((n, 3))
    pick = np.zeros((n, 4))
    err = np.zeros((n, 3))
    phi = np.zeros(n)

    def observe(bus) -> None:
        k = bus.k
        if bus.modulation is not None:
            phi[k] = bus.modulation[1]
        current[k] = servo.torquer_current
        pick[k] = bus.dtg
        th_a, th_q, th_p, _ = bus.truth.joint_position
        err[k] = th_a - phi[k], th_q, th_p

    run_stages(core, [platform_sensor_stage(suite), dtg_stage(pair, servo, core.env.omega_in_n, core.config.dt),
                      dtg_servo_stage(servo)], observer=observe)
    return _figures(servo, current, pick, err, phi, duration_s, rate_hz, settle_s, sample_s, pair, seed)


def _max_abs(a: np.ndarray) -> float:
    return float(np.max(np.abs(a))) if a.size else math.nan


def _figures(servo, current, pick, err, phi, duration_s, rate_hz, settle_s, sample_s, pair, seed) -> dict[str, Any]:
    t = np.arange(len(current)) / rate_hz
    rev = servo.schedule.reversal_times(duration_s)
    steady = t >= settle_s
    for tr in rev:
        steady &= ~((t >= tr - sample_s) & (t < tr + settle_s))
    every = max(1, int(round(sample_s * rate_hz)))
    sampled = np.zeros(len(t), dtype=bool)
    sampled[::every] = True
    iz = current[steady & sampled, 2]
    legs = [("+", iz[iz > 0.0]), ("-", -iz[iz < 0.0])]  # out and back: the vertical earth rate differs in sign
    mean_iz = float(np.mean(np.abs(iz))) if iz.size else math.nan
    return {
        "seed": seed, "duration_s": duration_s, "rate_hz": rate_hz,
        "scale_deg_h_ma": servo.scale_rad_s_a / (math.pi / 180.0 / 3600.0 * 1000.0),
        "azimuth_current_mean_abs_ma": mean_iz * 1e3,
        "azimuth_current_rsd": float(np.std(np.abs(iz)) / mean_iz) if iz.size > 1 else math.nan,
        "azimuth_current_samples": int(iz.size),
        "azimuth_current_legs": [(sign, float(np.mean(leg)) * 1e3, float(np.std(leg) / np.mean(leg)), int(leg.size))
                                 for sign, leg in legs if leg.size > 1],
        "level_current_max_abs_ma": _max_abs(current[steady, :2]) * 1e3,
        "steady_max_azimuth_error_arcsec": _max_abs(err[steady, 0]) / ARCSEC,
        "steady_max_level_error_arcsec": _max_abs(err[steady, 1:]) / ARCSEC,
        "steady_max_pickoff_arcsec": _max_abs(pick[steady]) / ARCSEC,
        "drift_truth_deg_h": [d / (math.pi / 180.0 / 3600.0) for d in pair.drift_truth()],
        "held_commands": servo.held_commands, "presets": servo.presets,
        "series": {"t": t[::every], "azimuth_current_a": current[::every, 2], "phi_z_rad": phi[::every],
                   "azimuth_error_rad": err[::every, 0]},
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m gimbal_sim.experiments.dtg_torquer",
                                 description="Paper 3's servo on its DTGs: the azimuth torquer current at 1.2 deg/s")
    ap.add_argument("--duration-s", type=float, default=300.0, help="run length [s] (one leg: 300)")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--lat-deg", type=float, default=45.0)
    ap.add_argument("--scale-error-ppm", type=float, default=0.0, help="the torquers' scale-factor error [ppm]")
    args = ap.parse_args(argv)
    if not (args.duration_s > 0.0 and abs(args.lat_deg) < 90.0):
        ap.error("--duration-s must be > 0 and --lat-deg within (-90, 90)")
    gyros = DtgPairParams(scale_error_ppm=(args.scale_error_ppm,) * 4)
    r = run_dtg_servo(args.duration_s, args.seed, lat_deg=args.lat_deg, gyros=gyros)
    print(f"torquer scale factor {r['scale_deg_h_ma']:.3f} (deg/h)/mA (paper 3's own: 4320 deg/h at 60 mA)")
    print(f"azimuth torquer current at 1.2 deg/s: {r['azimuth_current_mean_abs_ma']:.4f} mA "
          f"(paper: 60 mA), relative std {r['azimuth_current_rsd']:.3e} over {r['azimuth_current_samples']} "
          f"1-s samples (paper: 4.52e-5)")
    for sign, mean, rsd, count in r["azimuth_current_legs"]:
        print(f"  leg at {sign}1.2 deg/s: {mean:.4f} mA, relative std {rsd:.3e} over {count} 1-s samples")
    print(f"level torquer current max {r['level_current_max_abs_ma']:.4f} mA")
    print(f"steady errors: azimuth {r['steady_max_azimuth_error_arcsec']:.2f}\", level "
          f"{r['steady_max_level_error_arcsec']:.2f}\", pickoff {r['steady_max_pickoff_arcsec']:.2f}\" "
          f"(paper: < 40\")")
    print("drift truth (lower x, y, upper x, y) deg/h: " + ", ".join(f"{d:+.4f}" for d in r["drift_truth_deg_h"]))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
