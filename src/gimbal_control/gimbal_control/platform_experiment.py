"""Closed-loop paper 3 experiment: :class:`.platform_servo.PlatformServo` on gimbal_sim's
four-gimbal platform on a static base (SPEC §3.3; scenario ``rotational_platform_servo``).

Plant adapter. gimbal_sim's platform (``VehicleConfig(plant='four_gimbal_platform')``) is
four decoupled DC-motor loops. The loop angles a, q, p are the stable element's angles
relative to the level frame n, C_sn = rot1(θ_q) rot2(θ_p) rot3(θ_a), and the q and p loops
turn the platform about its *own* x and y axes. In the real gimbal set of paper 3 (and in
eq. 1) the inner-roll and pitch motors sit on gimbal axes that do not turn with the
azimuth. The servo is written for the real gimbal, so this adapter does two things:

* Resolver readings: the gimbal angles that realise the plant's attitude with the
  simulated outer-roll angle θ_r. They come from
  :func:`gimbal_kinematics.four_gimbal.gimbal_angles_from_dcm` on C_sb = C_sn C_nb,
  quantised like a 19-bit resolver-to-digital converter (2.5″; paper 3 §3).
* Motor torques: each gimbal motor's torque (k_t/R_a)·V is resolved onto the stable
  element's axes, τ_s = τ_a e3 + C_sq (τ_q e1 + τ_p C_qp e2), and converted back to the
  voltages of the plant loops. The outer-roll voltage goes straight to the outer-roll loop;
  that loop does not move the stable element in this plant.

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
from typing import Any, Sequence

import numpy as np

from gimbal_kinematics.four_gimbal import gimbal_angles_from_dcm
from gimbal_kinematics.rotations import quat_to_dcm, rot1, rot2, rot3

from .platform_servo import PlatformServo, PlatformServoParams

ARCSEC = math.pi / (180.0 * 3600.0)
#: 19-bit resolver-to-digital converter quantum [rad] (paper 3 §3: 19XSZ1411, ±10″ accuracy).
RESOLVER_QUANTUM_RAD = 2.0 * math.pi / 2 ** 19


def resolver_angles(loop_angles: Sequence[float], C_nb: np.ndarray, quantum_rad: float = RESOLVER_QUANTUM_RAD
                    ) -> tuple[float, float, float, float]:
    """Gimbal angles (θ_a, θ_q, θ_p, θ_r) [rad] read by the resolvers for the plant state.

    ``loop_angles``: the plant's (a, q, p, r) loop angles [rad]; ``C_nb`` (3, 3): base to
    NED; ``quantum_rad``: resolver quantum (0 = exact).
    """
    a, q, p, r = (float(v) for v in loop_angles)
    C_sb = rot1(q) @ rot2(p) @ rot3(a) @ C_nb
    ga, gq, gp, gr = (float(v) for v in gimbal_angles_from_dcm(C_sb, r))
    if quantum_rad > 0.0:
        ga, gq, gp, gr = (quantum_rad * math.floor(v / quantum_rad + 0.5) for v in (ga, gq, gp, gr))
    return ga, gq, gp, gr


def plant_voltages(gimbal_volts: Sequence[float], angles: Sequence[float],
                   torque_per_volt: Sequence[float]) -> tuple[float, float, float, float]:
    """Plant loop voltages (a, q, p, r) [V] for gimbal motor voltages (a, q, p, r) [V].

    ``angles``: resolver angles (θ_a, θ_q, ...) [rad]; ``torque_per_volt``: k_t/R_a of the
    loops (a, q, p, r) [N·m/V], the same motors on both sides. The gimbal torques are
    resolved on the stable element's axes (module docstring).
    """
    va, vq, vp, vr = gimbal_volts
    ka, kq, kp, _ = torque_per_volt
    ta, tq, tp = ka * va, kq * vq, kp * vp
    ca, sa = math.cos(angles[0]), math.sin(angles[0])
    cq, sq = math.cos(angles[1]), math.sin(angles[1])
    # in q: τ_q e1 + τ_p (0, cos θq, −sin θq); C_sq = rot3(θa) maps q to s
    x, y, z = tq, tp * cq, -tp * sq
    tx, ty, tz = ca * x + sa * y, -sa * x + ca * y, z + ta
    return tz / ka, tx / kq, ty / kp, vr


def run_platform_servo(duration_s: float = 320.0, seed: int = 0, *, params: PlatformServoParams | None = None,
                       settle_s: float = 2.0, transient_window_s: float = 2.0,
                       resolver_quantum_rad: float = RESOLVER_QUANTUM_RAD,
                       record_every: int = 10) -> dict[str, Any]:
    """Run the servo on the simulated platform (static base at ``params.lat_deg``).

    Returns metrics (radians, amperes, volts; see the module docstring) and ``series``
    (every ``record_every``-th tick: t, φz, e_a, level errors, pickoffs, azimuth current,
    voltages). Figures in arc-seconds are added as ``*_arcsec``.
    """
    from gimbal_sim.plant import paper3_axis_params
    from gimbal_sim.sensor_suite import PlatformImuSample, SensorSuite, SensorSuiteConfig
    from gimbal_sim.vehicle import VehicleConfig, VehicleCore

    params = params if params is not None else PlatformServoParams()
    rate = 1000.0
    core = VehicleCore(VehicleConfig(profile="static", profile_params={"lat_deg": params.lat_deg},
                                     plant="four_gimbal_platform", sim_rate_hz=rate, duration_s=duration_s))
    suite = SensorSuite(SensorSuiteConfig(sensors=("platform_imu",), sim_rate_hz=rate, seed=seed,
                                          platform_imu_rate_hz=rate))
    axes = [paper3_axis_params(a) for a in ("a", "q", "p", "r")]  # as VehicleCore builds them
    kpv = tuple(ax.torque_constant_nm_a / ax.resistance_ohm for ax in axes)
    kt_a = axes[0].torque_constant_nm_a
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
    C_nb = None
    k = 0
    while not core.finished:
        truth = core.truth()
        if C_nb is None:
            C_nb = quat_to_dcm(truth.quat_nb)  # static base: constant
        angles = resolver_angles(truth.joint_position, C_nb, resolver_quantum_rad)
        servo.on_resolvers(truth.t, angles)
        for s in suite.update(truth):
            if isinstance(s, PlatformImuSample):
                out = servo.on_gyro(s.t, s.omega)
                if out is not None:
                    cmd = plant_voltages(out.voltages, angles, kpv)
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
