"""Paper 1's headline experiment as a campaign declaration: scenario ``sighting_land_vehicle``
(vehicle, sensors, LOS controller and bias EKF, docs/spec.md §3.1) with the EKF's estimate not
fed back (``off``: variant ``ekf_off``), fed back (``feedback``: ``ekf_on``), or fed back with
the LOS-hold outer loop on the EKF's attitude (``los_hold``: scenario ``sighting_los_hold``,
the same one with ``los_rate_controller.mode: los_hold``), over seeds.

Each run is the scenario's, on the one engine (``engine: core``, :mod:`gimbal_sim.core.engine_run`:
the graph's bag) or in the node graph (``engine: graph``); its figures are the ``sighting``
report's, computed from the run's bag (:mod:`gimbal_sim.reports.sighting`: LOS drift against
−∫ true gyro bias dt, the (b_q, b_r) NEES from the EKF's recorded σ, the share within ±3σ), and
the table below from the runs' reports. ``ins`` picks the host INS's attitude errors
(:data:`INS_CASES`: the scenario's Schuler-correlated INS, paper 1's literal white reading, or
first-order Gauss-Markov with τ 300 s) and ``ins_error_states`` the 9-state EKF that models
correlated ones, as scenario values.

LOS drift (truth): the LOS (m-frame x axis) carried to the inertial frame (NED at t = 0), as
azimuth and elevation relative to the initial ones; azimuth cross-elevation (Δaz · cos el0),
so that without the EKF both components equal minus the integral of the true gyro bias
(q for elevation, r for azimuth).
"""
from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from ..campaign.report import stats
from ..campaign.spec import CampaignSpec
from ..campaign.experiment import ExperimentCampaign, GraphEquivalent, numbered_table, run_metrics
from ..campaign.runner_cli import add_engine_arguments, campaign_dir, run_for_cli
from ..graph.scenario import ScenarioError, apply_set, load, variant
from .engine_runs import run_on_engine

MODES = ("off", "feedback", "los_hold")
SETTLE_S = 30.0   # the bias figures are taken after the EKF's settling [s]
#: the host INS's attitude errors as scenario values: the scenario's own (Schuler), paper 1's
#: literal white reading, and first-order Gauss-Markov errors with τ 300 s
INS_CASES = {
    "schuler": (("sensor_models.ins_attitude_model", "schuler"), ("sensor_models.ins_attitude_tau_s", 3600.0)),
    "white": (("sensor_models.ins_attitude_model", "gauss_markov"), ("sensor_models.ins_attitude_tau_s", 0.001)),
    "gauss_markov": (("sensor_models.ins_attitude_model", "gauss_markov"), ("sensor_models.ins_attitude_tau_s", 300.0)),
}


def scenario_values(options: dict[str, Any]) -> tuple[float, tuple[tuple[str, Any], ...]]:
    """The options of :data:`CAMPAIGN` as the scenario's: the duration, the ``ins`` case's
    values (:data:`INS_CASES`) and the EKF's INS-error states."""
    return options["duration_s"], INS_CASES[options["ins"]] + (
        (("gyro_bias_ekf.ins_error_states", True),) if options["ins_error_states"] else ())


def summarize(runs: dict[str, list[tuple[int, dict]]], settle_s: float = SETTLE_S) -> str:
    """Text table of a Monte Carlo (per mode: [(seed, the run's report metrics)]): drift per
    mode (mean ± std over runs), and for the EKF the run- and time-averaged NEES against its
    95 % chi-square interval (the (b_q, b_r) NEES from the recorded σ; the 6-state NEES only
    when a run's metrics carry it, which needs the EKF's full covariance, not in its bag)."""
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
                lines.append(f"          {name} ({dof} dof): not in the runs' bags (the EKF publishes σ, "
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


#: The Monte Carlo over seeds as campaigns: scenario ``sighting_land_vehicle``'s runs (``off``,
#: ``feedback``) and ``sighting_los_hold``'s (``los_hold``, the same scenario with the outer
#: loop), on either engine, each with its bag and ``sighting`` report.
CAMPAIGN = ExperimentCampaign(
    name="sighting_loop", variants=MODES[:2], defaults={"duration_s": 120.0, "ins": "schuler",
                                                                  "ins_error_states": False}, run=None,
    graph=GraphEquivalent("sighting_land_vehicle", {"off": "ekf_off", "feedback": "ekf_on"},
                          ("duration_s", "ins", "ins_error_states"), scenario_values),
    table=numbered_table(summarize))
LOS_HOLD_CAMPAIGN = ExperimentCampaign(
    name="sighting_loop_los_hold", variants=MODES[2:], defaults=dict(CAMPAIGN.defaults), run=None,
    graph=GraphEquivalent("sighting_los_hold", {"los_hold": None}, ("duration_s", "ins", "ins_error_states"), scenario_values))


#: the headline's cases: the INS cases with paper 1's 6-state EKF, and the Schuler INS with the
#: 9-state EKF that models correlated INS errors
HEADLINE_CASES = {"schuler": INS_CASES["schuler"], "white": INS_CASES["white"],
                  "schuler, 9-state EKF": INS_CASES["schuler"] + (("gyro_bias_ekf.ins_error_states", True),)}
#: the report's topics a headline run records (the truth at 10 Hz: the figures are its final values)
HEADLINE_RECORD = {"/truth/gimbal/imu": 10.0, "/truth/gimbal/gyro_bias": 10.0}


def headline_table(seeds: Sequence[int], out: Path, cases: Sequence[str] = tuple(HEADLINE_CASES),
                   scenario: str = "sighting_land_vehicle", duration_s: float = 120.0,
                   settings: Sequence[str] = ()) -> str:
    """Paper 1's headline over ``seeds``: ``scenario``'s ``ekf_off`` and ``ekf_on`` runs of
    ``duration_s`` (``sighting_land_vehicle_100hz``: the paper's 100 Hz loop) in each case (:data:`HEADLINE_CASES`)
    and with ``settings`` (``NODE.PARAM=VALUE``, after the case's) on the engine, each run's bag (the truth
    LOS and bias at 10 Hz) under ``out``; per case and variant, |drift| at the run's end
    (azimuth and elevation pooled per run), its seed mean with the 95 % Student-t interval,
    and the worst seed."""
    from tqdm import tqdm

    rows = ["| case | EKF | runs | mean \\|drift\\| at the end [deg] | 95 % interval of the mean | worst seed [deg] |",
            "| --- | --- | --- | --- | --- | --- |"]
    jobs = [(c, v, seed) for c in cases for v in ("ekf_off", "ekf_on") for seed in seeds]
    drift: dict[tuple[str, str], list[float]] = {}
    for ins, v, seed in tqdm(jobs, desc="headline runs", unit="run"):
        s = dataclasses.replace(variant(load(scenario), v), duration_s=duration_s)
        for item in (*(f"{key}={value}" for key, value in HEADLINE_CASES[ins]), *settings):
            s = apply_set(s, item)
        s = dataclasses.replace(s, seed=seed, record=list(HEADLINE_RECORD), record_rates_hz=dict(HEADLINE_RECORD))
        d = run_on_engine(s, out / f"{ins.replace(', ', '_').replace('-', '_')}_{v}_seed{seed}")["sighting"]["final_drift_deg"]
        drift.setdefault((ins, v), []).append((abs(d["azimuth"]) + abs(d["elevation"])) / 2.0)
    for (ins, v), d in drift.items():
        st = stats(d)
        lo, hi = st["ci95"]
        rows.append(f"| {ins} | {v} | {st['n']} | {st['mean']:.3f} | [{lo:.3f}, {hi:.3f}] | {st['max']:.3f} |")
    return "\n".join(rows)


def main(argv: Sequence[str] | None = None) -> int:
    import argparse

    ap = argparse.ArgumentParser(
        prog="python -m gimbal_sim.experiments.sighting_loop",
        description="Paper 1 headline experiment: LOS drift without and with the gyro-bias EKF fed back, and "
                    "with the LOS-hold outer loop; a Monte Carlo over seeds of scenarios sighting_land_vehicle "
                    "(ekf_off, ekf_on) and sighting_los_hold, run as campaigns (gimbal-campaign's engine: --jobs, "
                    "--scheduler, --out, --resume) on the one engine (default, no ROS) or the real nodes "
                    "(--engine graph); each run keeps its bag and report, the table comes from the reports.")
    ap.add_argument("--monte-carlo", type=int, default=1, metavar="N", help="runs per mode (seeds 1..N)")
    ap.add_argument("--duration", type=float, default=120.0, help="simulated time per run [s]")
    ap.add_argument("--modes", nargs="+", default=None, choices=MODES,
                    help=f"default: {' '.join(MODES)}")
    ap.add_argument("--ins", choices=list(INS_CASES), default="schuler",
                    help="host INS attitude errors: schuler (the scenario's, Schuler-correlated tilt), white "
                         "(paper 1's literal reading), gauss_markov (first order, tau 300 s)")
    ap.add_argument("--ins-error-states", action="store_true",
                    help="the 9-state EKF that models correlated INS attitude errors (ins_error_states)")
    ap.add_argument("--headline", type=int, metavar="N", default=0,
                    help="instead: the headline table over seeds 1..N, Schuler and white INS, EKF off and on, on the "
                         "engine with light bags (the truth at 10 Hz) under --out, runs of --duration")
    ap.add_argument("--headline-scenario", default="sighting_land_vehicle",
                    choices=["sighting_land_vehicle", "sighting_land_vehicle_100hz"],
                    help="the headline's scenario (sighting_land_vehicle_100hz: the paper's 100 Hz loop at 4 kHz)")
    add_engine_arguments(ap, graph=True)
    a = ap.parse_args(argv)
    if a.headline:
        for item in a.set or ():
            try:
                apply_set(load(a.headline_scenario), item)
            except ScenarioError as exc:
                ap.error(str(exc))
        with campaign_dir(a.out) as out:
            print(headline_table(range(1, a.headline + 1), out, scenario=a.headline_scenario,
                                 duration_s=a.duration, settings=a.set or ()))
        return 0
    if a.monte_carlo < 1 or not 0 < a.duration < float("inf"):
        ap.error("--monte-carlo must be >= 1 and --duration a finite number > 0")
    modes = a.modes or list(MODES)
    options = (("duration_s", a.duration), ("ins", a.ins), ("ins_error_states", a.ins_error_states))
    runs: dict[str, list[tuple[int, dict]]] = {}
    with campaign_dir(a.out) as out:
        for exp, where in ((CAMPAIGN, out), (LOS_HOLD_CAMPAIGN, out / "los_hold")):
            variants = tuple(m for m in modes if m in exp.variants)
            if variants:
                spec = CampaignSpec(scenario="", experiment=exp.name, seeds=tuple(range(1, a.monte_carlo + 1)),
                                    variants=variants, engine=a.engine, mode=a.mode, options=options)
                runs.update(run_metrics(run_for_cli(ap, a, spec, where, exp, run_on_engine)))
        print(summarize({m: runs[m] for m in modes if m in runs}))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
