"""Paper 5 on a hull that bends on its own: the flexure filters against sea states 3, 4 and 5.

Accuracy table, a campaign declaration: scenario ``ship_flexure_sea_states`` (``ship_flexure``
once per NATO sea state; the truth's dynamic flexure is the hull model of
:mod:`gimbal_sim.world.sensors.hull_flexure`, which the filters do not contain), each run on
the one engine with its bag and ``flexure`` report (``--engine graph``: the real nodes). Per
sea state and estimator, the total-flexure RMS error (roll, pitch, yaw) over the seeds, mean
and worst, beside paper 5's 20″::

    python -m gimbal_sim.experiments.flexure_sea --seeds 0 1 2 3 4 5 6 7 --jobs 2 --out DIR

Spectrum (``--spectrum``): one seed per sea state through the core loop with every 10 Hz
filter epoch kept (no bag): the Welch PSD of the truth's dynamic flexure, of the
random_walk_rate filter's total-flexure error, and the analytic PSD of the band the filter
assumes; printed as RMS per frequency band (which part of the flexure the filter misses),
drawn to ``DIR/flexure_sea_spectrum.png`` with ``--out``::

    python -m gimbal_sim.experiments.flexure_sea --spectrum --seeds 0 --duration 3600

Error budget (``--budget``): the random_walk_rate filter with one truth source changed at a
time (:func:`budget_cases`), core loop, no bag::

    python -m gimbal_sim.experiments.flexure_sea --budget --sea-states 4 --seeds 0 1 --duration 3600
"""
from __future__ import annotations

import argparse
import math
from dataclasses import replace
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from gimbal_estimators.flexure_kf import FlexureKfParams
from gimbal_kinematics.maths.units import ARCSEC

from ..campaign.experiment import ExperimentCampaign, GraphEquivalent, run_metrics
from ..campaign.runner_cli import add_engine_arguments, campaign_dir, run_for_cli
from ..campaign.spec import CampaignSpec
from ..world.sensors import FlexureParams, HullFlexure, HullParams
from ..figures import pyplot
from .engine_runs import run_on_engine
from .flexure import run_flexure_comparison

SEA_STATES = (3, 4, 5)
VARIANTS = tuple(f"sea_state_{n}" for n in SEA_STATES)
#: Paper 5's full-scale accuracy [″].
PAPER_ACCURACY_ARCSEC = 20.0
#: The estimators of ship_flexure (node -> label in the table).
ESTIMATORS = {"flexure_random_walk_rate": "18-state (eq. 5), random-walk rate",
              "flexure_random_walk_rate_original": "original (eq. 1, 27 states), random-walk rate",
              "flexure_random_constant": "18-state, random constant (conventional)"}
#: Frequency bands of the spectrum table [rad/s].
BANDS_RAD_S = ((0.0, 0.1), (0.1, 0.3), (0.3, 1.5), (1.5, 5.0), (5.0, 10.0 * math.pi))


def campaign_table(runs: dict[str, list[dict[str, Any]]]) -> str:
    """Per sea state and estimator, the total-flexure RMS error over the runs (mean, worst),
    the truth's flexure-variation context and the mean NEES, beside paper 5's 20″."""
    f = lambda v: ", ".join(f"{x:.1f}" for x in v)  # noqa: E731
    lines = [f"Total flexure RMS error (roll, pitch, yaw) [″] after convergence; paper 5 (full-scale ships): "
             f"{PAPER_ACCURACY_ARCSEC:.0f}″"]
    for variant, ms in runs.items():
        lines.append(f"{variant} ({len(ms)} runs)")
        for node, label in ESTIMATORS.items():
            rows = [m["estimators"][node] for m in ms if node in m.get("estimators", {})]
            if not rows:
                continue
            rms = np.array([r["total_rms_arcsec"] for r in rows], float)
            nees = float(np.mean([r["total_nees_mean"] for r in rows]))
            lines.append(f"  {label:48s} mean {f(rms.mean(0))}  worst {f(rms.max(0))}  NEES {nees:.2f}")
    return "\n".join(lines)


#: A declaration: ``ship_flexure_sea_states``' variants on the one engine (each run's bag and
#: ``flexure`` report) or in the node graph.
CAMPAIGN = ExperimentCampaign(name="flexure_sea", variants=VARIANTS, defaults={"duration_s": 7200.0}, run=None,
                              graph=GraphEquivalent("ship_flexure_sea_states", {v: v for v in VARIANTS}),
                              table=campaign_table)


def band_psd(omega: np.ndarray, sigma: float, beta: float, freq: float) -> np.ndarray:
    """Two-sided PSD [rad²/(rad/s)] of the second-order Gauss-Markov band
    (:mod:`gimbal_sim.world.sensors.markov`): 4βω0²σ² / |ω0² − ω² + 2jβω|², ∫ S dω/2π = σ²."""
    w0sq = beta * beta + freq * freq
    return 4.0 * beta * w0sq * sigma * sigma / np.abs(w0sq - omega ** 2 + 2j * beta * omega) ** 2


def welch_rad(x: np.ndarray, fs_hz: float, nperseg: int = 2048) -> tuple[np.ndarray, np.ndarray]:
    """(ω [rad/s], one-sided PSD per rad/s) of ``x`` (n, k) along axis 0 (scipy Welch, Hann)."""
    from scipy.signal import welch

    f, p = welch(x, fs=fs_hz, nperseg=min(nperseg, x.shape[0]), axis=0, detrend="constant")
    return 2.0 * math.pi * f, p / (2.0 * math.pi)


def band_rms(omega: np.ndarray, psd: np.ndarray, lo: float, hi: float) -> np.ndarray:
    """RMS in [lo, hi) rad/s of a one-sided PSD per rad/s (rectangle rule), per column."""
    sel = (omega >= lo) & (omega < hi)
    dw = omega[1] - omega[0]
    return np.sqrt(np.sum(psd[sel], axis=0) * dw)


def spectrum(sea_state: int, seed: int, duration_s: float, convergence_s: float = 600.0) -> dict[str, Any]:
    """One core run (``ship_flexure``'s truth at ``sea_state``, the random_walk_rate filter,
    every 10 Hz epoch): truth dynamic flexure, filter error and the filter's band, as PSDs
    and as RMS per :data:`BANDS_RAD_S` [″]."""
    kf = FlexureKfParams()
    flexure = FlexureParams(dynamic_model="hull", hull=HullParams(sea_state=sea_state))
    res = run_flexure_comparison(duration_s, seed, models={"random_walk_rate": kf},
                                 sim_rate_hz=10.0, lgu_rate_hz=10.0, convergence_s=convergence_s,
                                 flexure=flexure, record_period_s=0.0)["random_walk_rate"]
    s = res.series
    keep = s["t"] >= s["t"][0] + convergence_s
    dyn = (s["truth_flexure"] - s["truth_quasi_static"])[keep]
    err = (s["flexure"] - s["truth_flexure"])[keep]
    w, p_dyn = welch_rad(dyn, 10.0)
    _, p_err = welch_rad(err, 10.0)
    sig = np.array(kf.dynamic_rms_arcsec) * ARCSEC
    beta = np.broadcast_to(np.asarray(kf.dynamic_beta_per_s, float), (3,))
    lam = np.broadcast_to(np.asarray(kf.dynamic_freq_rad_s, float), (3,))
    p_band = np.column_stack([2.0 * band_psd(w, sig[a], beta[a], lam[a]) / (2.0 * math.pi) for a in range(3)])
    table = {f"{lo:g}-{hi:.3g}": {"truth_dynamic": (band_rms(w, p_dyn, lo, hi) / ARCSEC).tolist(),
                                  "filter_band": (band_rms(w, p_band, lo, hi) / ARCSEC).tolist(),
                                  "error": (band_rms(w, p_err, lo, hi) / ARCSEC).tolist()}
             for lo, hi in BANDS_RAD_S}
    return {"sea_state": sea_state, "seed": seed, "omega": w, "psd_truth_dynamic": p_dyn, "psd_error": p_err,
            "psd_filter_band": p_band, "bands": table,
            "error_rms_arcsec": (np.sqrt(np.mean(err ** 2, axis=0)) / ARCSEC).tolist(),
            "gated_fraction": res.counters["gated"] / max(res.counters["pairs"], 1),
            "truth_dynamic_rms_arcsec": (np.sqrt(np.mean(dyn ** 2, axis=0)) / ARCSEC).tolist()}


def format_spectrum(r: dict[str, Any]) -> str:
    f = lambda v: ", ".join(f"{x:6.1f}" for x in v)  # noqa: E731
    lines = [f"sea state {r['sea_state']}, seed {r['seed']}: random_walk_rate total error RMS {f(r['error_rms_arcsec'])}″;"
             f" truth dynamic RMS {f(r['truth_dynamic_rms_arcsec'])}″; LGU pairs gated {100 * r['gated_fraction']:.0f} %",
             "  band [rad/s]   truth dynamic (roll, pitch, yaw) | filter's band model | filter error  [″ RMS]"]
    for band, row in r["bands"].items():
        lines.append(f"  {band:12s}  {f(row['truth_dynamic'])} | {f(row['filter_band'])} | {f(row['error'])}")
    return "\n".join(lines)


def plot_spectra(results: list[dict[str, Any]], path: Path) -> None:
    plt = pyplot()
    fig, axes = plt.subplots(len(results), 3, figsize=(13, 3.2 * len(results)), squeeze=False)
    for row, r in zip(axes, results):
        w = r["omega"]
        for a, (ax, name) in enumerate(zip(row, ("roll", "pitch", "yaw"))):
            sel = w > 0
            k = 1.0 / ARCSEC ** 2
            ax.loglog(w[sel], k * r["psd_truth_dynamic"][sel, a], label="truth dynamic (hull)")
            ax.loglog(w[sel], k * r["psd_filter_band"][sel, a], "--", label="filter's band (assumed)")
            ax.loglog(w[sel], k * r["psd_error"][sel, a], label="filter error")
            ax.set_title(f"SS{r['sea_state']} {name}")
            ax.set_xlabel("ω [rad/s]")
            ax.set_ylabel("PSD [″²/(rad/s)]")
            ax.grid(True, which="both", alpha=0.3)
    axes[0][0].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


def budget_cases(sea_state: int) -> dict[str, tuple[FlexureParams, FlexureKfParams]]:
    """One source at a time (:func:`budget`): the truth configurations and filter settings
    compared, by label. The filter is the product's (its own model and tuning) except in the
    row labelled a diagnostic, which runs it without its innovation gate."""
    hull = HullParams(sea_state=sea_state)
    rms = HullFlexure(hull, np.random.default_rng(0), 0.1).rms() / ARCSEC
    no_qs = {"initial_deg": 0.0, "linear_rate_deg_h": 0.0, "slow_amplitude_arcsec": 0.0, "helm_amplitude_deg": 0.0}
    kf = FlexureKfParams()
    cases = {
        f"hull, sea state {sea_state} (all sources)": FlexureParams(dynamic_model="hull", hull=hull),
        "hull dynamic flexure alone (no quasi-static)": FlexureParams(dynamic_model="hull", hull=hull, **no_qs),
        "quasi-static alone (no dynamic flexure)": FlexureParams(dynamic_rms_arcsec=0.0),
        "hull, head seas (vertical bending only)": FlexureParams(
            dynamic_model="hull", hull=replace(hull, wave_heading_rad=math.pi)),
        f"filter's band at the hull's RMS ({', '.join(f'{x:.0f}' for x in rms)}″)": FlexureParams(
            dynamic_rms_arcsec=tuple(float(x) for x in rms)),
        "filter's own band (20″, 60″, 40″; ship_flexure_band)": FlexureParams(),
    }
    out = {label: (flex, kf) for label, flex in cases.items()}
    out[f"hull, sea state {sea_state}, filter ungated (diagnostic, not a default)"] = (
        FlexureParams(dynamic_model="hull", hull=hull), replace(kf, gate_probability=None))
    return out


def budget(sea_state: int, seeds: Sequence[int], duration_s: float, convergence_s: float = 600.0) -> dict[str, Any]:
    """The random_walk_rate filter's total-flexure RMS error [″] (mean over ``seeds``) with one
    truth source changed at a time (:func:`budget_cases`), core loop, no bag."""
    out: dict[str, Any] = {}
    for label, (flex, kf) in budget_cases(sea_state).items():
        rms, gated = [], []
        for seed in seeds:
            r = run_flexure_comparison(duration_s, seed, models={"rwr": kf}, sim_rate_hz=10.0, lgu_rate_hz=10.0,
                                       convergence_s=convergence_s, flexure=flex)["rwr"]
            rms.append(r.metrics["total_rms_arcsec"])
            gated.append(r.counters["gated"] / max(r.counters["pairs"], 1))
        out[label] = {"total_rms_arcsec": np.mean(rms, axis=0).tolist(), "gated_fraction": float(np.mean(gated))}
    return out


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(
        prog="python -m gimbal_sim.experiments.flexure_sea",
        description="Paper 5 flexure filters on a hull bent by a sea (scenario ship_flexure_sea_states): the "
                    "accuracy table per NATO sea state over seeds (a campaign on the one engine, each run's bag and "
                    "report kept with --out), or with --spectrum where in frequency the error lies.")
    ap.add_argument("--seeds", type=int, nargs="+", default=[0], help="seeds (default 0)")
    ap.add_argument("--sea-states", type=int, nargs="+", choices=SEA_STATES, default=list(SEA_STATES))
    ap.add_argument("--duration", type=float, default=7200.0, help="simulated time [s] (default 7200)")
    ap.add_argument("--spectrum", action="store_true", help="the spectrum comparison instead of the table")
    ap.add_argument("--budget", action="store_true",
                    help="the error budget, one truth source at a time (core loop, no bag), instead of the table")
    add_engine_arguments(ap, graph=True)
    a = ap.parse_args(argv)
    if not 0.0 < a.duration < math.inf:
        ap.error(f"--duration must be a finite number > 0, got {a.duration}")
    if len(set(a.seeds)) != len(a.seeds) or min(a.seeds) < 0:
        ap.error("--seeds must be distinct integers >= 0")
    if a.budget:
        if a.duration <= 600.0:
            ap.error("--budget needs --duration > 600 s (the first 600 s are left out)")
        for ss in a.sea_states:
            print(f"random_walk_rate total flexure RMS error, mean of seeds {list(a.seeds)}, {a.duration:.0f} s "
                  f"scored after 600 s (roll, pitch, yaw) [″]:")
            for label, v in budget(ss, a.seeds, a.duration).items():
                print(f"  {label:66s} {', '.join(f'{x:.1f}' for x in v['total_rms_arcsec'])}"
                      f"   LGU pairs gated {100 * v['gated_fraction']:.0f} %")
        return 0
    if a.spectrum:
        if a.duration <= 600.0:
            ap.error("--spectrum needs --duration > 600 s (the first 600 s are left out)")
        results = [spectrum(ss, seed, a.duration) for ss in a.sea_states for seed in a.seeds]
        for r in results:
            print(format_spectrum(r))
        if a.out:
            Path(a.out).mkdir(parents=True, exist_ok=True)
            plot_spectra(results, Path(a.out) / "flexure_sea_spectrum.png")
            print(f"figure: {Path(a.out) / 'flexure_sea_spectrum.png'}")
        return 0
    spec = CampaignSpec(scenario="", experiment=CAMPAIGN.name, seeds=tuple(a.seeds),
                        variants=tuple(f"sea_state_{n}" for n in a.sea_states), engine=a.engine, mode=a.mode,
                        options=(("duration_s", a.duration),))
    with campaign_dir(a.out) as out:
        runs = run_metrics(run_for_cli(ap, a, spec, out, CAMPAIGN, run_on_engine))
    print(campaign_table({v: [m for _, m in rs] for v, rs in runs.items()}))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
