"""Paper 1's headline experiment without ROS: vehicle, sensors, LOS controller and bias EKF
stepped in one Python loop with the lockstep graph's timing (docs/spec.md §3.1, scenario
``sighting_land_vehicle``).

Per step k (t = k·dt): the sensors sample the truth of step k; the EKF takes the encoders,
the INS (when due) and the gyro of stamp k, and at INS steps returns its estimate stamped k;
the controller then uses the newest estimate (that of stamp k at INS steps) and its command
is held over [t_k, t_{k+1}]. This is what the graph does when the controller waits, at INS
steps, for the EKF's output of the same stamp, so the loop and the graph compute the same
numbers; the graph adds only messaging. The loop is also the benchmark's limit (a).

LOS drift (truth): the LOS (m-frame x axis) carried to the inertial frame (NED at t = 0,
:func:`gimbal_kinematics.los.inertial_los`), as azimuth and elevation relative to the
initial ones. The azimuth drift is reported cross-elevation (Δaz · cos el0), the angle the
LOS swept about the m-z axis, so that without the EKF both components equal minus the
integral of the true gyro bias (q for elevation, r for azimuth).
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, replace
from typing import Sequence

import numpy as np

from gimbal_control.los_hold import LosHold, LosHoldParams
from gimbal_control.los_rate_controller import LosRateController, LosRateControllerParams
from gimbal_estimators.gyro_bias_ekf import GyroBiasEkf, GyroBiasEkfParams
from gimbal_kinematics.rotations import quat_to_dcm, rotation_vector_from_dcm
from gimbal_kinematics.los import inertial_los, los_drift, los_from_quat

from ..sensor_suite import EncoderSample, GimbalGyroSample, InsSample, SensorSuite, SensorSuiteConfig
from ..sensors import InsParams
from ..vehicle import VehicleConfig, VehicleCore
from .bias_ekf import ekf_params_from_sensors

MODES = ("off", "feedback", "los_hold")


@dataclass(frozen=True)
class SightingRun:
    """One run. Series at every ``record_every`` steps: ``t`` (N,) [s], ``drift`` (N, 2)
    [rad] (az·cos el, el), ``bias_integral`` (N, 2) [rad]: −∫ true gyro bias dt (r for az,
    q for el); at the EKF outputs: ``t_ekf`` (M,), ``bias_est``/``bias_sigma``/
    ``bias_true`` (M, 3) [rad/s] (x, q, r; x is the INS gyro bias projected on the outer
    gimbal's x axis, what the roll-channel state models), ``nees`` (M,) of the 6 paper
    states (attitude error ψ and the three biases) and ``nees_bias`` (M,) of (b_q, b_r)."""

    mode: str
    seed: int
    duration_s: float
    t: np.ndarray
    drift: np.ndarray
    bias_integral: np.ndarray
    t_ekf: np.ndarray
    bias_est: np.ndarray
    bias_sigma: np.ndarray
    bias_true: np.ndarray
    nees: np.ndarray
    nees_bias: np.ndarray
    steps: int
    wall_s: float

    @property
    def final_drift_deg(self) -> np.ndarray:
        return np.degrees(self.drift[-1])

    def drift_rate_last_deg_h(self, span_s: float = 60.0) -> np.ndarray:
        """Mean drift rate over the last ``span_s`` [°/h], per axis (az, el)."""
        i = int(np.searchsorted(self.t, self.t[-1] - span_s))
        return np.degrees(self.drift[-1] - self.drift[i]) / (self.t[-1] - self.t[i]) * 3600.0


def run_sighting(mode: str = "feedback", seed: int = 1, duration_s: float = 120.0, *,
                 sensors_config: SensorSuiteConfig | None = None, ekf_params: GyroBiasEkfParams | None = None,
                 controller: LosRateControllerParams | None = None, hold: LosHoldParams | None = None,
                 sim_rate_hz: float = 1000.0, ins_rate_hz: float = 100.0,
                 initial_joints_deg: Sequence[float] = (20.0, 10.0), lat_deg: float = 0.0,
                 record_every: int = 10) -> SightingRun:
    """Run the land-vehicle scenario with the EKF ``off`` (estimated but not fed back),
    fed back (``feedback``), or fed back with the LOS-hold outer loop (``los_hold``)."""
    if mode not in MODES:
        raise ValueError(f"mode must be one of {MODES}, got {mode!r}")
    base = sensors_config if sensors_config is not None else SensorSuiteConfig()
    sensors = replace(base, sensors=("ins", "gimbal_gyro", "encoders"), seed=seed, sim_rate_hz=sim_rate_hz,
                      gimbal_gyro_rate_hz=sim_rate_hz, encoder_rate_hz=sim_rate_hz, ins_rate_hz=ins_rate_hz)
    core = VehicleCore(VehicleConfig(profile="paper1_land_vehicle", profile_params={"lat_deg": lat_deg},
                                     sim_rate_hz=sim_rate_hz, duration_s=duration_s,
                                     initial_joints_deg=tuple(initial_joints_deg)))
    suite = SensorSuite(sensors)
    ekf = GyroBiasEkf(ekf_params if ekf_params is not None else ekf_params_from_sensors(sensors, lat_deg))
    cparams = controller if controller is not None else LosRateControllerParams(rate_hz=sim_rate_hz)
    ctrl = LosRateController(replace(cparams, feedback=mode != "off", gravity_m_s2=core.env.gravity_m_s2))
    outer = LosHold(hold if hold is not None else LosHoldParams(lat_deg=lat_deg)) if mode == "los_hold" else None
    n = core.config.n_steps
    rec_t, rec_los, rec_b = [], [], []
    ekf_rec = []
    bias_int = [0.0, 0.0]
    ins_rates = None
    wall0 = time.perf_counter()
    for k in range(n):
        truth = core.truth()
        gyro = enc = None
        out = None
        for s in suite.update(truth):
            if isinstance(s, GimbalGyroSample):
                gyro = s
            elif isinstance(s, EncoderSample):
                enc = s
                out = ekf.on_encoders(s.t, s.angles, s.rates) or out
            elif isinstance(s, InsSample):
                ins_rates = s.omega_b
                out = ekf.on_ins(s.t, s.euler, s.omega_b) or out
        out = ekf.on_gyro(gyro.t, gyro.q_m, gyro.r_m) or out
        if out is not None:
            ctrl.set_bias_estimate(out.t, out.bias)
            if outer is not None:
                ctrl.set_rate_command(*outer.update(out.t, out.quat_nm, out.bias[1:]))
            az = truth.joint_position[0] + truth.joint_position[1]
            b_ins = suite.ins.true_gyro_bias
            b_true = np.array([math.cos(az) * b_ins[0] + math.sin(az) * b_ins[1], *gyro.true_bias])
            psi = rotation_vector_from_dcm(quat_to_dcm(truth.quat_nm) @ quat_to_dcm(out.quat_nm).T)
            e6 = np.concatenate((psi, b_true - out.bias))
            P6 = ekf.P[:6, :6]
            ekf_rec.append((out.t, out.bias, out.bias_sigma, b_true, float(e6 @ np.linalg.solve(P6, e6)),
                            float(e6[4:] @ np.linalg.solve(P6[4:, 4:], e6[4:]))))
        tau = ctrl.step(truth.t, (gyro.q_m, gyro.r_m), enc.angles, enc.rates, ins_rates)
        bias_int[0] -= gyro.true_bias[1] * core.config.dt  # r -> azimuth
        bias_int[1] -= gyro.true_bias[0] * core.config.dt  # q -> elevation
        if k % record_every == 0 or k == n - 1:
            rec_t.append(truth.t)
            rec_los.append(truth.quat_nm)
            rec_b.append(tuple(bias_int))
        core.step(tau)
    wall = time.perf_counter() - wall0
    t = np.array(rec_t)
    los_i = inertial_los(los_from_quat(np.array(rec_los)), t, np.asarray(core.env.omega_in_n))
    te = np.array([r[0] for r in ekf_rec])
    est = np.array([r[1] for r in ekf_rec])
    sig = np.array([r[2] for r in ekf_rec])
    tru = np.array([r[3] for r in ekf_rec])
    nees, nees_b = np.array([r[4] for r in ekf_rec]), np.array([r[5] for r in ekf_rec])
    return SightingRun(mode, seed, duration_s, t, los_drift(los_i), np.array(rec_b), te, est, sig, tru, nees, nees_b,
                       n, wall)


def paper1_sensors(correlated_ins: bool = False) -> tuple[SensorSuiteConfig, GyroBiasEkfParams]:
    """Paper 1's sensors and the matching EKF: the INS attitude errors white (paper 1's
    model, τ → 0, the 6-state filter) or Gauss-Markov with τ = 300 s (``correlated_ins``,
    the 9-state filter that models them)."""
    if correlated_ins:
        sensors = SensorSuiteConfig()
        return sensors, ekf_params_from_sensors(sensors)
    sensors = SensorSuiteConfig(ins=InsParams(attitude_tau_s=1e-3))
    return sensors, ekf_params_from_sensors(sensors, ins_error_states=False)


def monte_carlo(seeds: Sequence[int], duration_s: float = 120.0, modes: Sequence[str] = ("off", "feedback"),
                correlated_ins: bool = False, progress: bool = True) -> dict[str, list[SightingRun]]:
    """:func:`run_sighting` for every seed and mode with paper 1's sensors."""
    sensors, params = paper1_sensors(correlated_ins)
    jobs = [(mode, seed) for seed in seeds for mode in modes]
    runs: dict[str, list[SightingRun]] = {mode: [] for mode in modes}
    from tqdm import tqdm

    for mode, seed in tqdm(jobs, unit="run", disable=None if progress else True):
        runs[mode].append(run_sighting(mode, int(seed), duration_s, sensors_config=sensors, ekf_params=params))
    return runs


def summarize(runs: dict[str, list[SightingRun]], settle_s: float = 30.0) -> str:
    """Text table of a Monte Carlo: drift per mode (mean ± std over runs), and for the EKF
    the run- and time-averaged NEES against its 95 % chi-square interval."""
    from scipy.stats import chi2

    lines = []
    for mode, rs in runs.items():
        d = np.array([r.final_drift_deg for r in rs])
        rate = np.array([r.drift_rate_last_deg_h() for r in rs])
        lines.append(f"{mode:9s} {len(rs)} runs: drift at {rs[0].duration_s:g} s [deg] az {np.mean(d[:, 0]):+.4f} ± "
                     f"{np.std(d[:, 0]):.4f}, el {np.mean(d[:, 1]):+.4f} ± {np.std(d[:, 1]):.4f}; |drift| mean "
                     f"{np.mean(np.abs(d[:, 0])):.4f} / {np.mean(np.abs(d[:, 1])):.4f}; "
                     f"|rate last 60 s| mean [deg/h] {np.mean(np.abs(rate[:, 0])):.2f} / {np.mean(np.abs(rate[:, 1])):.2f}")
        n = len(rs)
        k = min(len(r.t_ekf) for r in rs)
        late = rs[0].t_ekf[:k] >= settle_s
        for name, dof in (("nees", 6), ("nees_bias", 2)):
            avg = float(np.mean(np.mean([getattr(r, name)[:k] for r in rs], axis=0)[late]))
            lo, hi = chi2.ppf([0.025, 0.975], n * dof) / n
            lines.append(f"          {name} ({dof} dof) time- and run-averaged {avg:.3f}; 95% interval of an "
                         f"{n}-run average [{lo:.3f}, {hi:.3f}] -> {'inside' if lo <= avg <= hi else 'OUTSIDE'}")
        within = np.array([np.mean(np.abs(r.bias_est[r.t_ekf >= settle_s, 1:] - r.bias_true[r.t_ekf >= settle_s, 1:])
                                   <= 3 * r.bias_sigma[r.t_ekf >= settle_s, 1:], axis=0) for r in rs])
        lines.append(f"          bias within ±3σ after {settle_s:g} s (q, r): mean {np.round(within.mean(axis=0), 4)}, "
                     f"worst run {np.round(within.min(axis=0), 4)}")
    return "\n".join(lines)


def main(argv: Sequence[str] | None = None) -> int:
    import argparse

    ap = argparse.ArgumentParser(
        prog="python -m gimbal_sim.experiments.sighting_loop",
        description="Paper 1 headline experiment in one Python loop (no ROS): LOS drift without and with the "
                    "gyro-bias EKF fed back, and with the LOS-hold outer loop; a Monte Carlo over seeds.")
    ap.add_argument("--monte-carlo", type=int, default=1, metavar="N", help="runs per mode (seeds 1..N)")
    ap.add_argument("--duration", type=float, default=120.0, help="simulated time per run [s]")
    ap.add_argument("--modes", nargs="+", default=list(MODES), choices=MODES)
    ap.add_argument("--correlated-ins", action="store_true",
                    help="Gauss-Markov INS attitude errors (tau 300 s) and the 9-state EKF instead of paper 1's white")
    a = ap.parse_args(argv)
    runs = monte_carlo(range(1, a.monte_carlo + 1), a.duration, a.modes, a.correlated_ins)
    print(summarize(runs))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
