"""Paper 1's loop bandwidth beside the default: ``python -m gimbal_sim.tools.bandwidth``.

For each loop design, the headline scenario that runs it (``sighting_land_vehicle``: ω_n =
25 Hz at 1 kHz; ``sighting_land_vehicle_100hz``: the paper's ω_n = 100 Hz, ξ = 0.8 at 4 kHz):

* the loop margins of :mod:`gimbal_control.loop_design` (the graph's timing, d = 0, and the
  design's extra sample of delay, d = 1);
* the LOS jitter with an ideal gyro: the scenario's cores stepped without ROS
  (:mod:`..core.core_loop`, the same numbers as the graph) with every gimbal-gyro, INS-gyro
  and encoder error zeroed (``los_stabilization``'s sensors), the true LOS against its
  initial inertial direction after the first second, RMS about its offset and trend
  (:func:`jitter_rms`);
* the LOS error the 16 Hz and 41 Hz structural modes cause (the profile's 101 and 258 rad/s
  terms): the amplitude of the least-squares sinusoid at each mode frequency in the LOS
  error's two cross-axis components, and the RMS with the modes minus without;
* the real-time factor of that core loop (the graph's: ``gimbal-run … --mode container``
  prints it; docs/results/paper1.md).
"""
from __future__ import annotations

import argparse
import dataclasses
import math
import sys

import numpy as np
from gimbal_control.loop_design import margins_full
from gimbal_kinematics.maths.earth import earth_rate_n
from gimbal_kinematics.maths.los import inertial_los, los_from_quat

from ..core.core_loop import run_core_loop
from ..graph.scenario import Scenario, apply_set, load

DESIGNS = ("sighting_land_vehicle", "sighting_land_vehicle_100hz")
#: paper 1's structural modes (motion_profiles.paper1_land_vehicle) [rad/s]
MODE_FREQUENCIES_RAD_S = (101.0, 258.0)
#: los_stabilization's ideal sensors
IDEAL_SENSORS = ("sensor_models.gimbal_gyro_bias_deg_h=[0.0, 0.0]", "sensor_models.gimbal_gyro_arw_deg_rt_h=0.0",
                 "sensor_models.gimbal_gyro_bi_deg_h=0.0", "sensor_models.encoder_noise_deg=0.0",
                 "sensor_models.ins_gyro_bias_sigma_deg_h=0.0", "sensor_models.ins_gyro_bi_deg_h=0.0",
                 "sensor_models.ins_gyro_arw_deg_rt_h=0.0", "los_rate_controller.feedback=false")
SETTLE_S = 1.0


def sinusoid_amplitude(t: np.ndarray, x: np.ndarray, omega_rad_s: float) -> float:
    """Amplitude of the least-squares fit a sin ωt + b cos ωt + c + d t to ``x`` (the
    offset and trend absorb the slow part of a stabilization residual)."""
    basis = np.column_stack((np.sin(omega_rad_s * t), np.cos(omega_rad_s * t), np.ones_like(t), t))
    coef, *_ = np.linalg.lstsq(basis, x, rcond=None)
    return float(math.hypot(coef[0], coef[1]))


def jitter_rms(t: np.ndarray, err: np.ndarray) -> float:
    """RMS [rad] of the LOS error vector (N, 2) about its own offset and linear trend: the
    jitter, without the offset a start-up transient leaves (a rate loop never takes it back)
    or the slow drift of a gyro error."""
    basis = np.column_stack((np.ones_like(t), t - t[0]))
    coef, *_ = np.linalg.lstsq(basis, err, rcond=None)
    resid = err - basis @ coef
    return float(np.sqrt(np.mean(np.sum(resid ** 2, axis=1))))


def los_error_components(t: np.ndarray, los0: np.ndarray) -> np.ndarray:
    """(N, 2) components [rad] of the LOS unit vectors ``los0`` (N, 3, in inertial n(0))
    across the initial LOS: on two unit vectors orthogonal to it and to each other."""
    u = los0[0]
    a = np.cross(u, [0.0, 0.0, 1.0])
    a /= np.linalg.norm(a)
    b = np.cross(u, a)
    return np.column_stack((los0 @ a, los0 @ b))


@dataclasses.dataclass
class IdealRun:
    rms_urad: float
    mode_amplitude_urad: dict[float, float]
    steps_per_s: float
    real_time_factor: float


def ideal_gyro_run(scenario: Scenario, duration_s: float, structural_modes: bool = True) -> IdealRun:
    """The scenario's cores with ideal sensors (module docstring); LOS error after SETTLE_S."""
    sc = scenario
    for assignment in IDEAL_SENSORS + (
            "vehicle_dynamics.profile_params='{structural_modes: %s}'" % str(structural_modes).lower(),):
        sc = apply_set(sc, assignment)
    sc = dataclasses.replace(sc, duration_s=duration_s)
    t_list: list[float] = []
    q_list: list[np.ndarray] = []

    def observe(bus) -> None:
        t_list.append(bus.t)
        q_list.append(bus.truth.quat_nm)

    result = run_core_loop(sc, observer=observe)
    t = np.array(t_list)
    # profile_params above leaves the profile at its default site, latitude 0
    los = inertial_los(los_from_quat(np.array(q_list)), t - t[0], earth_rate_n(0.0))
    keep = t - t[0] >= SETTLE_S
    err = los_error_components(t, los)[keep]
    amps = {w: 1e6 * math.hypot(*(sinusoid_amplitude(t[keep], err[:, i], w) for i in range(2)))
            for w in MODE_FREQUENCIES_RAD_S}
    return IdealRun(1e6 * jitter_rms(t[keep], err), amps, result.steps_per_s, result.sim_s / result.wall_s)


def design_row(name: str, duration_s: float) -> dict:
    sc = load(name)
    ctrl = {"omega_n_hz": 25.0, "zeta": 0.8} | sc.nodes["los_rate_controller"]["params"]
    row = {"scenario": name, "rate_hz": sc.sim_rate_hz, "omega_n_hz": ctrl["omega_n_hz"], "zeta": ctrl["zeta"]}
    for d in (0, 1):
        m = margins_full(sc.sim_rate_hz, ctrl["omega_n_hz"], ctrl["zeta"], d)
        row[f"d{d}"] = dict(pm_deg=m.phase_margin_deg, gm_db=m.gain_margin_db, fc_hz=m.crossover_hz, stable=m.stable)
    on = ideal_gyro_run(sc, duration_s, True)
    off = ideal_gyro_run(sc, duration_s, False)
    row.update(jitter_rms_urad=on.rms_urad, jitter_rms_no_modes_urad=off.rms_urad,
               mode_amplitude_urad={f"{w / (2 * math.pi):.1f} Hz": a for w, a in on.mode_amplitude_urad.items()},
               core_steps_per_s=on.steps_per_s, core_real_time_factor=on.real_time_factor)
    return row


def format_rows(rows: list[dict]) -> str:
    lines = []
    for r in rows:
        modes = ", ".join(f"{k}: {v:.3f}" for k, v in r["mode_amplitude_urad"].items())
        lines += [f"{r['scenario']}: {r['rate_hz']:.0f} Hz loop, omega_n {r['omega_n_hz']:g} Hz, zeta {r['zeta']:g}",
                  *(f"  margins d={d}: PM {r[f'd{d}']['pm_deg']:.1f} deg  GM {r[f'd{d}']['gm_db']:.1f} dB  "
                    f"crossover {r[f'd{d}']['fc_hz']:.1f} Hz  stable {r[f'd{d}']['stable']}" for d in (0, 1)),
                  f"  ideal-gyro LOS jitter after {SETTLE_S:g} s: {r['jitter_rms_urad']:.3f} urad RMS "
                  f"({r['jitter_rms_no_modes_urad']:.3f} without the structural modes)",
                  f"  structural-mode LOS amplitude [urad]: {modes}",
                  f"  core loop: {r['core_steps_per_s']:,.0f} steps/s, {r['core_real_time_factor']:.2f}x real time"]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m gimbal_sim.tools.bandwidth", description=__doc__.splitlines()[0])
    parser.add_argument("--duration", type=float, default=5.0, help="simulated seconds per run (default 5)")
    args = parser.parse_args(argv)
    if not (math.isfinite(args.duration) and args.duration > SETTLE_S):
        print(f"bandwidth: --duration must be > {SETTLE_S} s", file=sys.stderr)
        return 2
    print(format_rows([design_row(name, args.duration) for name in DESIGNS]))
    return 0


if __name__ == "__main__":
    sys.exit(main())
