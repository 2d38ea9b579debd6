"""Round trip of ``gimbal-allan``: bags of a gyro at rest with known noise terms, characterised
again, over term mixes and seeds; the scatter of single realisations, measured.

Each (mix, seed) is the ``gyro_at_rest`` scenario's variant run on the same cores its nodes
use (``VehicleCore`` and ``SensorSuite``, with the parameter values the orchestrator would
give the nodes, :func:`gimbal_sim.core.core_loop.node_values`), its ``/ins/imu`` serialised as
``sensor_models`` publishes it and written with our bag writer (a graph run of 6 h at 10 Hz
gives the same samples, but takes minutes). ``gimbal-allan``'s reader and fit then
characterise the bag, and each term is compared with what was simulated.

``python -m gimbal_sim.tools.allan_roundtrip [--mixes arw all] [--seeds 0 1 2 3 4]
[--duration-s 21600] [--jobs 2] [--json FILE]`` prints, per mix and term, fitted/true per seed
and axis, their mean and spread (the scatter of one realisation), the largest error, and
the fit's own 1σ next to that spread.
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import math
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

from gimbal_kinematics.ros import messages as m

from ..allan.analyze import analyze, to_json
from ..allan.params import sensor_models_params
from ..allan.stream import read_imu_field
from ..bag.writer import BagWriter
from ..core.core_loop import node_values
from ..core.core_stages import Bus, sensor_stage
from ..graph.scenario import Scenario, ScenarioError, apply_set, load, variant
from ..nodes.wire import noise_covariances, sensor_messages
from ..world.sensor_suite import SensorSuiteConfig
from ..world.vehicle import VehicleConfig, VehicleCore

SCENARIO = "gyro_at_rest"
TOPIC = "/ins/imu"
#: fitted JSON key -> (sensor_models parameter, JSON key of its 1σ)
TERMS = {"arw_deg_rt_h": ("ins_gyro_arw_deg_rt_h", "arw_sigma"),
         "bias_instability_deg_h": ("ins_gyro_bi_deg_h", "bias_instability_sigma"),
         "bias_tau_s": ("ins_gyro_bi_tau_s", "bias_tau_sigma"),
         "rrw_deg_h_rt_h": ("ins_gyro_rrw_deg_h_rt_h", "rrw_sigma")}
#: Acceptance: ARW within 10 % on every seed; bias instability and RRW within 15 %
#: as the mean over seeds and axes and 35 % on every seed; the correlation time within x2.
BOUNDS = {"arw_deg_rt_h": (None, 0.10), "bias_instability_deg_h": (0.15, 0.35), "rrw_deg_h_rt_h": (0.15, 0.35),
          "bias_tau_s": (None, "x2")}


def write_at_rest_bag(scenario: Scenario, out: Path) -> dict[str, float]:
    """Run ``scenario``'s vehicle and sensor cores and write its ``/ins/imu`` to a bag at ``out``
    as ``sensor_models`` would publish it; returns the sensor_models parameter values."""
    values = node_values(scenario)
    sensors = next(v for exe, v in values.values() if exe == "sensor_models")
    vehicle = VehicleCore(VehicleConfig.from_values(next(v for exe, v in values.values() if exe == "vehicle_dynamics")))
    stage = sensor_stage(sensors)
    # the node's own covariance fields (they depend on its config only)
    cov = noise_covariances(SensorSuiteConfig.from_values(sensors))
    writer = BagWriter(out, chunk_duration_ns=60_000_000_000)  # big chunks: a recorder's 0.5 s ones slow reading
    writer.add_topic(TOPIC, "sensor_msgs/msg/Imu", [])
    bus = Bus()
    rate = vehicle.config.sim_rate_hz
    n = vehicle.config.n_steps
    for k in range(n + 1):
        bus.k = k
        bus.truth = vehicle.truth()
        stage(bus)
        if bus.ins is not None:  # as sensor_models serialises it (nodes.wire)
            t_ns = m.step_stamp_ns(k, rate)
            for topic, _, data in sensor_messages(t_ns, bus.ins, cov):
                if topic == TOPIC:
                    writer.write(TOPIC, data, t_ns)
        if k < n:
            vehicle.step(())
    writer.close()
    return sensors


def one_run(mix: str, seed: int, duration_s: float) -> dict:
    """Simulate, write, read back and characterise one (mix, seed); fitted/true per axis and term."""
    scenario = dataclasses.replace(variant(load(SCENARIO), mix), seed=seed, duration_s=duration_s)
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="allan_rt_") as tmp:
        params = write_at_rest_bag(scenario, Path(tmp) / "bag")
        t1 = time.perf_counter()
        doc = to_json(analyze(read_imu_field(Path(tmp) / "bag", TOPIC, "angular_velocity", progress=False)))
    t2 = time.perf_counter()
    truth = {key: float(params[name]) for key, (name, _) in TERMS.items()}
    if not truth["bias_instability_deg_h"]:
        truth["bias_tau_s"] = 0.0
    axes = {}
    for axis, terms in doc["axes"].items():
        axes[axis] = {key: {"fitted": terms[key] or 0.0, "sigma": terms[TERMS[key][1]],
                            "ratio": (terms[key] or 0.0) / truth[key] if truth[key] else None}
                      for key in TERMS}
    return {"mix": mix, "seed": seed, "truth": truth, "axes": axes, "simulate_s": t1 - t0, "analyse_s": t2 - t1}


def refit_scenario(scenario: Scenario, fitted_params: dict[str, float], seed: int) -> Scenario:
    """``scenario`` whose INS gyro is the fitted one (``sensor_models`` parameters), with ``seed``."""
    for name, value in fitted_params.items():
        scenario = apply_set(scenario, f"sensor_models.{name}={float(value)!r}")
    return dataclasses.replace(scenario, seed=seed)


def closed_loop(mix: str, seed: int, duration_s: float) -> dict:
    """Fit a simulated bag, simulate the fitted gyro (seed + 1000), fit again: each axis of the
    second fit over the first fit's values as ``sensor_models`` simulated them (mean over axes)."""
    scenario = dataclasses.replace(variant(load(SCENARIO), mix), seed=seed, duration_s=duration_s)
    with tempfile.TemporaryDirectory(prefix="allan_cl_") as tmp:
        write_at_rest_bag(scenario, Path(tmp) / "first")
        result = analyze(read_imu_field(Path(tmp) / "first", TOPIC, "angular_velocity", progress=False))
        fitted = sensor_models_params(result, "ins_gyro")
        write_at_rest_bag(refit_scenario(scenario, fitted, seed + 1000), Path(tmp) / "second")
        first = to_json(result)
        second = to_json(analyze(read_imu_field(Path(tmp) / "second", TOPIC, "angular_velocity", progress=False)))
    # the first fit as sensor_models got it (one value for the axes) against each axis of the second
    simulated = {key: float(fitted.get(name, 0.0)) if key != "bias_tau_s" or fitted["ins_gyro_bi_deg_h"] else 0.0
                 for key, (name, _) in TERMS.items()}
    axes = {axis: {key: {"first": simulated[key], "first_axis": first["axes"][axis][key] or 0.0,
                         "second": terms[key] or 0.0,
                         "ratio": (terms[key] or 0.0) / simulated[key] if simulated[key] else None} for key in TERMS}
            for axis, terms in second["axes"].items()}
    return {"mix": mix, "seed": seed, "fitted_params": fitted, "axes": axes}


def summarise(runs: list[dict]) -> dict:
    """Per mix and term: ratios over seeds and axes, their mean and spread, the worst error, the
    fit's mean 1σ (relative), and whether the round trip's bounds hold."""
    out: dict = {}
    for mix in dict.fromkeys(r["mix"] for r in runs):
        rows = [r for r in runs if r["mix"] == mix]
        out[mix] = {}
        for key in TERMS:
            if not rows[0]["truth"][key]:
                continue
            ratios = np.array([[a[key]["ratio"] for a in r["axes"].values()] for r in rows])
            rel_sigma = np.array([[(a[key]["sigma"] or math.nan) / rows[0]["truth"][key] for a in r["axes"].values()]
                                  for r in rows])
            mean_bound, each_bound = BOUNDS[key]
            if each_bound == "x2":
                ok = bool(np.all((ratios >= 0.5) & (ratios <= 2.0)))
            else:
                ok = bool(np.all(np.abs(ratios - 1.0) <= each_bound))
                if mean_bound is not None:
                    ok = ok and abs(float(ratios.mean()) - 1.0) <= mean_bound
            out[mix][key] = {"true": rows[0]["truth"][key], "ratios": ratios.round(4).tolist(),
                             "mean": float(ratios.mean()), "scatter": float(ratios.std(ddof=1)) if ratios.size > 1
                             else 0.0, "worst_error": float(np.max(np.abs(ratios - 1.0))),
                             "fit_sigma_mean": float(np.nanmean(rel_sigma)), "meets_bound": ok}
    return out


def summarise_closed_loop(runs: list[dict]) -> dict:
    """Per mix and term: second fit / first fit over seeds and axes, against the same bounds."""
    out: dict = {}
    for mix in dict.fromkeys(r["mix"] for r in runs):
        rows = [r for r in runs if r["mix"] == mix]
        out[mix] = {}
        for key in TERMS:
            ratios = np.array([[a[key]["ratio"] for a in r["axes"].values()] for r in rows], dtype=object)
            if any(v is None for v in ratios.ravel()):
                continue  # the first fit had no such term
            ratios = ratios.astype(float)
            mean_bound, each_bound = BOUNDS[key]
            if each_bound == "x2":
                ok = bool(np.all((ratios >= 0.5) & (ratios <= 2.0)))
            else:
                ok = bool(np.all(np.abs(ratios - 1.0) <= each_bound)) and \
                    (mean_bound is None or abs(float(ratios.mean()) - 1.0) <= mean_bound)
            out[mix][key] = {"mean": float(ratios.mean()), "scatter": float(ratios.std(ddof=1)) if ratios.size > 1
                             else 0.0, "worst_error": float(np.max(np.abs(ratios - 1.0))), "meets_bound": ok}
    return out


def closed_loop_table(summary: dict) -> str:
    lines = ["closed loop: fit -> sensor_models parameters -> new bag (seed + 1000) -> fit again "
             "(second fit per axis / first fit as simulated)",
             "| mix | term | mean | scatter (1σ) | worst error | met |", "| --- | --- | ---: | ---: | ---: | --- |"]
    for mix, terms in summary.items():
        for key, s in terms.items():
            lines.append(f"| {mix} | {key} | {s['mean']:.3f} | {s['scatter']:.3f} | {s['worst_error']:.1%} | "
                         f"{'yes' if s['meets_bound'] else 'NO'} |")
    return "\n".join(lines)


def table(summary: dict, seeds: list[int], duration_s: float) -> str:
    lines = [f"gimbal-allan round trip: {SCENARIO} at rest, {duration_s / 3600:g} h at 10 Hz, seeds {seeds}, "
             f"axes x y z (fitted / true)",
             "| mix | term | true | mean | scatter (1σ) | worst error | fit's own 1σ | bound | met |",
             "| --- | --- | ---: | ---: | ---: | ---: | ---: | --- | --- |"]
    for mix, terms in summary.items():
        for key, s in terms.items():
            mean_bound, each_bound = BOUNDS[key]
            bound = "x2 every seed" if each_bound == "x2" else \
                (f"{each_bound:.0%} every seed" + (f", {mean_bound:.0%} mean" if mean_bound else ""))
            lines.append(f"| {mix} | {key} | {s['true']:g} | {s['mean']:.3f} | {s['scatter']:.3f} | "
                         f"{s['worst_error']:.1%} | {s['fit_sigma_mean']:.3f} | {bound} | "
                         f"{'yes' if s['meets_bound'] else 'NO'} |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    scenario = load(SCENARIO)
    parser = argparse.ArgumentParser(prog="python -m gimbal_sim.tools.allan_roundtrip",
                                     description="gimbal-allan round trip on simulated at-rest gyro bags: the "
                                                 "gyro_at_rest variants (term mixes) over seeds; prints the table.")
    parser.add_argument("--mixes", nargs="+", default=list(scenario.variants), choices=list(scenario.variants))
    parser.add_argument("--seeds", nargs="+", type=int, default=[0, 1, 2, 3, 4])
    parser.add_argument("--duration-s", type=float, default=scenario.duration_s, help="record length [s]")
    parser.add_argument("--jobs", type=int, default=1, help="processes")
    parser.add_argument("--json", type=Path, help="write every run and the summary to this file")
    parser.add_argument("--closed-loop", action="store_true",
                        help="fit, simulate the fitted parameters (another seed), fit again; compare the two fits")
    args = parser.parse_args(argv)
    try:
        if args.jobs < 1:
            raise ScenarioError(f"--jobs must be >= 1, got {args.jobs}")
        if not args.duration_s > 0:
            raise ScenarioError(f"--duration-s must be > 0, got {args.duration_s}")
        if len(set(args.seeds)) != len(args.seeds) or min(args.seeds) < 0:
            raise ScenarioError(f"--seeds must be distinct and >= 0, got {args.seeds}")
        if args.json is not None and args.json.exists():
            raise ScenarioError(f"--json {args.json} already exists; not overwriting it")
    except ScenarioError as exc:
        print(f"allan_roundtrip: {exc}", file=sys.stderr)
        return 2
    jobs = [(mix, seed, args.duration_s) for mix in args.mixes for seed in args.seeds]
    t0 = time.perf_counter()
    with ProcessPoolExecutor(max_workers=args.jobs) as pool:
        runs = []
        for run in pool.map(closed_loop if args.closed_loop else one_run, *zip(*jobs)):
            runs.append(run)
            print(f"  {run['mix']} seed {run['seed']} done", file=sys.stderr)
    if args.closed_loop:
        summary = summarise_closed_loop(runs)
        print(closed_loop_table(summary))
    else:
        summary = summarise(runs)
        print(table(summary, args.seeds, args.duration_s))
    print(f"({len(runs)} runs in {time.perf_counter() - t0:.0f} s)")
    if args.json is not None:
        args.json.write_text(json.dumps({"runs": runs, "summary": summary}, indent=1) + "\n")
    return 0 if all(s["meets_bound"] for terms in summary.values() for s in terms.values()) else 1


if __name__ == "__main__":
    sys.exit(main())
