"""The ``flexure`` report: paper 5's Figs. 2-8 and the flexure metrics, from the bag.

Truth: ``/truth/ship/flexure`` and ``/truth/ship/flexure_quasi_static`` (sensor_models, one
per LGU sample); the true bias difference is the configured fixed LGU biases
(sensor_models' ``lgu1_bias_deg_h − lgu2_bias_deg_h`` from the run's scenario.yaml, else
their defaults; the LGU model has no other bias term). Estimates: every
``flexure_estimator`` node of the run (scenario.yaml; without one, every
``/<node>/flexure_sigma`` topic), its ``~/flexure``, ``~/quasi_static``, ``~/dynamic``,
``~/bias_diff`` and their ``_sigma`` companions, matched to the truth by header stamp.
Errors are estimate − truth; metrics use the epochs after ``convergence_s``.

Figures (paper 5 → here): Fig. 2 → ``flexure_truth_fig2.png``; Figs. 3, 4 and 6 →
``<node>_errors.png`` (quasi-static, dynamic and total error with ±3σ); Fig. 7 →
``<node>_estimates.png``; Figs. 5 and 8 → ``<node>_bias_diff.png``; the paper's contrast
in one plot → ``quasi_static_error_comparison.png``.
"""
from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from gimbal_kinematics.maths.units import ARCSEC, DEG_H

from ..bag.reader import BagError, scan
from ..figures import save, stacked
from ..graph.registry import NODE_TYPES
from .common import load_series
from .generic import generic_report

AXES = ("roll", "pitch", "yaw")
ESTIMATOR = "flexure_estimator"
#: Estimator output stems (each with a ``_sigma`` companion).
OUTPUTS = ("flexure", "quasi_static", "dynamic", "bias_diff")
TRUTH_TOPICS = ("/truth/ship/flexure", "/truth/ship/flexure_quasi_static")


def flexure_metrics(s: dict[str, np.ndarray], convergence_s: float, settle_deg_h: float = 0.01,
                    helm_period_s: float = 200.0) -> dict[str, Any]:
    """Scores from series ``s``: ``t`` (N,) [s] and (N, 3) arrays ``truth_flexure``,
    ``truth_quasi_static``, ``truth_bias_diff``, ``flexure``, ``flexure_sigma``,
    ``quasi_static``, ``bias_diff`` [rad, rad/s].

    Keys (per axis roll, pitch, yaw unless noted): ``total_rms_arcsec``, ``total_max_arcsec``
    (total-flexure error), ``total_sigma_rms_arcsec`` (RMS of the filter's own 1σ: the
    error it expects); ``qs_rms_arcsec``, ``qs_max_arcsec`` (quasi-static error);
    ``qs_variation_pp_arcsec`` (peak-to-peak of the true quasi-static flexure over the run)
    and ``qs_variation_rms_arcsec`` (its RMS about its mean after convergence);
    ``qs_max_over_variation_pp`` (the paper's "about half the variation" figure);
    ``helm_error_fraction``: amplitude of the quasi-static error's component at the helm
    period over the truth's (least squares on [1, t, sin, cos] after convergence; ≪ 1 when
    the helm flexure is tracked, ≈ 1 when it is ignored);
    ``bias_diff_err_final_deg_h``, ``bias_diff_err_max_deg_h``, ``bias_diff_err_rms_deg_h``,
    ``bias_diff_err_last600_max_deg_h`` (largest error in the last 600 s);
    ``total_within_3sigma`` (fraction of epochs with every axis inside ±3σ);
    ``total_nees_mean`` (Σ (e/σ)² over the axes with the diagonal σ; about 3 if consistent);
    ``bias_diff_settle_s`` (scalar): time after which every axis's bias-difference error
    stays within ``settle_deg_h`` (nan if it ends outside); ``n_epochs`` (scalar).
    """
    t = np.asarray(s["t"], float)
    sel = t >= convergence_s
    if not np.any(sel):
        raise ValueError(f"no filter epochs after convergence_s = {convergence_s} s")
    e_tot = (s["flexure"] - s["truth_flexure"])[sel]
    e_qs = (s["quasi_static"] - s["truth_quasi_static"])[sel]
    e_eps_all = s["bias_diff"] - s["truth_bias_diff"]
    e_eps = e_eps_all[sel]
    qs_true = s["truth_quasi_static"]
    rms = lambda e: np.sqrt(np.mean(e * e, axis=0))  # noqa: E731
    sig = s["flexure_sigma"][sel]
    outside = np.any(np.abs(e_eps_all) > settle_deg_h * DEG_H, axis=1)
    if outside[-1]:
        settle = math.nan
    else:
        idx = np.flatnonzero(outside)
        settle = float(t[idx[-1] + 1]) if idx.size else float(t[0])
    last = t >= t[-1] - 600.0
    return {
        "total_rms_arcsec": rms(e_tot) / ARCSEC,
        "total_max_arcsec": np.max(np.abs(e_tot), axis=0) / ARCSEC,
        "total_sigma_rms_arcsec": rms(sig) / ARCSEC,
        "qs_rms_arcsec": rms(e_qs) / ARCSEC,
        "qs_max_arcsec": np.max(np.abs(e_qs), axis=0) / ARCSEC,
        "qs_variation_pp_arcsec": np.ptp(qs_true, axis=0) / ARCSEC,
        "qs_variation_rms_arcsec": np.std(qs_true[sel], axis=0) / ARCSEC,
        "qs_max_over_variation_pp": np.max(np.abs(e_qs), axis=0) / np.ptp(qs_true, axis=0),
        "helm_error_fraction": (_tone_amplitude(t[sel], e_qs, helm_period_s)
                                / _tone_amplitude(t[sel], qs_true[sel], helm_period_s)),
        "bias_diff_err_final_deg_h": e_eps[-1] / DEG_H,
        "bias_diff_err_max_deg_h": np.max(np.abs(e_eps), axis=0) / DEG_H,
        "bias_diff_err_rms_deg_h": rms(e_eps) / DEG_H,
        "bias_diff_err_last600_max_deg_h": np.max(np.abs(e_eps_all[last]), axis=0) / DEG_H,
        "total_within_3sigma": float(np.mean(np.all(np.abs(e_tot) <= 3.0 * sig, axis=1))),
        "total_nees_mean": float(np.mean(np.sum((e_tot / np.maximum(sig, 1e-300)) ** 2, axis=1))),
        "bias_diff_settle_s": settle,
        "n_epochs": int(np.count_nonzero(sel)),
    }


def _tone_amplitude(t: np.ndarray, y: np.ndarray, period_s: float) -> np.ndarray:
    """Amplitude (3,) of the sinusoid of ``period_s`` in each column of ``y`` (N, 3), fitted
    by least squares together with an offset and a linear trend (which absorb the slower
    components over the window)."""
    w = 2.0 * math.pi / period_s
    tc = t - t.mean()
    basis = np.column_stack([np.ones_like(tc), tc / max(np.ptp(tc), 1e-9), np.sin(w * tc), np.cos(w * tc)])
    coef, *_ = np.linalg.lstsq(basis, y, rcond=None)
    return np.hypot(coef[2], coef[3])


# ---------------------------------------------------------------------------- bag reading
def _run_config(bag_dir: Path) -> dict[str, dict]:
    """The run's scenario nodes (name -> {"executable", "params"}), {} without scenario.yaml."""
    scenario_file = bag_dir / "scenario.yaml"
    if not scenario_file.is_file():
        return {}
    return yaml.safe_load(scenario_file.read_text()).get("nodes", {}) or {}


def _param(nodes: dict[str, dict], executable: str, name: str) -> Any:
    """A node parameter from the run (first node of ``executable``), else its declared default."""
    for spec in nodes.values():
        if spec.get("executable") == executable and name in (spec.get("params") or {}):
            return spec["params"][name]
    return next(p.default for p in NODE_TYPES[executable].params if p.name == name)


def estimator_nodes(bag_dir: Path, topics: set[str]) -> dict[str, str]:
    """``{node name: quasi-static model}`` of the run's flexure estimators, in run order
    (from scenario.yaml; without it, every ``/<node>/flexure_sigma`` topic, model unknown)."""
    nodes = _run_config(bag_dir)
    if nodes:
        default = _param({}, ESTIMATOR, "quasi_static_model")
        return {name: (spec.get("params") or {}).get("quasi_static_model", default)
                for name, spec in nodes.items() if spec.get("executable") == ESTIMATOR}
    return {t.split("/")[1]: "unknown" for t in sorted(topics) if t.count("/") == 2 and t.endswith("/flexure_sigma")}


def _stamped(samples: list) -> tuple[np.ndarray, np.ndarray]:
    """(header stamps [ns] (N,), vectors (N, 3)) of a Vector3Stamped topic."""
    ns = np.array([m.header.stamp.sec * 1_000_000_000 + m.header.stamp.nanosec for _, m in samples], dtype=np.int64)
    vec = np.array([[m.vector.x, m.vector.y, m.vector.z] for _, m in samples], dtype=float).reshape(-1, 3)
    return ns, vec


def load_flexure_runs(bag_dir: Path) -> tuple[dict[str, dict[str, np.ndarray]], dict[str, str], dict[str, Any]]:
    """Per estimator node, its series (the :func:`flexure_metrics` keys plus the ``_sigma``
    companions and ``truth_dynamic``) on its own epochs, matched to the truth by stamp.
    Returns (series by node, models by node, truth settings)."""
    bag_dir = Path(bag_dir)

    topics = set(scan(bag_dir).topics)
    models = estimator_nodes(bag_dir, topics)
    if not models:
        raise BagError(f"{bag_dir}: no flexure_estimator node in the run")
    wanted = set(TRUTH_TOPICS) | {f"/{n}/{o}{s}" for n in models for o in OUTPUTS for s in ("", "_sigma")}
    series, _ = load_series(bag_dir, wanted)
    for topic in TRUTH_TOPICS:
        if not series.get(topic):
            raise BagError(f"{bag_dir}: no {topic} (the flexure truth) in the bag")
    truth_ns, truth_flex = _stamped(series[TRUTH_TOPICS[0]])
    qs_ns, truth_qs = _stamped(series[TRUTH_TOPICS[1]])
    if not np.array_equal(truth_ns, qs_ns):
        raise BagError(f"{bag_dir}: the two flexure truth topics do not share their stamps")
    nodes = _run_config(bag_dir)
    eps_true = (float(_param(nodes, "sensor_models", "lgu1_bias_deg_h"))
                - float(_param(nodes, "sensor_models", "lgu2_bias_deg_h"))) * DEG_H
    settings = {"true_bias_diff_deg_h": eps_true / DEG_H,
                "helm_period_s": float(_param(nodes, "sensor_models", "flexure_helm_period_s"))}
    runs: dict[str, dict[str, np.ndarray]] = {}
    for node in models:
        parts = {}
        for o in OUTPUTS:
            for suffix in ("", "_sigma"):
                topic = f"/{node}/{o}{suffix}"
                if not series.get(topic):
                    raise BagError(f"{bag_dir}: no {topic} in the bag")
                parts[o + suffix] = _stamped(series[topic])
        ns = parts["flexure"][0]
        if any(not np.array_equal(ns, p[0]) for p in parts.values()):
            raise BagError(f"{bag_dir}: the outputs of {node} do not share their stamps")
        idx = np.searchsorted(truth_ns, ns)
        ok = (idx < truth_ns.size) & (truth_ns[np.minimum(idx, truth_ns.size - 1)] == ns)
        if not np.all(ok):
            raise BagError(f"{bag_dir}: {np.count_nonzero(~ok)} estimates of {node} have no truth sample")
        s = {k: v[1] for k, v in parts.items()}
        s["t"] = ns * 1e-9  # stamps are simulation time from t = 0
        s["truth_flexure"] = truth_flex[idx]
        s["truth_quasi_static"] = truth_qs[idx]
        s["truth_dynamic"] = truth_flex[idx] - truth_qs[idx]
        s["truth_bias_diff"] = np.full_like(s["flexure"], eps_true)
        runs[node] = s
    return runs, models, settings


# ---------------------------------------------------------------------------- plots
def _axes_figure(path: Path, title: str, t: np.ndarray, rows: list[tuple[str, dict[str, np.ndarray], Any]],
                 zoom_from_s: float | None = None) -> None:
    """One column per axis (roll, pitch, yaw), one row per ``(ylabel, {label: (N, 3)},
    3σ (N, 3) or None)``; a 3σ array is drawn as a ±3σ band about zero. ``zoom_from_s``:
    scale the y axes to the data from that time on (the start-up transient is hundreds
    of times larger than the converged errors)."""
    fig, axs = stacked(len(rows), 3.0 * len(rows) + 0.6, cols=3, width_in=14.0)
    for r, (ylabel, curves, sig3) in enumerate(rows):
        for a in range(3):
            ax = axs[r, a]
            if sig3 is not None:
                ax.fill_between(t, -sig3[:, a], sig3[:, a], color="0.85", label="±3σ (filter)")
            for label, y in curves.items():
                ax.plot(t, y[:, a], linewidth=0.8, label=label)
            if zoom_from_s is not None and np.any(t >= zoom_from_s):
                sel = t >= zoom_from_s
                shown = [y[sel, a] for y in curves.values()]
                if sig3 is not None:
                    shown += [sig3[sel, a], -sig3[sel, a]]
                lo, hi = min(float(np.min(v)) for v in shown), max(float(np.max(v)) for v in shown)
                pad = 0.05 * (hi - lo) + 1e-12
                ax.set_ylim(lo - pad, hi + pad)
            ax.grid(True, alpha=0.3)
            if r == 0:
                ax.set_title(AXES[a])
            if a == 0:
                ax.set_ylabel(ylabel)
            if r == len(rows) - 1:
                ax.set_xlabel("sim time [s]")
        axs[r, 0].legend(loc="best", fontsize=7)
    fig.suptitle(title)
    save(fig, path, dpi=100)


def _as(x: np.ndarray) -> np.ndarray:
    return x / ARCSEC


def flexure_report(bag_dir: Path, out: Path, convergence_s: float = 600.0) -> dict:
    """Paper 5 figures and metrics (module docstring) for every flexure estimator of the run,
    scored after ``convergence_s`` [s] (half the run if that is shorter)."""
    bag_dir = Path(bag_dir)
    runs, models, settings = load_flexure_runs(bag_dir)
    first = next(iter(runs.values()))
    t = first["t"]
    if t.size == 0:
        raise BagError(f"{bag_dir}: the flexure estimators published nothing")
    # A run shorter than twice the convergence time (a smoke test) is scored on its second half.
    convergence_s = min(convergence_s, 0.5 * float(t[-1]))
    metrics = generic_report(bag_dir, out)  # bag summary (topics, counts, closed cleanly) and its truth plot
    metrics.update({"convergence_s": convergence_s, **settings, "estimators": {}})
    plots = metrics["plots"]
    zoom = 0.5 * convergence_s  # error plots are scaled to the data from here on
    _axes_figure(out / "flexure_truth_fig2.png", "Simulated ship flexure LGU1 → LGU2 (truth; paper 5 Fig. 2)", t, [
        ("quasi-static variation [″]", {"Φ(t) − Φ(0)": _as(first["truth_quasi_static"] - first["truth_quasi_static"][0])},
         None),
        ("total flexure [″]", {"Φ + θ": _as(first["truth_flexure"])}, None),
    ])
    plots.append("flexure_truth_fig2.png")
    for node, s in runs.items():
        model = models[node]
        m = flexure_metrics(s, convergence_s, helm_period_s=settings["helm_period_s"])
        m["model"] = model
        metrics["estimators"][node] = {k: (v.tolist() if isinstance(v, np.ndarray) else v) for k, v in m.items()}
        t = s["t"]
        _axes_figure(out / f"{node}_estimates.png", f"{node} ({model}): estimates and truth (paper 5 Fig. 7)", t, [
            ("quasi-static [″]", {"truth": _as(s["truth_quasi_static"]), "estimate": _as(s["quasi_static"])}, None),
            ("total flexure [″]", {"truth": _as(s["truth_flexure"]), "estimate": _as(s["flexure"])}, None),
        ])
        _axes_figure(out / f"{node}_errors.png",
                     f"{node} ({model}): estimation errors with the filter's ±3σ (paper 5 Figs. 3, 4, 6)", t, [
            ("quasi-static error [″]", {"error": _as(s["quasi_static"] - s["truth_quasi_static"])},
             3.0 * _as(s["quasi_static_sigma"])),
            ("dynamic error [″]", {"error": _as(s["dynamic"] - s["truth_dynamic"])}, 3.0 * _as(s["dynamic_sigma"])),
            ("total flexure error [″]", {"error": _as(s["flexure"] - s["truth_flexure"])},
             3.0 * _as(s["flexure_sigma"])),
        ], zoom_from_s=zoom)
        _axes_figure(out / f"{node}_bias_diff.png", f"{node} ({model}): bias difference ε1 − ε2 (paper 5 Figs. 5, 8)",
                     t, [
            ("ε1 − ε2 [°/h]", {"truth": s["truth_bias_diff"] / DEG_H, "estimate": s["bias_diff"] / DEG_H}, None),
            ("error [°/h]", {"error": (s["bias_diff"] - s["truth_bias_diff"]) / DEG_H},
             3.0 * s["bias_diff_sigma"] / DEG_H),
        ], zoom_from_s=zoom)
        plots += [f"{node}_estimates.png", f"{node}_errors.png", f"{node}_bias_diff.png"]
    t = first["t"]
    _axes_figure(out / "quasi_static_error_comparison.png", "Quasi-static flexure error of each model", t, [
        ("quasi-static error [″]",
         {f"{n} ({models[n]})": _interp(t, s["t"], s["quasi_static"] - s["truth_quasi_static"])
          for n, s in runs.items()}, None),
        ("quasi-static truth variation [″]",
         {"Φ(t) − Φ(0)": _as(first["truth_quasi_static"] - first["truth_quasi_static"][0])}, None),
    ], zoom_from_s=zoom)
    plots.append("quasi_static_error_comparison.png")
    return metrics


def _interp(t: np.ndarray, ts: np.ndarray, y: np.ndarray) -> np.ndarray:
    """``y`` (M, 3) sampled at ``ts`` resampled to ``t`` (N,) [rad → arcsec]."""
    return np.column_stack([np.interp(t, ts, y[:, a]) for a in range(3)]) / ARCSEC


def flexure_sea_states_comparison(runs: dict[str, Path], out: Path, convergence_s: float = 600.0) -> dict:
    """Sea states side by side (scenario ``ship_flexure_sea_states``): per variant and
    estimator, the total-flexure RMS error (roll, pitch, yaw) [″] and mean NEES after
    ``convergence_s`` (half the run if shorter), and the truth's dynamic-flexure RMS [″]."""
    cases: dict[str, dict[str, Any]] = {}
    for name, bag in runs.items():
        est, models, _ = load_flexure_runs(Path(bag))
        first = next(iter(est.values()))
        conv = min(convergence_s, 0.5 * float(first["t"][-1]))
        keep = first["t"] >= first["t"][0] + conv
        dyn = first["truth_flexure"] - first["truth_quasi_static"]
        case: dict[str, Any] = {"truth_dynamic_rms_arcsec": (np.sqrt(np.mean(dyn[keep] ** 2, axis=0)) / ARCSEC).tolist()}
        for node, s in est.items():
            m = flexure_metrics(s, conv)
            case[node] = {"model": models[node], "total_rms_arcsec": np.asarray(m["total_rms_arcsec"]).tolist(),
                          "total_nees_mean": float(m["total_nees_mean"])}
        cases[name] = case
    f = lambda v: ", ".join(f"{x:.1f}" for x in v)  # noqa: E731
    lines = ["Total flexure RMS error (roll, pitch, yaw) [″] per sea state; paper 5 (full-scale ships): 20″"]
    for name, case in cases.items():
        lines.append(f"{name}: truth dynamic flexure RMS {f(case['truth_dynamic_rms_arcsec'])}″")
        for node, c in case.items():
            if node != "truth_dynamic_rms_arcsec":
                lines.append(f"  {node:36s} {f(c['total_rms_arcsec'])}″  NEES {c['total_nees_mean']:.2f}")
    return {"cases": cases, "table": "\n".join(lines), "plots": [], "runs": {k: str(v) for k, v in runs.items()}}
