"""Paper 1's headline experiment without ROS: vehicle, sensors, LOS controller and bias EKF
on the core engine (:func:`..core_loop.run_stages`, the stages of the graph's nodes), with
the lockstep graph's timing (docs/spec.md §3.1, scenarios ``sighting_land_vehicle`` and,
for the LOS-hold outer loop, ``sighting_los_hold``).

Per step k: the sensors sample the truth of step k; the EKF takes the encoders, the INS
(when due) and the gyro of stamp k, and at INS steps returns its estimate stamped k; the
controller then uses the newest estimate (that of stamp k at INS steps) and its command is
held over [t_k, t_{k+1}]. This is what the graph does when the controller waits, at INS
steps, for the EKF's output of the same stamp; the runner differs from a scenario run only
in taking its sensor and EKF parameters as objects (:func:`paper1_sensors`) and in its
observer (:class:`SightingRecorder`), which keeps the EKF's covariance for the NEES.

LOS drift (truth): the LOS (m-frame x axis) carried to the inertial frame (NED at t = 0,
:func:`gimbal_kinematics.los.inertial_los`), as azimuth and elevation relative to the
initial ones. The azimuth drift is reported cross-elevation (Δaz · cos el0), the angle the
LOS swept about the m-z axis, so that without the EKF both components equal minus the
integral of the true gyro bias (q for elevation, r for azimuth).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Sequence

import numpy as np

from gimbal_control.los_hold import LosHold, LosHoldParams
from gimbal_control.los_rate_controller import LosRateController, LosRateControllerParams
from gimbal_estimators.gyro_bias_ekf import EkfOutput, GyroBiasEkf, GyroBiasEkfParams
from gimbal_estimators.gyro_bias_ekf_model import GYRO_BIAS, PSI_BIAS
from gimbal_kinematics.rotations import quat_to_dcm, rotation_vector_from_dcm
from gimbal_kinematics.los import inertial_los, los_drift, los_from_quat

from ..core.core_loop import run_stages
from ..core.core_stages import Bus, controller_stage, ekf_stage, suite_stage
from ..world.sensor_suite import GimbalGyroSample, SensorSuite, SensorSuiteConfig
from ..world.sensors import InsParams
from ..world.vehicle import VehicleTruth
from .bias_ekf import ekf_params_from_sensors, paper1_land_vehicle
from ..campaign.spec import CampaignSpec
from ..campaign.experiment import ExperimentCampaign, GraphEquivalent, run_metrics
from ..campaign.runner_cli import add_engine_arguments, campaign_dir, run_for_cli

MODES = ("off", "feedback", "los_hold")
SETTLE_S = 30.0   # the bias figures are taken after the EKF's settling [s]


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


class SightingRecorder:
    """Observer of the run's n steps (k < n): the truth's C_nm and −∫ true gyro bias dt every
    ``record_every`` steps and at the last; at each EKF output the estimate, σ, the truth
    (:class:`SightingRun`) and the NEES, with ``ekf``'s covariance."""

    def __init__(self, ekf: GyroBiasEkf, suite: SensorSuite, n: int, dt: float, record_every: int) -> None:
        self.ekf, self.suite, self.n, self.dt, self.every = ekf, suite, n, dt, record_every
        self.t: list[float] = []
        self.quat: list = []
        self.bias_int: list[tuple[float, float]] = []
        self.ekf_rec: list[tuple] = []
        self._int = [0.0, 0.0]

    def __call__(self, bus: Bus) -> None:
        k, truth, gyro, out = bus.k, bus.truth, bus.gyro, bus.ekf
        if k >= self.n:
            return
        if out is not None:
            self._record_estimate(truth, gyro, out)
        self._int[0] -= gyro.true_bias[1] * self.dt  # r -> azimuth
        self._int[1] -= gyro.true_bias[0] * self.dt  # q -> elevation
        if k % self.every == 0 or k == self.n - 1:
            self.t.append(truth.t)
            self.quat.append(truth.quat_nm)
            self.bias_int.append(tuple(self._int))

    def _record_estimate(self, truth: VehicleTruth, gyro: GimbalGyroSample, out: EkfOutput) -> None:
        az = truth.joint_position[0] + truth.joint_position[1]
        b_ins = self.suite.ins.true_gyro_bias
        b_true = np.array([math.cos(az) * b_ins[0] + math.sin(az) * b_ins[1], *gyro.true_bias])
        psi = rotation_vector_from_dcm(quat_to_dcm(truth.quat_nm) @ quat_to_dcm(out.quat_nm).T)
        e6 = np.concatenate((psi, b_true - out.bias))
        P6 = self.ekf.P[PSI_BIAS, PSI_BIAS]
        self.ekf_rec.append((out.t, out.bias, out.bias_sigma, b_true, float(e6 @ np.linalg.solve(P6, e6)),
                             float(e6[GYRO_BIAS] @ np.linalg.solve(P6[GYRO_BIAS, GYRO_BIAS], e6[GYRO_BIAS]))))

    def run(self, mode: str, seed: int, duration_s: float, omega_in_n: Sequence[float], wall_s: float) -> SightingRun:
        """The run (:class:`SightingRun`); ``omega_in_n`` the n frame's inertial rate that
        carries the LOS to the inertial frame."""
        t = np.array(self.t)
        los_i = inertial_los(los_from_quat(np.array(self.quat)), t, np.asarray(omega_in_n))
        te, est, sig, tru, nees, nees_b = (np.array([r[i] for r in self.ekf_rec]) for i in range(6))
        return SightingRun(mode, seed, duration_s, t, los_drift(los_i), np.array(self.bias_int), te, est, sig, tru,
                           nees, nees_b, self.n, wall_s)


def run_sighting(mode: str = "feedback", seed: int = 1, duration_s: float = 120.0, *,
                 sensors_config: SensorSuiteConfig | None = None, ekf_params: GyroBiasEkfParams | None = None,
                 controller: LosRateControllerParams | None = None, hold: LosHoldParams | None = None,
                 sim_rate_hz: float = 1000.0, ins_rate_hz: float = 100.0,
                 initial_joints_deg: Sequence[float] = (20.0, 10.0), lat_deg: float = 0.0,
                 record_every: int = 10) -> SightingRun:
    """Run the land-vehicle scenario with the EKF ``off`` (estimated but not fed back),
    fed back (``feedback``), or fed back with the LOS-hold outer loop (``los_hold``), on the
    core engine: the stages of the graph's sensor, EKF and controller nodes
    (:mod:`..core_stages`), :class:`SightingRecorder` observing."""
    if mode not in MODES:
        raise ValueError(f"mode must be one of {MODES}, got {mode!r}")
    core, sensors = paper1_land_vehicle(seed, duration_s, sensors_config, sim_rate_hz, ins_rate_hz,
                                        initial_joints_deg, lat_deg)
    suite = SensorSuite(sensors)
    ekf = GyroBiasEkf(ekf_params if ekf_params is not None else ekf_params_from_sensors(sensors, lat_deg))
    cparams = controller if controller is not None else LosRateControllerParams(rate_hz=sim_rate_hz)
    ctrl = LosRateController(replace(cparams, feedback=mode != "off", gravity_m_s2=core.env.gravity_m_s2))
    outer = LosHold(hold if hold is not None else LosHoldParams(lat_deg=lat_deg)) if mode == "los_hold" else None
    recorder = SightingRecorder(ekf, suite, core.config.n_steps, core.config.dt, record_every)
    result = run_stages(core, [suite_stage(suite), ekf_stage(ekf), controller_stage(ctrl, sim_rate_hz, outer)],
                        observer=recorder)
    return recorder.run(mode, seed, duration_s, core.env.omega_in_n, result.wall_s)


def paper1_sensors(correlated_ins: bool = False) -> tuple[SensorSuiteConfig, GyroBiasEkfParams]:
    """Paper 1's sensors and the matching EKF: the INS attitude errors white (paper 1's
    model, τ → 0, the 6-state filter) or Gauss-Markov with τ = 300 s (``correlated_ins``,
    the 9-state filter that models them)."""
    if correlated_ins:
        sensors = SensorSuiteConfig()
        return sensors, ekf_params_from_sensors(sensors)
    sensors = SensorSuiteConfig(ins=InsParams(attitude_tau_s=1e-3))
    return sensors, ekf_params_from_sensors(sensors, ins_error_states=False)


def run_figures(run: SightingRun, settle_s: float = SETTLE_S) -> dict:
    """One run's figures, under the ``sighting`` report's names (:mod:`..reports.sighting`),
    computed from the run's series: final drift and last-60 s drift rate (az·cos el, el),
    the (b_q, b_r) NEES with the EKF's full 2×2 covariance and the share of estimates within
    ±3σ after ``settle_s``, and (core only: a bag carries σ, not the covariance) the NEES of
    the 6 paper states."""
    late = run.t_ekf >= settle_s
    d, rate = run.final_drift_deg, run.drift_rate_last_deg_h()
    err = np.abs(run.bias_est[late, 1:] - run.bias_true[late, 1:])
    within = np.mean(err <= 3 * run.bias_sigma[late, 1:], axis=0)
    return {"duration_s": run.duration_s, "wall_s": run.wall_s, "steps": run.steps,
            "sighting": {"final_drift_deg": {"azimuth": float(d[0]), "elevation": float(d[1])},
                         "drift_rate_last_60s_deg_h": {"azimuth": float(rate[0]), "elevation": float(rate[1])},
                         "bias_within_3sigma_after_30s": {"q": float(within[0]), "r": float(within[1])},
                         "bias_nees_mean_after_30s": float(np.mean(run.nees_bias[late])),
                         "nees_mean_after_30s": float(np.mean(run.nees[late]))}}


def campaign_run(mode: str, seed: int, options: dict) -> dict:
    """The campaign engine's core run (:data:`CAMPAIGN`): one mode and seed with paper 1's
    sensors, as :func:`run_figures`."""
    sensors, params = paper1_sensors(options["correlated_ins"])
    return run_figures(run_sighting(mode, seed, options["duration_s"], sensors_config=sensors, ekf_params=params))


#: The Monte Carlo over seeds as a campaign: ``engine: core`` runs :func:`campaign_run`;
#: ``engine: graph`` runs scenario ``sighting_land_vehicle`` (the same paper 1 sensors and
#: 6-state EKF; no LOS-hold variant, and its INS model is paper 1's white one).
CAMPAIGN = ExperimentCampaign(
    name="sighting_loop", variants=MODES, defaults={"duration_s": 120.0, "correlated_ins": False}, run=campaign_run,
    graph=GraphEquivalent("sighting_land_vehicle", {"off": "ekf_off", "feedback": "ekf_on"}))


def summarize(runs: dict[str, list[tuple[int, dict]]], settle_s: float = SETTLE_S) -> str:
    """Text table of a Monte Carlo (per mode: [(seed, figures)] as :func:`run_figures` gives
    them, or a graph run's report): drift per mode (mean ± std over runs), and for the EKF the
    run- and time-averaged NEES against its 95 % chi-square interval."""
    from scipy.stats import chi2

    lines = []
    for mode, rs in runs.items():
        fig = [m["sighting"] for _, m in rs]
        d = np.array([[f["final_drift_deg"]["azimuth"], f["final_drift_deg"]["elevation"]] for f in fig])
        rate = np.array([[f["drift_rate_last_60s_deg_h"]["azimuth"], f["drift_rate_last_60s_deg_h"]["elevation"]]
                         for f in fig])
        lines.append(f"{mode:9s} {len(rs)} runs: drift at {rs[0][1]['duration_s']:g} s [deg] az {np.mean(d[:, 0]):+.4f} ± "
                     f"{np.std(d[:, 0]):.4f}, el {np.mean(d[:, 1]):+.4f} ± {np.std(d[:, 1]):.4f}; |drift| mean "
                     f"{np.mean(np.abs(d[:, 0])):.4f} / {np.mean(np.abs(d[:, 1])):.4f}; "
                     f"|rate last 60 s| mean [deg/h] {np.mean(np.abs(rate[:, 0])):.2f} / {np.mean(np.abs(rate[:, 1])):.2f}")
        n = len(rs)
        for name, key, dof in (("nees", "nees_mean_after_30s", 6), ("nees_bias", "bias_nees_mean_after_30s", 2)):
            if key not in fig[0]:
                lines.append(f"          {name} ({dof} dof): not in a graph run's bag (the EKF publishes σ, "
                             "not its covariance)")
                continue
            # every run has the same EKF output times: the run average of each run's time
            # average is the time average of the run average
            avg = float(np.mean([f[key] for f in fig]))
            lo, hi = chi2.ppf([0.025, 0.975], n * dof) / n
            lines.append(f"          {name} ({dof} dof) time- and run-averaged {avg:.3f}; 95% interval of an "
                         f"{n}-run average [{lo:.3f}, {hi:.3f}] -> {'inside' if lo <= avg <= hi else 'OUTSIDE'}")
        within = np.array([[f["bias_within_3sigma_after_30s"]["q"], f["bias_within_3sigma_after_30s"]["r"]]
                           for f in fig])
        lines.append(f"          bias within ±3σ after {settle_s:g} s (q, r): mean {np.round(within.mean(axis=0), 4)}, "
                     f"worst run {np.round(within.min(axis=0), 4)}")
    return "\n".join(lines)


def main(argv: Sequence[str] | None = None) -> int:
    import argparse

    ap = argparse.ArgumentParser(
        prog="python -m gimbal_sim.experiments.sighting_loop",
        description="Paper 1 headline experiment in one Python loop (no ROS): LOS drift without and with the "
                    "gyro-bias EKF fed back, and with the LOS-hold outer loop; a Monte Carlo over seeds, run as a "
                    "campaign (gimbal-campaign's engine: --jobs, --scheduler, --out, --resume; --engine graph "
                    "runs the real nodes of scenario sighting_land_vehicle instead).")
    ap.add_argument("--monte-carlo", type=int, default=1, metavar="N", help="runs per mode (seeds 1..N)")
    ap.add_argument("--duration", type=float, default=120.0, help="simulated time per run [s]")
    ap.add_argument("--modes", nargs="+", default=None, choices=MODES,
                    help=f"default: {' '.join(MODES)} (engine core), off feedback (engine graph)")
    ap.add_argument("--correlated-ins", action="store_true",
                    help="Gauss-Markov INS attitude errors (tau 300 s) and the 9-state EKF instead of paper 1's white")
    add_engine_arguments(ap, graph=True)
    a = ap.parse_args(argv)
    if a.monte_carlo < 1 or not 0 < a.duration < float("inf"):
        ap.error("--monte-carlo must be >= 1 and --duration a finite number > 0")
    modes = a.modes or (list(MODES) if a.engine == "core" else list(CAMPAIGN.graph.variants))
    spec = CampaignSpec(scenario="", experiment=CAMPAIGN.name, seeds=tuple(range(1, a.monte_carlo + 1)),
                        variants=tuple(modes), engine=a.engine, mode=a.mode,
                        options=(("duration_s", a.duration), ("correlated_ins", a.correlated_ins)))
    with campaign_dir(a.out) as out:
        print(summarize(run_metrics(run_for_cli(ap, a, spec, out, CAMPAIGN))))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
