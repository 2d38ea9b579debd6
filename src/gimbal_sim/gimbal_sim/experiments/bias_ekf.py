"""An analysis runner (not a scenario): the gyro-bias EKF open loop on the engine's one loop
(:func:`..core.core_loop.run_stages`): truth + sensors -> GyroBiasEkf.

The sensor and EKF stages are the graph's (:mod:`..core.core_stages`); the gimbal is held by an
idealised stabilizer that uses the *true* attitude and rates
(:class:`..core.core_ideal.TruthStabilizer`: the EKF's accuracy hardly depends on the
controller, and keeping it out of the loop makes the estimator the only thing measured).
The EKF estimates are not fed back ("open loop"). It stays a runner rather than a scenario
because no node holds a gimbal from the truth (a simulator's shortcut, not a capability a
user deploys) and its NEES needs what no bag carries: the EKF's full covariance and the INS
model's true attitude errors. It writes no bag; the published paper 1 figures come from the
scenarios' bags (docs/results/paper1.md).

    run_open_loop_ekf(seed, duration_s, sensors_config) -> BiasEkfRun
    run_monte_carlo(seeds, duration_s, sensors_config)  -> MonteCarloSummary
    python -m gimbal_sim.experiments.bias_ekf --runs 20 --duration 120 [--general]

Truth used for the metrics, at each EKF update t:
ψ = log(C_true Ĉᵀ) (the filter's attitude error convention); b_q, b_r =
``GimbalGyroSample.true_bias``; b_x = cos(ψt+ψm) b_p + sin(ψt+ψm) b_q of the INS gyro's
true bias (``InsSample.true_gyro_bias``), the quantity the roll-channel state models.
NEES uses the 6 paper states (ψ, b) and, separately, the (b_q, b_r) pair.
"""
from __future__ import annotations

import argparse
import math
from dataclasses import dataclass, replace
from typing import Sequence

import numpy as np
from scipy.stats import chi2

from gimbal_estimators.gyro_bias_ekf import Counters, EkfOutput, GyroBiasEkf, GyroBiasEkfParams
from gimbal_estimators.gyro_bias_ekf_model import GYRO_BIAS, N_STATES_INS, PSI_BIAS
from gimbal_estimators.gyro_bias_ekf_stamp import EkfInput
from gimbal_kinematics.maths.rotations import quat_to_dcm, rotation_vector_from_dcm
from gimbal_kinematics.maths.units import DEG_H
from gimbal_kinematics.timing.sync import RateSync

from ..core.core_ideal import TruthStabilizer, truth_stabilizer_stage
from ..core.core_loop import run_stages
from ..core.core_stages import Bus, ekf_stage, suite_stage, timed
from ..world.sensor_suite import SensorSuite, SensorSuiteConfig
from ..world.sensors import GyroParams
from ..world.vehicle import VehicleConfig, VehicleCore, VehicleTruth


#: "Beyond the paper" gyro for the generality check: 30 °/h bias, 10 °/h Gauss-Markov
#: with τ = 300 s, the paper's ARW.
GENERAL_GIMBAL_GYRO = GyroParams(bias_deg_h=30.0, arw_deg_rt_h=0.15, bias_instability_deg_h=10.0,
                                 bias_instability_tau_s=300.0)


def _bias_prior_deg_h(g: GyroParams) -> float:
    """1σ prior of a lumped bias: turn-on magnitude (a datasheet bound), run-to-run σ and
    the instability, root-sum-squared."""
    given = max(abs(float(b)) for b in g.bias_deg_h)  # type: ignore[union-attr]
    return max(math.sqrt(given**2 + g.bias_sigma_deg_h**2 + g.bias_instability_deg_h**2), 1e-3)


def ekf_params_from_sensors(sensors: SensorSuiteConfig, lat_deg: float = 0.0, **overrides: object) -> GyroBiasEkfParams:
    """EKF parameters from the sensor specification (as an engineer would from datasheets).

    Rate random walk and scale-factor terms are not modelled by the filter; ``overrides``
    replace any :class:`GyroBiasEkfParams` field.
    """
    g, ins = sensors.gimbal_gyro, sensors.ins
    ig = ins.gyro
    enc = sensors.encoder
    quantum_deg = 360.0 / enc.counts_per_rev if enc.counts_per_rev > 0 else 0.0
    kw: dict[str, object] = dict(
        lat_deg=lat_deg,
        gyro_arw_deg_rt_h=g.arw_deg_rt_h,
        gyro_bias_sigma_deg_h=_bias_prior_deg_h(g),
        gyro_bias_instability_deg_h=g.bias_instability_deg_h,
        gyro_bias_tau_s=g.bias_instability_tau_s,
        roll_arw_deg_rt_h=ig.arw_deg_rt_h,
        roll_bias_sigma_deg_h=_bias_prior_deg_h(ig),
        roll_bias_instability_deg_h=ig.bias_instability_deg_h,
        roll_bias_tau_s=ig.bias_instability_tau_s,
        ins_roll_pitch_rms_deg=ins.roll_pitch_rms_deg,
        ins_heading_rms_deg=ins.heading_rms_deg,
        ins_attitude_tau_s=ins.attitude_tau_s,
        encoder_noise_deg=max(math.sqrt(enc.noise_deg**2 + quantum_deg**2 / 12.0), 1e-4),
    )
    kw.update(overrides)
    return GyroBiasEkfParams(**kw)  # type: ignore[arg-type]


@dataclass(frozen=True)
class BiasEkfRun:
    """Metrics of one run. Arrays are sampled at the EKF updates kept (every
    ``record_every_s``); biases in rad/s, angles in rad.

    ``within_3sigma`` (3,): fraction of samples with t ≥ ``settle_s`` whose bias error is
    within ±3σ, per axis (x, q, r). ``final_bias_error_deg_h`` (3,): estimate − truth at
    the end [°/h]. ``nees_full``: NEES of all 9 states (truth of the INS-error states from
    the INS model; NaN for the 6-state filter). ``mean_nees_state`` / ``mean_nees_bias``:
    time-averaged NEES for t ≥ settle_s of the 6 paper states (6 dof) and of (b_q, b_r).
    ``ekf_us_per_gyro``: EKF wall time per gyro sample (all handlers) [µs].
    """

    seed: int
    duration_s: float
    settle_s: float
    t: np.ndarray
    bias_est: np.ndarray
    bias_sigma: np.ndarray
    bias_true: np.ndarray
    att_err: np.ndarray
    att_sigma: np.ndarray
    nees_state: np.ndarray
    nees_bias: np.ndarray
    nees_full: np.ndarray
    within_3sigma: np.ndarray
    final_bias_error_deg_h: np.ndarray
    mean_nees_state: float
    mean_nees_bias: float
    counters: Counters
    ekf_us_per_gyro: float


def paper1_land_vehicle(seed: int, duration_s: float, sensors_config: SensorSuiteConfig | None,
                        sim_rate_hz: float, ins_rate_hz: float, initial_joints_deg: Sequence[float],
                        lat_deg: float) -> tuple[VehicleCore, SensorSuiteConfig]:
    """Paper 1's land vehicle as the runners set it up (the vehicle and sensors of scenario
    ``sighting_land_vehicle``): the vehicle core, and ``sensors_config`` (default
    ``SensorSuiteConfig()``) with INS, gimbal gyro and encoders, ``seed``, the gyro and
    encoders at ``sim_rate_hz`` and the INS at ``ins_rate_hz``."""
    base = sensors_config if sensors_config is not None else SensorSuiteConfig()
    sensors = replace(base, sensors=("ins", "gimbal_gyro", "encoders"), seed=seed, sim_rate_hz=sim_rate_hz,
                      gimbal_gyro_rate_hz=sim_rate_hz, encoder_rate_hz=sim_rate_hz, ins_rate_hz=ins_rate_hz)
    core = VehicleCore(VehicleConfig(profile="paper1_land_vehicle", profile_params={"lat_deg": lat_deg},
                                     sim_rate_hz=sim_rate_hz, duration_s=duration_s,
                                     initial_joints_deg=tuple(initial_joints_deg)))
    return core, sensors


class EkfRecorder:
    """Observer of the run's n steps (k < n): at each EKF output, once per ``record_every_s``,
    the estimate, its σ, the truth (module docstring) and the NEES; the EKF's counters
    after step n − 1."""

    def __init__(self, ekf: GyroBiasEkf, suite: SensorSuite, n: int, record_every_s: float) -> None:
        self.ekf, self.suite, self.n, self.every = ekf, suite, n, record_every_s
        self.rec: list[tuple] = []
        self.next_rec = 0.0
        self.ins_bias = (0.0, 0.0, 0.0)
        self.gyro_bias = (0.0, 0.0)
        self.n_gyro = 0
        self.counters = ekf.counters

    def __call__(self, bus: Bus) -> None:
        if bus.gyro is not None:
            self.n_gyro += 1  # of every step, for the EKF's time per gyro sample
        if bus.k >= self.n:
            return
        if bus.ins is not None:
            self.ins_bias = bus.ins.true_gyro_bias
        if bus.gyro is not None:
            self.gyro_bias = bus.gyro.true_bias
        if bus.k == self.n - 1:
            self.counters = self.ekf.counters
        out = bus.ekf
        if out is not None and out.t >= self.next_rec - 1e-9:
            self.next_rec = out.t + self.every
            self._record(bus.truth, out)

    def _record(self, truth: VehicleTruth, out: EkfOutput) -> None:
        ekf, ins_bias = self.ekf, self.ins_bias
        az = truth.joint_position[0] + truth.joint_position[1]
        b_true = np.array([math.cos(az) * ins_bias[0] + math.sin(az) * ins_bias[1], *self.gyro_bias])
        psi = rotation_vector_from_dcm(quat_to_dcm(truth.quat_nm) @ quat_to_dcm(out.quat_nm).T)
        e6 = np.concatenate((psi, b_true - out.bias))
        P6 = ekf.P[PSI_BIAS, PSI_BIAS]
        if ekf.n_states == N_STATES_INS:
            e_all = np.concatenate((e6, self.suite.ins.attitude_error - ekf.ins_error))
            nees_all = float(e_all @ np.linalg.solve(ekf.P, e_all))
        else:
            nees_all = math.nan
        self.rec.append((out.t, out.bias, out.bias_sigma, b_true, psi, np.sqrt(np.diag(out.attitude_cov)),
                         float(e6 @ np.linalg.solve(P6, e6)),
                         float(e6[GYRO_BIAS] @ np.linalg.solve(P6[GYRO_BIAS, GYRO_BIAS], e6[GYRO_BIAS])), nees_all))

    def run(self, seed: int, duration_s: float, settle_s: float, ekf_s: float) -> BiasEkfRun:
        """The run's metrics (:class:`BiasEkfRun`); ``ekf_s`` the EKF's wall time [s]."""
        rec = self.rec
        t = np.array([r[0] for r in rec])
        est, sig, tru = (np.array([r[i] for r in rec]) for i in (1, 2, 3))
        att, att_sig = np.array([r[4] for r in rec]), np.array([r[5] for r in rec])
        nees_s, nees_b, nees_f = (np.array([r[i] for r in rec]) for i in (6, 7, 8))
        late = t >= settle_s
        within = (np.mean(np.abs(est[late] - tru[late]) <= 3.0 * sig[late], axis=0) if late.any()
                  else np.full(3, np.nan))
        return BiasEkfRun(
            seed=seed, duration_s=duration_s, settle_s=settle_s, t=t, bias_est=est, bias_sigma=sig, bias_true=tru,
            att_err=att, att_sigma=att_sig, nees_state=nees_s, nees_bias=nees_b, nees_full=nees_f,
            within_3sigma=within,
            final_bias_error_deg_h=(est[-1] - tru[-1]) / DEG_H,
            mean_nees_state=float(np.mean(nees_s[late])) if late.any() else math.nan,
            mean_nees_bias=float(np.mean(nees_b[late])) if late.any() else math.nan,
            counters=self.counters, ekf_us_per_gyro=1e6 * ekf_s / max(self.n_gyro, 1),
        )


def run_open_loop_ekf(
    seed: int,
    duration_s: float = 120.0,
    sensors_config: SensorSuiteConfig | None = None,
    ekf_params: GyroBiasEkfParams | None = None,
    sim_rate_hz: float = 1000.0,
    ins_rate_hz: float = 100.0,
    initial_joints_deg: tuple[float, float] = (20.0, 10.0),
    scan_amplitude_deg: float = 0.0,
    lat_deg: float = 0.0,
    settle_s: float = 30.0,
    record_every_s: float = 0.1,
) -> BiasEkfRun:
    """One paper 1 land-vehicle run with the EKF open loop (module docstring), on the core
    engine: the sensor and EKF stages of the graph's nodes, the gimbal held by
    :func:`..core_ideal.truth_stabilizer_stage`, :class:`EkfRecorder` observing.

    ``sensors_config`` defaults to ``SensorSuiteConfig()`` (paper 1's sensors); its seed
    and rates are replaced by ``seed``, ``sim_rate_hz`` (gyro and encoders at the sim rate)
    and ``ins_rate_hz``. ``ekf_params`` defaults to :func:`ekf_params_from_sensors`.
    """
    core, sensors = paper1_land_vehicle(seed, duration_s, sensors_config, sim_rate_hz, ins_rate_hz,
                                        initial_joints_deg, lat_deg)
    params = ekf_params if ekf_params is not None else ekf_params_from_sensors(sensors, lat_deg)
    suite = SensorSuite(sensors)
    ekf = EkfInput(GyroBiasEkf(params), RateSync)
    estimate, ekf_s = timed(ekf_stage(ekf))
    stabilize = truth_stabilizer_stage(TruthStabilizer(core.config.dt, scan_amplitude_deg=scan_amplitude_deg))
    recorder = EkfRecorder(ekf, suite, core.config.n_steps, record_every_s)
    run_stages(core, [suite_stage(suite), estimate, stabilize], observer=recorder)
    return recorder.run(seed, duration_s, settle_s, ekf_s[0])


@dataclass(frozen=True)
class MonteCarloSummary:
    """N-run consistency figures (t ≥ settle_s).

    ``anees_state``/``anees_bias``: NEES averaged over runs and time (6 and 2 dof), with
    the 95 % interval ``chi2.ppf([0.025, 0.975], N·dof)/N`` of an N-run average
    (``*_interval``). Time-averaging shrinks the spread further, so this interval is the
    lenient one; ``*_fraction_in`` is the stricter check: the fraction of sample times at
    which the N-run average NEES lies inside the interval (≈ 0.95 when consistent).
    ``within_3sigma_min`` (3,): worst run's per-axis fraction within ±3σ. ``anees_full``:
    the same average for all 9 states (NaN for the 6-state filter).
    """

    n_runs: int
    anees_state: float
    anees_state_interval: tuple[float, float]
    anees_state_fraction_in: float
    anees_bias: float
    anees_bias_interval: tuple[float, float]
    anees_bias_fraction_in: float
    anees_full: float
    anees_full_interval: tuple[float, float]
    within_3sigma_mean: np.ndarray
    within_3sigma_min: np.ndarray
    final_bias_error_rms_deg_h: np.ndarray
    runs: tuple[BiasEkfRun, ...]


def summarize(runs: Sequence[BiasEkfRun]) -> MonteCarloSummary:
    """Consistency figures of several runs of equal length (see :class:`MonteCarloSummary`)."""
    n = len(runs)
    k = min(len(r.t) for r in runs)
    late = runs[0].t[:k] >= runs[0].settle_s
    out = {}
    for name, dof in (("state", 6), ("bias", 2)):
        a = np.mean([getattr(r, "nees_" + name)[:k] for r in runs], axis=0)[late]
        lo, hi = chi2.ppf([0.025, 0.975], n * dof) / n
        out[name] = (float(np.mean(a)), (float(lo), float(hi)), float(np.mean((a >= lo) & (a <= hi))))
    full = float(np.mean(np.mean([r.nees_full[:k] for r in runs], axis=0)[late]))
    full_iv = tuple(float(v) for v in chi2.ppf([0.025, 0.975], n * 9) / n)
    w = np.array([r.within_3sigma for r in runs])
    fe = np.array([r.final_bias_error_deg_h for r in runs])
    return MonteCarloSummary(n, *out["state"], *out["bias"], full, full_iv, w.mean(axis=0), w.min(axis=0),
                             np.sqrt(np.mean(fe**2, axis=0)), tuple(runs))


def run_monte_carlo(seeds: Sequence[int], duration_s: float = 120.0, **kwargs: object) -> MonteCarloSummary:
    """:func:`run_open_loop_ekf` for each seed (same keyword arguments), then :func:`summarize`."""
    return summarize([run_open_loop_ekf(int(s), duration_s, **kwargs) for s in seeds])  # type: ignore[arg-type]


def _print_summary(label: str, mc: MonteCarloSummary) -> None:
    print(f"== {label}: {mc.n_runs} runs")
    print(f"  ANEES 6-state {mc.anees_state:.3f} in [{mc.anees_state_interval[0]:.3f}, "
          f"{mc.anees_state_interval[1]:.3f}]; fraction of times inside {mc.anees_state_fraction_in:.3f}")
    print(f"  ANEES bias(q,r) {mc.anees_bias:.3f} in [{mc.anees_bias_interval[0]:.3f}, "
          f"{mc.anees_bias_interval[1]:.3f}]; fraction of times inside {mc.anees_bias_fraction_in:.3f}")
    print(f"  ANEES all 9 states {mc.anees_full:.3f} in [{mc.anees_full_interval[0]:.3f}, "
          f"{mc.anees_full_interval[1]:.3f}]")
    print(f"  within ±3σ after settle (x, q, r): mean {np.round(mc.within_3sigma_mean, 4)}, "
          f"worst run {np.round(mc.within_3sigma_min, 4)}")
    print(f"  final bias error RMS over runs [°/h] (x, q, r): {np.round(mc.final_bias_error_rms_deg_h, 3)}")
    for r in mc.runs:
        print(f"    seed {r.seed:3d}: final err [°/h] {np.round(r.final_bias_error_deg_h, 2)}  "
              f"NEES6 {r.mean_nees_state:6.2f}  NEESb {r.mean_nees_bias:5.2f}  "
              f"in3σ {np.round(r.within_3sigma, 3)}  {r.ekf_us_per_gyro:5.1f} µs/gyro")


def main(argv: Sequence[str] | None = None) -> None:
    ap = argparse.ArgumentParser(prog="python -m gimbal_sim.experiments.bias_ekf",
                                 description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=20)
    ap.add_argument("--first-seed", type=int, default=1)
    ap.add_argument("--duration", type=float, default=120.0)
    ap.add_argument("--sim-rate", type=float, default=1000.0)
    ap.add_argument("--general", action="store_true",
                    help="gyro with 30 °/h bias, 10 °/h Gauss-Markov τ = 300 s instead of paper 1's")
    ap.add_argument("--paper-r", action="store_true", help="paper 1's white INS noise (no INS-error states)")
    ap.add_argument("--scan", type=float, default=0.0, help="elevation scan amplitude [°]")
    a = ap.parse_args(argv)
    sensors = SensorSuiteConfig(gimbal_gyro=GENERAL_GIMBAL_GYRO) if a.general else SensorSuiteConfig()
    params = ekf_params_from_sensors(sensors, ins_error_states=not a.paper_r)
    seeds = range(a.first_seed, a.first_seed + a.runs)
    mc = run_monte_carlo(seeds, a.duration, sensors_config=sensors, ekf_params=params, sim_rate_hz=a.sim_rate,
                         scan_amplitude_deg=a.scan)
    _print_summary(("general gyro" if a.general else "paper 1 gyro") + (", paper R" if a.paper_r else ""), mc)


if __name__ == "__main__":
    main()
