"""Paper 5 flexure experiment: the ship simulation on the engine's one loop (the
``sensor_models`` stage, :func:`..core.core_loop.run_stages`, no ROS) feeding
:class:`~gimbal_estimators.flexure_kf.FlexureKf`, one filter per quasi-static model on the
same LGU samples, scored against the simulator's flexure truth at every filter epoch.

Command line (prints the metrics of both models; with several seeds, a Monte Carlo table)::

    python -m gimbal_sim.experiments.flexure --duration 7200 --seeds 0
    python -m gimbal_sim.experiments.flexure --seeds 0 1 2 3 4 5 6 7 --dynamic-freq 0.5
    python -m gimbal_sim.experiments.flexure --turn --methods simplified original

``--dynamic-beta``/``--dynamic-freq`` set the dynamic-flexure band of the truth and of the
filters alike (a matched model: what is left is the information the LGUs carry).

Errors are estimate − truth; statistics use the filter epochs after ``convergence_s``
(:func:`gimbal_sim.reports.flexure.flexure_metrics`, the same scoring as the bag report).
"""
from __future__ import annotations

import argparse
import math
import time
from dataclasses import dataclass, field, replace
from collections.abc import Mapping
from typing import Any, Callable

import numpy as np

from gimbal_estimators.flexure_attitude_matching import AttitudeMatchingKf, AttitudeMatchingParams
from gimbal_estimators.flexure_estimator_params import METHODS
from gimbal_estimators.flexure_kf import QS_MODELS, FlexureKf, FlexureKfParams
from gimbal_kinematics.timing.sync import StampPairs

from ..core.core_loop import run_stages
from ..core.core_stages import Bus, suite_stage
from ..reports.flexure import flexure_metrics
from ..world.sensor_suite import SensorSuite, SensorSuiteConfig
from ..world.sensors import FlexureParams, GyroParams
from ..world.vehicle import VehicleConfig, VehicleCore
from ..campaign.spec import CampaignSpec
from ..campaign.experiment import ExperimentCampaign, GraphEquivalent, run_metrics
from ..campaign.runner_cli import add_engine_arguments, campaign_dir, run_for_cli


#: The turning manoeuvre (``ship_flexure_turn``, paper 5 Fig. 1): the paper 5 ship's rocking
#: (``paper5_ship``'s defaults) on a zigzag course, heading −20° → +20° and back every
#: ``TURN_PERIOD_S`` (a 40° turn in 100 s, at most 0.63 °/s), as ``sinusoids`` profile
#: parameters. The truth's helm flexure (:class:`FlexureParams` ``helm_*``) is the turn's
#: bending: same period, phased with the turn rate (helm phase 0: sin, yaw: −cos), of the 7′
#: amplitude paper 5 reports from Fig. 1.
TURN_PERIOD_S = 200.0
TURN_HEADING_DEG = 20.0
TURN_FLEXURE_DEG = 7.0 / 60.0
TURN_PROFILE = {
    "roll": {"terms": [{"amplitude_deg": 5.0, "period_s": 10.0}]},
    "pitch": {"terms": [{"amplitude_deg": 3.0, "period_s": 6.0}]},
    "yaw": {"terms": [{"amplitude_deg": 3.0, "period_s": 15.0},
                      {"amplitude_deg": TURN_HEADING_DEG, "period_s": TURN_PERIOD_S, "phase_rad": -math.pi / 2}]},
}
TURN_FLEXURE = {"helm_amplitude_deg": TURN_FLEXURE_DEG, "helm_period_s": TURN_PERIOD_S, "helm_phase_rad": 0.0}

#: Per-epoch series kept (each (n, 3) except ``t`` and ``d2``).
SERIES = ("t", "truth_flexure", "truth_quasi_static", "truth_bias_diff", "flexure", "flexure_sigma",
          "quasi_static", "quasi_static_sigma", "bias_diff", "bias_diff_sigma", "d2")


@dataclass
class FlexureExperimentResult:
    """Outcome for one filter (``label``: the key it was run under; ``model``: its
    quasi-static model).

    ``metrics``: figures after convergence (keys documented in :func:`flexure_metrics`);
    ``series``: the :data:`SERIES` arrays [rad, rad/s, s] thinned to ``record_period_s``;
    ``counters``: the filter's counters; ``wall_s``: wall time of the whole run (shared
    simulation included); ``filter_us_per_pair``: filter CPU time per LGU pair [µs].
    """

    label: str
    model: str
    metrics: dict[str, Any]
    series: dict[str, np.ndarray]
    counters: dict[str, int]
    reset_reasons: list[str]
    wall_s: float
    filter_us_per_pair: float
    config: dict[str, Any] = field(default_factory=dict)


def run_flexure_comparison(
    duration_s: float = 7200.0,
    seed: int = 0,
    *,
    models: tuple[str, ...] | Mapping[str, FlexureKfParams] = QS_MODELS,
    sim_rate_hz: float = 50.0,
    lgu_rate_hz: float = 10.0,
    convergence_s: float = 600.0,
    params: FlexureKfParams | None = None,
    flexure: FlexureParams | None = None,
    lgu1: GyroParams | None = None,
    lgu2: GyroParams | None = None,
    profile_params: dict[str, Any] | None = None,
    record_period_s: float = 1.0,
    gate_conventional: bool = False,
    profile: str = "paper5_ship",
) -> dict[str, FlexureExperimentResult]:
    """Run one ship simulation (paper 5 profile, host only, LGUs only) for ``duration_s``
    [s] with ``seed`` and one filter per entry of ``models`` on the same LGU samples.

    ``params`` is the base filter configuration (its ``quasi_static_model`` is replaced
    per model); ``models`` may instead map labels to complete parameter sets (tuning runs;
    an :class:`AttitudeMatchingParams` runs the original eq. 1 filter, see :func:`method_models`).
    The conventional ``random_constant`` model runs ungated unless ``gate_conventional``:
    its innovations are inconsistent by construction (the paper's point), so a gate would
    reject them and the filter would keep re-anchoring and resetting instead of showing
    the paper's error.
    ``flexure``/``lgu1``/``lgu2`` override the simulator's truth parameters; ``profile`` and
    ``profile_params`` the ship's motion (:data:`TURN_PROFILE`: the turning manoeuvre).
    Returns ``{label: FlexureExperimentResult}``.
    """
    filters = _filters(models, FlexureKfParams() if params is None else params, gate_conventional)
    vehicle = VehicleCore(VehicleConfig(profile=profile, profile_params=dict(profile_params or {}),
                                        plant="host_only", sim_rate_hz=sim_rate_hz, duration_s=duration_s))
    truth = {k: v for k, v in (("flexure", flexure), ("lgu1", lgu1), ("lgu2", lgu2)) if v is not None}
    suite = SensorSuite(SensorSuiteConfig(sensors=("lgu",), sim_rate_hz=sim_rate_hz, lgu_rate_hz=lgu_rate_hz,
                                          seed=seed, **truth))
    wall0 = time.perf_counter()
    rows, filter_s, pairs = _sail(vehicle, suite, filters)
    wall = time.perf_counter() - wall0
    out: dict[str, FlexureExperimentResult] = {}
    for m, kf in filters.items():
        full = {k: np.asarray(v, dtype=float) for k, v in rows[m].items()}
        metrics = flexure_metrics(full, convergence_s, helm_period_s=suite.config.flexure.helm_period_s[0])
        # Thin to one row per record period for plots and reports.
        t = full["t"]
        keep = np.ones(t.shape, bool)
        if record_period_s > 0.0 and t.size:
            bins = np.floor((t - t[0]) / record_period_s + 1e-9)
            keep = np.r_[True, bins[1:] != bins[:-1]]
        out[m] = FlexureExperimentResult(
            label=m, model=kf.params.quasi_static_model, metrics=metrics,
            series={k: v[keep] for k, v in full.items()},
            counters=dict(kf.counters), reset_reasons=list(kf.reset_reasons), wall_s=wall,
            filter_us_per_pair=1e6 * filter_s[m] / max(pairs, 1),
            config={"duration_s": duration_s, "seed": seed, "sim_rate_hz": sim_rate_hz,
                    "lgu_rate_hz": lgu_rate_hz, "convergence_s": convergence_s, "params": kf.params},
        )
    return out


def _filters(models: tuple[str, ...] | Mapping[str, FlexureKfParams], base: FlexureKfParams,
             gate_conventional: bool) -> dict[str, FlexureKf]:
    """One filter per model label (:func:`run_flexure_comparison`)."""
    if not isinstance(models, Mapping):
        models = model_params(models, base, gate_conventional)
    return {label: (AttitudeMatchingKf(p) if isinstance(p, AttitudeMatchingParams) else FlexureKf(p))
            for label, p in models.items()}


def model_params(models: tuple[str, ...], base: FlexureKfParams, gate_conventional: bool = False,
                 methods: tuple[str, ...] = ("simplified",)) -> dict[str, FlexureKfParams]:
    """``base`` with each quasi-static model of ``models`` by each attitude-matching method of
    ``methods`` (:data:`METHODS`), labelled ``<model>`` (simplified) or ``<model>_original``;
    ``random_constant`` runs ungated unless ``gate_conventional`` (:func:`run_flexure_comparison`)."""
    out: dict[str, FlexureKfParams] = {}
    for m in models:
        p = replace(base, quasi_static_model=m)
        if m == "random_constant" and not gate_conventional:
            p = replace(p, gate_probability=None)
        for method in methods:
            if method not in METHODS:
                raise ValueError(f"methods: {method!r} is not one of {METHODS}")
            out[m if method == "simplified" else f"{m}_{method}"] = method_models(p)[method]
    return out


def method_models(params: FlexureKfParams) -> dict[str, FlexureKfParams]:
    """Both attitude-matching methods on ``params``' flexure model: ``{"simplified": params,
    "original": AttitudeMatchingParams}`` (per-unit bias models of σ_diff/√2), for the
    ``models`` of :func:`run_flexure_comparison`."""
    return {"simplified": params, "original": AttitudeMatchingParams.from_simplified(params)}


def _sail(vehicle: VehicleCore, suite: SensorSuite,
          filters: dict[str, FlexureKf]) -> tuple[dict[str, dict[str, list]], dict[str, float], int]:
    """Step the ship to the end on the engine (:func:`..core.core_loop.run_stages`: the
    ``sensor_models`` stage, then :func:`_filters_stage`), feeding every LGU pair to every
    filter: each filter's rows (:data:`SERIES`), its CPU time in the filter [s], and the
    number of pairs."""
    rows: dict[str, dict[str, list]] = {m: {k: [] for k in SERIES} for m in filters}
    filter_s = dict.fromkeys(filters, 0.0)
    pairs = [0]
    run_stages(vehicle, [suite_stage(suite), _filters_stage(suite, filters, rows, filter_s, pairs)], controlled=False)
    return rows, filter_s, pairs[0]


def _filters_stage(suite: SensorSuite, filters: dict[str, FlexureKf], rows: dict[str, dict[str, list]],
                   filter_s: dict[str, float], pairs: list[int]) -> Callable[[Bus], None]:
    """The step's LGU pair (``bus.lgu``) into every filter, their estimates into ``rows`` with
    the truth. The filters take the pairs in turn, in alternating order, so that a change of
    the machine's load weighs on every filter's time alike."""
    # CPU time of this process, not wall time: on a shared machine other processes' turns
    # would count as filter time otherwise
    clock = time.process_time
    feeds = {m: StampPairs.feeding(kf) for m, kf in filters.items()}
    orders = (tuple(filters.items()), tuple(reversed(filters.items())))

    def stage(bus: Bus) -> None:
        sample = bus.lgu
        if sample is None:
            return
        pairs[0] += 1
        truth_eps = None
        for m, kf in orders[pairs[0] % 2]:
            c0 = clock()
            feeds[m].add(0, sample.t, sample.dalpha1, sample.dt)
            est = feeds[m].add(1, sample.t, sample.dalpha2, sample.dt)
            filter_s[m] += clock() - c0
            if est is None:
                continue
            if truth_eps is None:
                truth_eps = suite.lgu.lgu1.true_bias - suite.lgu.lgu2.true_bias
            r = rows[m]
            r["t"].append(est.t)
            r["truth_flexure"].append(sample.flexure)
            r["truth_quasi_static"].append(sample.flexure_quasi_static)
            r["truth_bias_diff"].append(truth_eps)
            r["flexure"].append(est.flexure)
            r["flexure_sigma"].append(est.flexure_sigma)
            r["quasi_static"].append(est.quasi_static)
            r["quasi_static_sigma"].append(est.quasi_static_sigma)
            r["bias_diff"].append(est.bias_diff)
            r["bias_diff_sigma"].append(est.bias_diff_sigma)
            r["d2"].append(est.d2)
    return stage


def estimator_figures(result: FlexureExperimentResult) -> dict[str, Any]:
    """One filter's figures as the ``flexure`` report keeps an estimator's (JSON-able), plus
    what only the core loop knows: wall time, filter cost and counters."""
    out = {k: (v.tolist() if isinstance(v, np.ndarray) else v) for k, v in result.metrics.items()}
    out.update(model=result.model, wall_s=result.wall_s, filter_us_per_pair=result.filter_us_per_pair,
               counters=dict(result.counters))
    return out


def format_metrics(label: str, m: dict[str, Any]) -> str:
    """Human-readable summary of one filter's figures (:func:`estimator_figures`, or a graph
    run's report entry, which has no wall time, filter cost or counters)."""
    f = lambda v, d=1: "(" + ", ".join(f"{x:.{d}f}" for x in v) + ")"  # noqa: E731
    cost = (f" wall={m['wall_s']:.1f} s filter={m['filter_us_per_pair']:.1f} us/pair" if "wall_s" in m else "")
    return "\n".join([
        f"[{label}] epochs={m['n_epochs']}{cost}",
        f"  total flexure error RMS {f(m['total_rms_arcsec'])}″  max {f(m['total_max_arcsec'])}″"
        f"  filter 1σ RMS {f(m['total_sigma_rms_arcsec'])}″"
        f"  within ±3σ {100 * m['total_within_3sigma']:.1f} %  NEES {m['total_nees_mean']:.2f}",
        f"  quasi-static error RMS {f(m['qs_rms_arcsec'])}″  max {f(m['qs_max_arcsec'])}″"
        f"  variation p-p {f(m['qs_variation_pp_arcsec'])}″  max/p-p {f(m['qs_max_over_variation_pp'], 2)}",
        f"  bias diff error final {f(m['bias_diff_err_final_deg_h'], 4)} °/h  max {f(m['bias_diff_err_max_deg_h'], 4)}"
        f"  RMS {f(m['bias_diff_err_rms_deg_h'], 4)} °/h  within 0.01 °/h from {m['bias_diff_settle_s']:.0f} s",
        *([f"  counters {m['counters']}"] if "counters" in m else []),
    ])


def _band(values: list[float] | None, name: str) -> float | tuple[float, ...] | None:
    if values is None:
        return None
    if len(values) not in (1, 3):
        raise ValueError(f"{name} takes 1 value or 3 (roll, pitch, yaw), got {len(values)}")
    return values[0] if len(values) == 1 else tuple(values)


def _band_kwargs(options: dict[str, Any]) -> dict[str, Any]:
    """The dynamic-flexure band options given (lists) as FlexureParams/FlexureKfParams keywords."""
    return {k: (v if isinstance(v, float) else tuple(v)) for k in ("dynamic_beta_per_s", "dynamic_freq_rad_s")
            if (v := options[k]) is not None}


def campaign_run(variant: str, seed: int, options: dict[str, Any]) -> dict[str, Any]:
    """The campaign engine's core run (:data:`CAMPAIGN`): one ship simulation feeding one
    filter per model and method (:func:`model_params`), on the turning manoeuvre when
    ``turn``; the figures under the ``flexure`` report's names (``estimators.flexure_<label>``)."""
    band = _band_kwargs(options)
    turn = bool(options["turn"])
    models = model_params(tuple(options["models"]), FlexureKfParams(**band), methods=tuple(options["methods"]))
    results = run_flexure_comparison(options["duration_s"], seed, models=models,
                                     sim_rate_hz=options["sim_rate_hz"], lgu_rate_hz=options["lgu_rate_hz"],
                                     convergence_s=options["convergence_s"],
                                     flexure=FlexureParams(**band, **(TURN_FLEXURE if turn else {})),
                                     **({"profile": "sinusoids", "profile_params": TURN_PROFILE} if turn else {}))
    return {"duration_s": options["duration_s"], "convergence_s": options["convergence_s"],
            "estimators": {f"flexure_{m}": estimator_figures(r) for m, r in results.items()}}


#: Seeds as a campaign: ``engine: core`` runs :func:`campaign_run`; ``engine: graph`` runs
#: scenario ``ship_flexure_band`` (the filter's own band as the truth; both models, simplified method, no turn, 10 Hz, the default
#: band; its estimators publish at 1 Hz, so its figures are scored on those epochs).
CAMPAIGN = ExperimentCampaign(
    name="flexure", variants=("",),
    defaults={"duration_s": 7200.0, "models": list(QS_MODELS), "methods": ["simplified"], "turn": False,
              "sim_rate_hz": 10.0, "lgu_rate_hz": 10.0, "convergence_s": 600.0, "dynamic_beta_per_s": None,
              "dynamic_freq_rad_s": None},
    run=campaign_run, graph=GraphEquivalent("ship_flexure_band", {"": None}))


def monte_carlo_table(runs: list[tuple[int, dict[str, Any]]], models: list[str]) -> str:
    """Per model, statistics over seeds (``runs``: [(seed, figures)]) of the figures the
    comparison scores (arcsec, °/h)."""
    lines = []
    seeds = sorted(seed for seed, _ in runs)
    f = lambda v, d=1: " / ".join(f"{x:.{d}f}" for x in v)  # noqa: E731
    for m in models:
        ms = [fig["estimators"][f"flexure_{m}"] for _, fig in sorted(runs, key=lambda r: r[0])]
        rms = np.array([x["total_rms_arcsec"] for x in ms])
        sig = np.array([x["total_sigma_rms_arcsec"] for x in ms])
        bd = np.array([np.abs(x["bias_diff_err_final_deg_h"]) for x in ms])
        nees = np.array([x["total_nees_mean"] for x in ms])
        lines += [
            f"[{m}] {len(ms)} seeds ({', '.join(str(s) for s in seeds)})",
            f"  total flexure error RMS, roll / pitch / yaw [″]: mean {f(rms.mean(0))}   max {f(rms.max(0))}",
            f"  filter 1σ RMS [″]: mean {f(sig.mean(0))}   NEES (3 dof) mean {nees.mean():.2f}",
            f"  |bias difference error| at the end [°/h]: max {f(bd.max(0), 4)}",
        ]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(
        prog="python -m gimbal_sim.experiments.flexure",
        description="Paper 5 ship flexure without ROS: the ship simulation feeds one FlexureKf per "
                    "quasi-static model on the same LGU samples; prints the errors against the truth "
                    "after the convergence time (several seeds: a Monte Carlo table). The seeds run as a "
                    "campaign (gimbal-campaign's engine: --jobs, --scheduler, --out, --resume; --engine graph "
                    "runs the real nodes of scenario ship_flexure_band instead).")
    ap.add_argument("--duration", type=float, default=7200.0, help="simulated time [s] (default 7200)")
    ap.add_argument("--seeds", "--seed", type=int, nargs="+", default=[0], help="seeds to run (default 0)")
    ap.add_argument("--models", nargs="+", choices=QS_MODELS, default=list(QS_MODELS),
                    help="quasi-static models to run (default both)")
    ap.add_argument("--methods", nargs="+", choices=METHODS, default=["simplified"],
                    help="attitude-matching methods (default simplified; original: paper 5 eq. 1)")
    ap.add_argument("--turn", action="store_true",
                    help="the turning manoeuvre (scenario ship_flexure_turn): zigzag course ±20° every 200 s, "
                         "7′ turn flexure")
    ap.add_argument("--sim-rate", type=float, default=10.0,
                    help="simulation rate [Hz] (default 10, as the ship_flexure_band scenario)")
    ap.add_argument("--lgu-rate", type=float, default=10.0, help="LGU sample rate [Hz] (default 10)")
    ap.add_argument("--convergence", type=float, default=600.0, help="convergence time left out [s] (default 600)")
    ap.add_argument("--dynamic-beta", type=float, nargs="+", metavar="BETA_PER_S",
                    help="dynamic flexure decay rate beta [1/s], 1 value or roll pitch yaw (truth and filters)")
    ap.add_argument("--dynamic-freq", type=float, nargs="+", metavar="LAMBDA_RAD_S",
                    help="dynamic flexure damped frequency lambda [rad/s] (0 = critically damped; truth and "
                         "filters)")
    add_engine_arguments(ap, graph=True)
    a = ap.parse_args(argv)
    for name, value in (("--duration", a.duration), ("--sim-rate", a.sim_rate), ("--lgu-rate", a.lgu_rate)):
        if not value > 0.0 or value == float("inf"):
            ap.error(f"{name} must be a finite number > 0, got {value}")
    if not 0.0 <= a.convergence < a.duration:
        ap.error(f"--convergence must be in [0, --duration), got {a.convergence}")
    if len(set(a.seeds)) != len(a.seeds):
        ap.error("--seeds must not repeat a seed")
    band: dict[str, Any] = {}
    try:
        for key, values, name in (("dynamic_beta_per_s", a.dynamic_beta, "--dynamic-beta"),
                                  ("dynamic_freq_rad_s", a.dynamic_freq, "--dynamic-freq")):
            v = _band(values, name)
            if v is not None:
                band[key] = v
        flexure = FlexureParams(**band)
        FlexureKfParams(**band)
    except ValueError as exc:
        ap.error(str(exc))
    options = {"duration_s": a.duration, "models": list(a.models), "methods": list(a.methods), "turn": a.turn,
               "sim_rate_hz": a.sim_rate,
               "lgu_rate_hz": a.lgu_rate, "convergence_s": a.convergence,
               **{k: (list(v) if isinstance(v, tuple) else v) for k, v in band.items()}}
    spec = CampaignSpec(scenario="", experiment=CAMPAIGN.name, seeds=tuple(a.seeds), engine=a.engine, mode=a.mode,
                        options=tuple(options.items()))
    with campaign_dir(a.out) as out:
        runs = run_metrics(run_for_cli(ap, a, spec, out, CAMPAIGN))[""]
    print(f"dynamic flexure band: beta {flexure.dynamic_beta_per_s} 1/s, lambda {flexure.dynamic_freq_rad_s} rad/s")
    models = list(model_params(tuple(a.models), FlexureKfParams(), methods=tuple(a.methods)))
    if len(runs) == 1:
        for m in models:
            print(format_metrics(m, runs[0][1]["estimators"][f"flexure_{m}"]))
    else:
        print(monte_carlo_table(runs, models))


if __name__ == "__main__":
    main()
