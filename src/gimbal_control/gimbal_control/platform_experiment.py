"""Closed-loop paper 3 experiment: :class:`.platform_servo.PlatformServo` on gimbal_sim's
four-gimbal platform on a static base (SPEC §3.3; scenario ``rotational_platform_servo``).

Plant and sensors. gimbal_sim's platform (``VehicleConfig(plant='four_gimbal_platform')``)
takes the four gimbal motor voltages and resolves their torques onto its loops through the
gimbal geometry (:mod:`gimbal_sim.plant.platform_gimbals`); the servo reads the gimbal angles
from the ``resolvers`` sensor (19-bit converters, paper 3 §3). The graph runs the same pieces:
``vehicle_dynamics`` + ``sensor_models`` + the ``platform_servo`` node.

Sensors: the platform gyro triad of gimbal_sim's SensorSuite (``platform_imu``, paper 3
DTG grade: 0.03 °/h run-to-run bias, 0.003 °/√h ARW) at 1 kHz, with no drift
compensation.

Control errors (truth, radians):

* ``azimuth``: e_a = θ_a − φz(t), the platform azimuth (loop angle relative to n) minus
  the commanded modulation angle schedule;
* ``level``: the tilts θ_q and θ_p of the stable element relative to level;
* the sensed error (the pickoff angles) is reported too.

Steady rotation means t >= ``settle_s`` and outside [t_k, t_k + ``transient_window_s``]
around every reversal t_k. The reversal transient is the largest |e_a| inside those windows.
Torque current: the azimuth motor armature current, effort/k_t.
"""
from __future__ import annotations

import math
from typing import Any

import numpy as np

from .platform_servo import PlatformServo, PlatformServoParams

ARCSEC = math.pi / (180.0 * 3600.0)


def run_platform_servo(duration_s: float = 320.0, seed: int = 0, *, params: PlatformServoParams | None = None,
                       settle_s: float = 2.0, transient_window_s: float = 2.0,
                       resolver=None, record_every: int = 10) -> dict[str, Any]:
    """Run the servo on the simulated platform (static base at ``params.lat_deg``).

    Returns metrics (radians, amperes, volts; see the module docstring) and ``series``
    (every ``record_every``-th tick: t, φz, e_a, level errors, pickoffs, azimuth current,
    voltages). Figures in arc-seconds are added as ``*_arcsec``. ``resolver``: the resolver
    ``EncoderParams`` (default ``gimbal_sim.sensor_suite.PAPER3_RESOLVER``).
    """
    from gimbal_sim.plant import paper3_axis_params
    from gimbal_sim.sensor_suite import (
        PAPER3_RESOLVER, PlatformImuSample, ResolverSample, SensorSuite, SensorSuiteConfig,
    )
    from gimbal_sim.vehicle import VehicleConfig, VehicleCore

    params = params if params is not None else PlatformServoParams()
    rate = 1000.0
    core = VehicleCore(VehicleConfig(profile="static", profile_params={"lat_deg": params.lat_deg},
                                     plant="four_gimbal_platform", sim_rate_hz=rate, duration_s=duration_s))
    suite = SensorSuite(SensorSuiteConfig(sensors=("platform_imu", "resolvers"), sim_rate_hz=rate, seed=seed,
                                          platform_imu_rate_hz=rate, resolver_rate_hz=rate,
                                          resolver=PAPER3_RESOLVER if resolver is None else resolver))
    kt_a = paper3_axis_params("a").torque_constant_nm_a  # the plant's azimuth motor
    servo = PlatformServo(params)
    n = core.config.n_steps
    t = np.arange(n) / rate
    phi = np.zeros(n)
    e_a = np.zeros(n)
    level = np.zeros((n, 2))
    pickoff = np.zeros((n, 3))
    current_a = np.zeros(n)
    volts = np.zeros((n, 4))
    cmd = (0.0, 0.0, 0.0, 0.0)
    k = 0
    while not core.finished:
        truth = core.truth()
        for s in suite.update(truth):  # the suite delivers a step's resolvers before its IMU
            if isinstance(s, ResolverSample):
                servo.on_resolvers(s.t, s.angles)
            elif isinstance(s, PlatformImuSample):
                out = servo.on_gyro(s.t, s.omega)
                if out is not None:
                    cmd = out.voltages
                    phi[k] = out.phi_z
                    volts[k] = out.voltages
        th_a, th_q, th_p, _ = truth.joint_position
        e_a[k] = th_a - phi[k]
        level[k] = th_q, th_p
        pickoff[k] = servo.pickoff
        current_a[k] = truth.joint_effort[0] / kt_a
        core.step(cmd)
        k += 1

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
    for key in [k for k in metrics if k.endswith("_rad")]:
        metrics[key[:-4] + "_arcsec"] = metrics[key] / ARCSEC
    sl = slice(None, None, max(1, int(record_every)))
    metrics["series"] = {"t": t[sl], "phi_z_rad": phi[sl], "azimuth_error_rad": e_a[sl],
                         "level_error_rad": level[sl], "pickoff_rad": pickoff[sl],
                         "azimuth_current_a": current_a[sl], "voltages_v": volts[sl]}
    return metrics
