"""Paper 2's studies on the campaign engine (docs/results/paper2.md): the headline ratio on
the paper's baseline and the filter-tuning (R/Q) sweep of Figs. 5–7::

    python -m gimbal_sim.experiments.encoder_fusion_study headline --seeds 1-10 --jobs 2
    python -m gimbal_sim.experiments.encoder_fusion_study rq --seeds 1-10 --jobs 2 --out bags/p2_rq

Two experiment campaigns, run by :func:`..experiments.encoder_fusion.run_encoder_fusion`
(the no-ROS loop of the ``gimbal_encoder_fusion`` scenario's cores):

* ``encoder_fusion``: variants ``encoder``, ``gyro``, ``fused`` (the controller's modes).
  Options: ``duration_s``, ``disturbance_scale`` (every amplitude of the UAV motion and
  vibration times this factor) and ``random_phases`` (each term's phase drawn from the
  seed, so seeds also differ in the disturbance, not only in the gyro noise). The graph
  engine runs scenario ``gimbal_encoder_fusion`` with the scaled profile; it cannot draw
  phases per seed, so ``random_phases`` is core only.
* ``encoder_fusion_rq``: fused mode, one variant per point of the R × Q grid
  (:data:`RQ_GRID`, which holds paper 2's pairs 0.1/0.01, 0.1/0.5 and 1/0.1). Core only.

Paper 2 gives R and Q without units. We read them in encoder counts (δ = 2π/1024):
R [counts²] is the variance of z (R = 0.1 is about one count's quantisation variance
1/12), Q [counts² per filter step T = gate] is the angle state's process noise per step,
Q₁₁ = q1·T = Q·δ². The drift and scale-factor densities keep the default filter's ratios
to the angle density (:func:`paper_kf`), so the whole Q matrix scales with Q and the
steady-state gain depends on R/Q alone.
"""
from __future__ import annotations

import argparse
import dataclasses
import math
from pathlib import Path
from typing import Any, Sequence

import numpy as np
import yaml

from gimbal_control.encoder_fusion import EncoderFusionParams
from gimbal_control.fusion_kf import FusionKfParams

from gimbal_kinematics.maths.units import DEG

from ..campaign.experiment import ExperimentCampaign, GraphEquivalent, run_metrics
from ..campaign.report import stats
from ..campaign.parsing import parse_seeds
from ..campaign.runner_cli import add_engine_arguments, campaign_dir, run_for_cli
from ..campaign.spec import CampaignSpec
from ..reports.encoder_fusion import FusionRun, run_metrics as fusion_run_metrics
from ..reports.encoder_fusion_study import rq_grid_plot, velocity_traces_plot
from ..world.sensors import PAPER2_ENCODER
from .encoder_fusion import UAV_PROFILE, run_encoder_fusion

#: Paper 2's three (R, Q) pairs (Figs. 5, 6, 7).
PAPER_PAIRS = ((0.1, 0.01), (0.1, 0.5), (1.0, 0.1))
#: The sweep: R and Q values [counts², counts² per step]; the grid holds the paper's pairs.
RQ_R = (0.01, 0.1, 1.0, 10.0)
RQ_Q = (1e-4, 1e-3, 0.01, 0.1, 0.5)
#: The disturbance scale whose encoder-only peaks are paper 2's ≈ 1.2° (docs/results/paper2.md).
PAPER_BASELINE_SCALE = 0.2


def rq_variant(r: float, q: float) -> str:
    """The variant name of grid point (R, Q), e.g. ``R0.1_Q0.01``."""
    return f"R{r:g}_Q{q:g}"


RQ_GRID = tuple(rq_variant(r, q) for r in RQ_R for q in RQ_Q)


def parse_rq(variant: str) -> tuple[float, float]:
    """(R, Q) of a grid variant name (:func:`rq_variant`)."""
    r, _, q = variant.partition("_")
    return float(r[1:]), float(q[1:])


def paper_kf(r_counts2: float, q_counts2: float, gate_s: float = PAPER2_ENCODER.velocity_gate_s,
             counts_per_rev: int = PAPER2_ENCODER.counts_per_rev) -> FusionKfParams:
    """The filter parameters of paper 2's (R, Q) read in encoder counts (module docstring)."""
    delta_deg = 360.0 / counts_per_rev
    base = FusionKfParams()
    q_angle = math.sqrt(q_counts2 / gate_s) * delta_deg
    s = q_angle / base.q_angle_deg_rt_s
    return dataclasses.replace(base, r_deg=math.sqrt(r_counts2) * delta_deg, q_angle_deg_rt_s=q_angle,
                               q_drift_deg_s_rt_s=s * base.q_drift_deg_s_rt_s, q_scale_rt_s=s * base.q_scale_rt_s)


def disturbance(scale: float, phase_seed: int | None = None) -> dict[str, Any]:
    """The UAV profile with every amplitude times ``scale``; with ``phase_seed``, each term's
    phase drawn uniformly in [0, 2π) from that seed (its own stream, not the sensors')."""
    rng = np.random.default_rng([int(phase_seed), 25]) if phase_seed is not None else None
    return {key: [[a * scale, w, float(rng.uniform(0.0, 2.0 * math.pi)) if rng is not None else ph]
                  for a, w, ph in terms] for key, terms in UAV_PROFILE.items()}


def fusion_run(mode: str, out: dict[str, Any]) -> FusionRun:
    """The report's :class:`FusionRun` from a :func:`run_encoder_fusion` result recorded at
    every step (so both engines' figures are :func:`reports.encoder_fusion.run_metrics`)."""
    s = out["series"]
    t = s["t"]
    none = np.zeros(0)
    return FusionRun(mode=mode, t=t, error=s["error_rad"], true_rate=s["true_rate_rad_s"], fb_t=t,
                     fb_error=s["feedback_rad_s"] - s["true_rate_rad_s"], bias_t=t, bias=s["gyro_bias_rad_s"],
                     corr_t=none, corr=none.reshape(0, 2), torque_t=t, torque=s["torque_nm"])


def velocity_split(t: np.ndarray, err: np.ndarray, gate_s: float, window_gates: int = 10,
                   after_s: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """Velocity error (n, 2) [rad/s] averaged over each gate (the gyro's white noise averages
    out), split into its slow part (centred moving mean over ``window_gates`` gates) and the
    rest; returns the RMS of each per axis (2,), over the gates after ``after_s``."""
    bins = np.floor((t - t[0]) / gate_s + 1e-9).astype(int)
    counts = np.bincount(bins)
    full = counts == counts.max()
    means = np.stack([np.bincount(bins, weights=err[:, i]) / counts for i in range(2)], axis=1)[full]
    centres = (np.nonzero(full)[0] + 0.5) * gate_s
    k = np.ones(window_gates) / window_gates
    slow = np.stack([np.convolve(means[:, i], k, "valid") for i in range(2)], axis=1)
    h = window_gates // 2
    rest = means[h:h + len(slow)] - slow
    keep = centres[h:h + len(slow)] >= after_s
    return np.sqrt(np.mean(slow[keep] ** 2, axis=0)), np.sqrt(np.mean(rest[keep] ** 2, axis=0))


def _run(mode: str, seed: int, options: dict[str, Any], params: EncoderFusionParams | None) -> dict[str, Any]:
    phase_seed = seed if options["random_phases"] else None
    out = run_encoder_fusion(mode, options["duration_s"], seed, params=params, record_every=1,
                             profile_params=disturbance(options["disturbance_scale"], phase_seed))
    metrics = fusion_run_metrics(fusion_run(mode, out))
    metrics["stabilization_error_urad"]["rms_held"] = 1e6 * out["rms_error_held_rad"]
    return metrics, out


HEADLINE_DEFAULTS = {"duration_s": 20.0, "disturbance_scale": 1.0, "random_phases": False}


def headline_run(variant: str, seed: int, options: dict[str, Any]) -> dict[str, Any]:
    """One seed of one feedback mode (``variant``): the encoder_fusion report's figures."""
    return _run(variant, seed, options, None)[0]


def headline_translate(options: dict[str, Any]) -> tuple[float, tuple]:
    """Scenario ``gimbal_encoder_fusion`` with the scaled profile (fixed phases)."""
    profile = yaml.safe_dump(disturbance(options["disturbance_scale"]), default_flow_style=True, width=10_000).strip()
    return options["duration_s"], (("vehicle_dynamics.profile_params", profile),)


CAMPAIGN = ExperimentCampaign(
    name="encoder_fusion", variants=("encoder", "gyro", "fused"), defaults=HEADLINE_DEFAULTS, run=headline_run,
    graph=GraphEquivalent("gimbal_encoder_fusion", {"encoder": "encoder", "gyro": "gyro", "fused": "fused"},
                          ("duration_s", "disturbance_scale"), headline_translate))

RQ_DEFAULTS = {"duration_s": 30.0, "disturbance_scale": PAPER_BASELINE_SCALE, "random_phases": True}


def rq_run(variant: str, seed: int, options: dict[str, Any]) -> dict[str, Any]:
    """One seed of one grid point: the report's figures plus the estimated-velocity error
    (feedback − true rate, gate means) split into slow and fast parts after the settle
    time [deg/s], and the drift correction's convergence."""
    r, q = parse_rq(variant)
    params = EncoderFusionParams(mode="fused", kf=paper_kf(r, q))
    metrics, out = _run("fused", seed, options, params)
    s = out["series"]
    slow, fast = velocity_split(s["t"], s["feedback_rad_s"] - s["true_rate_rad_s"], params.encoder_gate_s,
                                after_s=metrics["settle_s"])
    metrics["rq"] = {"r_counts2": r, "q_counts2": q, "r_over_q": r / q,
                     "velocity_error_slow_deg_s": float(np.sqrt(np.mean(slow ** 2)) / DEG),
                     "velocity_error_fast_deg_s": float(np.sqrt(np.mean(fast ** 2)) / DEG)}
    return metrics


RQ_CAMPAIGN = ExperimentCampaign(name="encoder_fusion_rq", variants=RQ_GRID, defaults=RQ_DEFAULTS, run=rq_run)


# ---------------------------------------------------------------------------- tables
def ratio_interval(encoder_rms: Sequence[float], fused_rms: Sequence[float]) -> dict[str, Any]:
    """Per-seed ratios fused/encoder RMS: mean, std and the 95 % Student-t interval of the
    mean (:func:`..campaign.report.stats`)."""
    ratios = [f / e for e, f in zip(encoder_rms, fused_rms)]
    return stats(ratios) | {"ratios": ratios}


def headline_table(by_variant: dict[str, list[tuple[int, dict]]]) -> tuple[str, dict[str, Any]]:
    """The mode table (RMS and peak after settle [mrad], mean ± std over the seeds) and the
    fused/encoder ratio with its interval."""
    fig = {v: {s: m["stabilization_error_urad"] for s, m in runs} for v, runs in by_variant.items()}
    lines = ["| feedback | runs | RMS after settle [mrad] | peak [mrad] | peak [deg] |", "|---|---:|---|---|---|"]
    out: dict[str, Any] = {}
    for v, per_seed in fig.items():
        rms = stats([1e-3 * f["rms_after_settle"] for f in per_seed.values()])
        peak = stats([1e-3 * f["peak_after_settle"] for f in per_seed.values()])
        out[v] = {"rms_mrad": rms, "peak_mrad": peak}
        lines.append(f"| {v} | {rms['n']} | {rms['mean']:.3f} ± {_sd(rms):.3f} | {peak['mean']:.2f} ± {_sd(peak):.2f} "
                     f"| {peak['mean'] * 1e-3 / DEG:.2f} |")
    text = "\n".join(lines) + "\n"
    if "encoder" in fig and "fused" in fig:
        seeds = sorted(set(fig["encoder"]) & set(fig["fused"]))
        ratio = ratio_interval([fig["encoder"][s]["rms_after_settle"] for s in seeds],
                               [fig["fused"][s]["rms_after_settle"] for s in seeds])
        out["ratio_fused_over_encoder"] = ratio
        lo, hi = ratio["ci95"]
        text += (f"\nRMS(fused)/RMS(encoder) per seed: {ratio['mean']:.4f}, 95 % interval [{lo:.4f}, {hi:.4f}] "
                 f"(n = {ratio['n']}); improvement {1 / ratio['mean']:.1f}x (paper 2: 10x)\n")
    return text, out


def _sd(s: dict) -> float:
    return s["std"] if math.isfinite(s["std"]) else 0.0


def rq_table(by_variant: dict[str, list[tuple[int, dict]]]) -> tuple[str, dict[str, Any]]:
    """Per grid point: stabilization RMS [mrad] and the slow / fast velocity error [deg/s],
    means over the seeds; the paper's pairs marked."""
    lines = ["| R | Q | R/Q | runs | RMS after settle [mrad] | velocity error slow [deg/s] | fast [deg/s] | |",
             "|---:|---:|---:|---:|---:|---:|---:|---|"]
    out = {}
    for v, runs in by_variant.items():
        r, q = parse_rq(v)
        rms = stats([1e-3 * m["stabilization_error_urad"]["rms_after_settle"] for _, m in runs])
        slow = stats([m["rq"]["velocity_error_slow_deg_s"] for _, m in runs])
        fast = stats([m["rq"]["velocity_error_fast_deg_s"] for _, m in runs])
        out[v] = {"r": r, "q": q, "rms_mrad": rms, "slow_deg_s": slow, "fast_deg_s": fast}
        mark = "paper" if (r, q) in PAPER_PAIRS else ""
        lines.append(f"| {r:g} | {q:g} | {r / q:g} | {rms['n']} | {rms['mean']:.3f} | {slow['mean']:.4f} "
                     f"| {fast['mean']:.4f} | {mark} |")
    return "\n".join(lines) + "\n", out


# ---------------------------------------------------------------------------- command line
def main(argv: Sequence[str] | None = None) -> None:
    """``python -m gimbal_sim.experiments.encoder_fusion_study headline|rq``."""
    ap = argparse.ArgumentParser(prog="python -m gimbal_sim.experiments.encoder_fusion_study",
                                 description="Paper 2 studies: the fused/encoder ratio over seeds (headline) and "
                                             "the R/Q filter-tuning sweep (rq), on gimbal-campaign's engine.")
    ap.add_argument("study", choices=("headline", "rq"))
    ap.add_argument("--seeds", default="1-10", help="seed list, e.g. 1-10 or 1,3,5")
    ap.add_argument("--duration", type=float, help="run length [s] (headline 20, rq 30)")
    ap.add_argument("--disturbance-scale", type=float,
                    help=f"UAV motion amplitudes times this (headline 1, rq {PAPER_BASELINE_SCALE}; "
                         f"{PAPER_BASELINE_SCALE}: the paper's 1.2 deg encoder-only peaks)")
    ap.add_argument("--random-phases", action=argparse.BooleanOptionalAction, default=None,
                    help="draw the disturbance phases from each seed (core only; default: headline no, rq yes)")
    ap.add_argument("--variants", help="comma-separated variants (default all)")
    ap.add_argument("--plots", metavar="DIR", help="rq: write the velocity-trace and grid plots here")
    add_engine_arguments(ap, graph=True)
    a = ap.parse_args(argv)
    exp = CAMPAIGN if a.study == "headline" else RQ_CAMPAIGN
    try:
        seeds = parse_seeds(a.seeds)
    except ValueError:
        ap.error(f"--seeds {a.seeds!r}: expected a list like 1-10 or 1,3,5")
    options = dict(exp.defaults)
    for key, value in (("duration_s", a.duration), ("disturbance_scale", a.disturbance_scale),
                       ("random_phases", a.random_phases)):
        if value is not None:
            options[key] = value
    variants = tuple(a.variants.split(",")) if a.variants else ()
    spec = CampaignSpec(scenario="", experiment=exp.name, seeds=seeds, engine=a.engine, mode=a.mode,
                        variants=variants, options=tuple(options.items()))
    with campaign_dir(a.out) as out:
        by_variant = run_metrics(run_for_cli(ap, a, spec, out, exp))
    text, _ = (headline_table if a.study == "headline" else rq_table)(by_variant)
    print(f"{exp.name}: {len(seeds)} seeds, options {options}\n{text}", end="")
    if a.plots and a.study == "rq":
        print("plots:", ", ".join(rq_plots(rq_table(by_variant)[1], options, seeds[0], Path(a.plots))))


def rq_plots(table: dict[str, dict[str, Any]], options: dict[str, Any], seed: int, out: Path) -> list[str]:
    """The grid plot of ``table`` (:func:`rq_table`) and the velocity traces of the paper's
    pairs, rerun on ``seed`` with ``options``, into ``out``."""
    out.mkdir(parents=True, exist_ok=True)
    rq_grid_plot(out / "rq_grid.png", table, PAPER_PAIRS)
    phase_seed = seed if options["random_phases"] else None
    traces = {}
    for r, q in PAPER_PAIRS:
        run = run_encoder_fusion("fused", options["duration_s"], seed, record_every=1,
                                 params=EncoderFusionParams(mode="fused", kf=paper_kf(r, q)),
                                 profile_params=disturbance(options["disturbance_scale"], phase_seed))
        traces[f"R = {r:g}, Q = {q:g} (R/Q = {r / q:g})"] = run["series"]
    run = run_encoder_fusion("fused", options["duration_s"], seed, record_every=1,
                             profile_params=disturbance(options["disturbance_scale"], phase_seed))
    traces["default filter (kf_* defaults)"] = run["series"]
    velocity_traces_plot(out / "rq_velocity_traces.png", traces, (0.0, options["duration_s"]))
    return ["rq_grid.png", "rq_velocity_traces.png"]


if __name__ == "__main__":
    main()
