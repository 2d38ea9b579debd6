"""An analysis runner (not a scenario): paper 1's LOS rate loop alone, without ROS: vehicle,
gyro and LosRateController on the engine's one loop (:func:`..core.core_loop.run_stages`) with
ideal encoders and INS.

The acceptance figure (LOS pointing error over 120 s, ideal gyro and paper 1's gyro noise;
docs/results/paper1.md) comes from scenario ``los_stabilization``'s bags, its ideal sensors
set as ``sensor_models`` values. This runner measures what no node does: the truth's encoders
and INS rates at every step, a command applied some steps late (a loop-delay study), each
noise model alone; the tests use it at a shorter span. It writes no bag.

Measurements (:func:`..core_ideal.ideal_sensor_stage`): the gyro reads the truth's inertial
rate of m about y, z at t_k (``'ideal'``), plus paper 1's ARW (``'noise'``:
``PAPER1_GIMBAL_GYRO`` without its fixed bias and Gauss-Markov terms), or the full paper 1
gyro (``'paper1'``: bias too; with no estimator fed back the LOS drifts, docs/spec.md §3.1).
Encoders and INS body rates are ideal (truth). Timing follows the lockstep graph
(:func:`..core_stages.controller_stage`): the command computed from the samples of t_k is
held over [t_k, t_{k+1}]; ``delay_samples`` > 0 applies it that many steps later
(:func:`..core_ideal.command_delay_stage`).

Pointing error: the angle between the LOS and its initial *inertial* direction. The truth
is resolved in NED, which turns with the earth (``earth_rate=True``), so the LOS is
carried to the inertial frame (NED at t = 0) with C_{n0 n}(t) = exp([ω_ie^n ×] t)
(constant ω_ie^n: the profiles do not translate), the same rotation the vehicle core uses
for its delta angles.
"""
from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np

from gimbal_control.los_rate_controller import (
    DEFAULT_OMEGA_N_HZ, DEFAULT_RATE_HZ, PAPER_ZETA, LosRateController, LosRateControllerParams,
)
from gimbal_kinematics.maths.los import inertial_los, pointing_error

from ..core.core_ideal import command_delay_stage, ideal_sensor_stage
from ..core.core_loop import run_stages
from ..core.core_stages import Bus, controller_stage, timed
from ..world.sensors import PAPER1_GIMBAL_GYRO, GyroModel
from ..world.vehicle import VehicleConfig, VehicleCore

GYRO_MODES = ("ideal", "noise", "paper1")

#: Paper 1's gimbal gyro with only its angle random walk (no fixed bias, no bias instability).
PAPER1_GYRO_ARW_ONLY = dataclasses.replace(PAPER1_GIMBAL_GYRO, bias_deg_h=0.0, bias_sigma_deg_h=0.0,
                                           bias_instability_deg_h=0.0, rrw_deg_h_rt_h=0.0)


class PointingRecorder:
    """Observer of the run's n steps (k < n): the LOS (first column of C_nm), the applied
    command and the controller's rate error every ``record_every`` steps; the sum of the
    squared commands and the controller's counters after step n − 1."""

    def __init__(self, ctrl: LosRateController, n: int, record_every: int) -> None:
        self.ctrl, self.n, self.every = ctrl, n, record_every
        n_rec = (n + record_every - 1) // record_every
        self.t, self.los = np.empty(n_rec), np.empty((n_rec, 3))
        self.tau, self.err = np.empty((n_rec, 2)), np.empty((n_rec, 2))
        self.j = 0
        self.sum_tau2 = [0.0, 0.0]
        self.saturated_steps = self.rejected_inputs = 0

    def __call__(self, bus: Bus) -> None:
        k, tau = bus.k, bus.command
        if k >= self.n:
            return
        if k % self.every == 0:
            tr, j = bus.truth, self.j
            x, y, z, w = tr.quat_nm
            self.t[j] = tr.t
            self.los[j] = (1.0 - 2.0 * (y * y + z * z), 2.0 * (x * y + z * w), 2.0 * (x * z - y * w))
            self.tau[j] = tau
            self.err[j] = self.ctrl.rate_error
            self.j += 1
        self.sum_tau2[0] += tau[0] * tau[0]
        self.sum_tau2[1] += tau[1] * tau[1]
        if k == self.n - 1:
            self.saturated_steps, self.rejected_inputs = self.ctrl.saturated_steps, self.ctrl.rejected_inputs


def _check(gyro: str, delay_samples: int, record_every: int) -> None:
    if gyro not in GYRO_MODES:
        raise ValueError(f"gyro must be one of {GYRO_MODES}, got {gyro!r}")
    if int(delay_samples) != delay_samples or delay_samples < 0:
        raise ValueError(f"delay_samples must be an int >= 0, got {delay_samples!r}")
    if int(record_every) != record_every or record_every < 1:
        raise ValueError(f"record_every must be an int >= 1, got {record_every!r}")


def run_closed_loop(duration_s: float = 10.0, rate_hz: float = DEFAULT_RATE_HZ,
                    omega_n_hz: float = DEFAULT_OMEGA_N_HZ, gyro: str = "ideal", seed: int = 0,
                    zeta: float = PAPER_ZETA, delay_samples: int = 0, earth_rate: bool = True,
                    profile: str = "paper1_land_vehicle", settle_s: float = 1.0,
                    record_every: int = 1, anti_windup: str = "clamp",
                    integrator_limit_factor: float = 4.0) -> dict[str, Any]:
    """Run the paper 1 rate loop for ``duration_s`` [s] at ``rate_hz`` [Hz].

    Returns ``{"metrics": {...}, "t": (N,), "pointing_error_rad": (N,), "los_i": (N, 3),
    "tau": (N, 2), "rate_error": (N, 2)}`` (series every ``record_every`` steps). Metrics:
    ``pointing_rms_urad`` (whole run), ``pointing_rms_after_settle_urad`` (t ≥ settle_s),
    ``pointing_max_urad``, ``final_error_urad``, ``steps``, ``wall_s``, ``steps_per_s``
    (whole loop incl. bookkeeping), ``controller_us_per_step``, ``saturated_steps``,
    ``rejected_inputs``, ``torque_rms_nm`` (2,).
    """
    _check(gyro, delay_samples, record_every)
    core = VehicleCore(VehicleConfig(profile=profile, sim_rate_hz=rate_hz, duration_s=duration_s,
                                     earth_rate=earth_rate))
    ctrl = LosRateController(LosRateControllerParams(rate_hz=rate_hz, omega_n_hz=omega_n_hz, zeta=zeta,
                                                     feedback=False, gravity_m_s2=core.env.gravity_m_s2,
                                                     anti_windup=anti_windup,
                                                     integrator_limit_factor=integrator_limit_factor))
    model = None
    if gyro != "ideal":
        gp = PAPER1_GYRO_ARW_ONLY if gyro == "noise" else PAPER1_GIMBAL_GYRO
        model = GyroModel(gp, 2, np.random.default_rng(seed), core.config.dt)
    n = core.config.n_steps
    control, ctrl_s = timed(controller_stage(ctrl, rate_hz, sample_time=lambda bus: bus.truth.t))
    stages = [ideal_sensor_stage(model), control] + ([command_delay_stage(delay_samples)] if delay_samples else [])
    rec = PointingRecorder(ctrl, n, record_every)
    result = run_stages(core, stages, observer=rec)
    los_i = inertial_los(rec.los, rec.t, np.asarray(core.env.omega_in_n))
    err = pointing_error(los_i)
    after = err[rec.t >= settle_s]
    metrics = dict(
        duration_s=duration_s, rate_hz=rate_hz, omega_n_hz=omega_n_hz, zeta=zeta, gyro=gyro, seed=seed,
        delay_samples=delay_samples, earth_rate=earth_rate,
        pointing_rms_urad=float(np.sqrt(np.mean(err ** 2)) * 1e6),
        pointing_rms_after_settle_urad=float(np.sqrt(np.mean(after ** 2)) * 1e6) if after.size else math.nan,
        pointing_max_urad=float(np.max(err) * 1e6),
        final_error_urad=float(err[-1] * 1e6),
        steps=n, wall_s=result.wall_s, steps_per_s=result.steps_per_s,
        controller_us_per_step=ctrl_s[0] / (n + 1) * 1e6,
        saturated_steps=rec.saturated_steps, rejected_inputs=rec.rejected_inputs,
        torque_rms_nm=(math.sqrt(rec.sum_tau2[0] / n), math.sqrt(rec.sum_tau2[1] / n)),
    )
    return dict(metrics=metrics, t=rec.t, pointing_error_rad=err, los_i=los_i, tau=rec.tau, rate_error=rec.err)


def main(argv: list[str] | None = None) -> int:
    """``python -m gimbal_sim.experiments.closed_loop [duration] [rate] [omega_n] [gyro] [delay]``:
    one run, its metrics printed one per line."""
    import argparse

    ap = argparse.ArgumentParser(prog="python -m gimbal_sim.experiments.closed_loop",
                                 description="Paper 1 rate loop without ROS (vehicle, gyro, LosRateController in "
                                             "one loop); prints the pointing-error metrics.")
    ap.add_argument("duration", nargs="?", type=float, default=10.0, help="simulated time [s] (default 10)")
    ap.add_argument("rate", nargs="?", type=float, default=DEFAULT_RATE_HZ,
                    help=f"loop rate [Hz] (default {DEFAULT_RATE_HZ:g})")
    ap.add_argument("omega_n", nargs="?", type=float, default=DEFAULT_OMEGA_N_HZ,
                    help=f"loop natural frequency [Hz] (default {DEFAULT_OMEGA_N_HZ:g})")
    ap.add_argument("gyro", nargs="?", choices=GYRO_MODES, default="ideal", help="gyro model (default ideal)")
    ap.add_argument("delay", nargs="?", type=int, default=0, help="extra command delay [samples] (default 0)")
    a = ap.parse_args(argv)
    try:
        out = run_closed_loop(duration_s=a.duration, rate_hz=a.rate, omega_n_hz=a.omega_n, gyro=a.gyro,
                              delay_samples=a.delay)
    except ValueError as exc:
        ap.error(str(exc))
    for key, value in out["metrics"].items():
        print(f"{key}: {value}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
