"""Paper 1's headline figures (scenario ``sighting_land_vehicle``): LOS drift without and
with the gyro-bias EKF fed back, and the bias estimates against the truth.

Per run (``sighting_report``), from the bag:

* LOS drift (truth, ``/truth/gimbal/imu``): azimuth (cross-elevation) and elevation change
  of the inertial LOS from its initial direction (:func:`gimbal_kinematics.maths.los.los_drift`);
  at the end, and as a mean rate over the last ``LAST_SPAN_S``;
* the drift the true gyro bias alone would cause, −∫b dt (``/truth/gimbal/gyro_bias``:
  r for azimuth, q for elevation), and the ratio of the two;
* bias estimates (``/gyro_bias_ekf/bias``, ``bias_sigma``) against the truth: final error,
  the fraction of samples after ``SETTLE_S`` within ±3σ, the time-averaged NEES of (b_q, b_r).

The comparison (``sighting_comparison``) tabulates the variants side by side with each
run's real-time factor (``run.json``) and plots the drift of all of them and the bias
estimates of the feedback run with ±3σ.
"""
from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from gimbal_kinematics.maths.los import inertial_los, los_drift, los_from_quat
from gimbal_kinematics.maths.units import DEG_H_PER_RAD_S

from ..bag.reader import BagError
from ..figures import save_stacked, stacked, style
from .common import load_series, site_rate_n, times, vectors, vehicle_site
from .generic import generic_report

SETTLE_S = 30.0
LAST_SPAN_S = 60.0
TRUTH_LOS = "/truth/gimbal/imu"
TRUTH_BIAS = "/truth/gimbal/gyro_bias"
EKF_BIAS = "/gyro_bias_ekf/bias"
EKF_SIGMA = "/gyro_bias_ekf/bias_sigma"


def _interp_columns(t: np.ndarray, tp: np.ndarray, y: np.ndarray) -> np.ndarray:
    return np.column_stack([np.interp(t, tp, y[:, i]) for i in range(y.shape[1])])


@dataclass(frozen=True)
class SightingSeries:
    """What the sighting figures are computed from, as recorded (times are log times [s]):
    ``t_truth`` (N,) and ``quat_nm`` (N, 4) (x, y, z, w) of ``/truth/gimbal/imu``;
    ``t_bias`` (M,) and ``bias_true`` (M, 3) [rad/s] of ``/truth/gimbal/gyro_bias``;
    ``t_ekf`` (K,), ``bias_est`` and ``bias_sigma`` (K, 3) [rad/s] of the EKF's ``~/bias`` and
    ``~/bias_sigma`` (None without an EKF). A bag gives them (:func:`load_sighting_series`),
    and so does the core loop (``gimbal_sim.reports.core_metrics``), so that both
    engines' figures come from this one computation."""

    t_truth: np.ndarray
    quat_nm: np.ndarray
    t_bias: np.ndarray
    bias_true: np.ndarray
    t_ekf: np.ndarray | None = None
    bias_est: np.ndarray | None = None
    bias_sigma: np.ndarray | None = None


def load_sighting_series(bag_dir: Path) -> SightingSeries:
    """The recorded series of a run (:class:`SightingSeries`); raises :class:`BagError`
    when the truth topics are missing."""
    series, _ = load_series(bag_dir, {TRUTH_LOS, TRUTH_BIAS, EKF_BIAS, EKF_SIGMA})
    if not series.get(TRUTH_LOS) or not series.get(TRUTH_BIAS):
        raise BagError(f"{bag_dir}: needs {TRUTH_LOS} and {TRUTH_BIAS} (record the truth topics)")
    truth = series[TRUTH_LOS]
    quats = np.array([[m.orientation.x, m.orientation.y, m.orientation.z, m.orientation.w] for _, m in truth])
    ekf = {}
    if series.get(EKF_BIAS) and series.get(EKF_SIGMA):
        ekf = dict(t_ekf=times(series[EKF_BIAS]), bias_est=vectors(series[EKF_BIAS]),
                   bias_sigma=vectors(series[EKF_SIGMA]))
    return SightingSeries(times(truth), quats, times(series[TRUTH_BIAS]), vectors(series[TRUTH_BIAS]), **ekf)


def analyse(bag_dir: Path) -> dict:
    """The run's series and figures (SI units; see the module docstring)."""
    lat, earth_rate = vehicle_site(bag_dir)
    return analyse_series(load_sighting_series(bag_dir), lat, earth_rate)


def analyse_series(s: SightingSeries, lat: float, earth_rate: bool) -> dict:
    """Series and figures of one run from its :class:`SightingSeries`, at latitude ``lat``
    [rad] with or without the earth rate (the run's vehicle site)."""
    t0 = s.t_truth[0]
    t = s.t_truth - t0
    drift = los_drift(inertial_los(los_from_quat(s.quat_nm), t, site_rate_n(lat, earth_rate)))
    tb = s.t_bias - t0
    b_true = s.bias_true
    # −∫b dt by trapezoids on the bias samples (az from r = z, el from q = y)
    integral = np.zeros((len(tb), 2))
    if len(tb) > 1:
        dt = np.diff(tb)[:, None]
        integral[1:] = -np.cumsum(0.5 * dt * (b_true[1:, [2, 1]] + b_true[:-1, [2, 1]]), axis=0)
    integral = _interp_columns(t, tb, integral)
    i_last = int(np.searchsorted(t, t[-1] - LAST_SPAN_S))
    span = t[-1] - t[i_last]
    out = {"t": t, "drift": drift, "bias_integral": integral,
           "final_drift_deg": np.degrees(drift[-1]), "bias_integral_deg": np.degrees(integral[-1]),
           "drift_rate_last_deg_h": np.degrees(drift[-1] - drift[i_last]) / span * 3600.0 if span > 0 else
           np.full(2, np.nan), "bias_rate_last_deg_h": np.degrees(integral[-1] - integral[i_last]) / span * 3600.0
           if span > 0 else np.full(2, np.nan)}
    if s.t_ekf is not None and len(s.t_ekf):
        te = s.t_ekf - t0
        est, sig = s.bias_est, s.bias_sigma
        tru = _interp_columns(te, tb, b_true)
        err = est[:, 1:] - tru[:, 1:]
        late = te >= SETTLE_S
        nees = np.sum((err / sig[:, 1:]) ** 2, axis=1)
        out.update(t_ekf=te, bias_est=est, bias_sigma=sig, bias_true=tru, nees_bias=nees,
                   final_bias_error_deg_h=err[-1] * DEG_H_PER_RAD_S,
                   within_3sigma=np.mean(np.abs(err[late]) <= 3.0 * sig[late, 1:], axis=0) if late.any()
                   else np.full(2, np.nan),
                   mean_nees_bias=float(np.mean(nees[late])) if late.any() else math.nan)
    return out


def sighting_figures(s: SightingSeries, lat: float, earth_rate: bool) -> dict:
    """The ``sighting`` entry of a run's metrics.json, from its series."""
    return _figures(analyse_series(s, lat, earth_rate))


def _figures(a: dict) -> dict:
    fig = {
        "final_drift_deg": {"azimuth": float(a["final_drift_deg"][0]), "elevation": float(a["final_drift_deg"][1])},
        "true_bias_drift_deg": {"azimuth": float(a["bias_integral_deg"][0]),
                                "elevation": float(a["bias_integral_deg"][1])},
        "drift_over_bias_drift": {k: float(a["final_drift_deg"][i] / a["bias_integral_deg"][i])
                                  if a["bias_integral_deg"][i] else None for i, k in enumerate(("azimuth", "elevation"))},
        "drift_rate_last_60s_deg_h": {"azimuth": float(a["drift_rate_last_deg_h"][0]),
                                      "elevation": float(a["drift_rate_last_deg_h"][1])},
        "bias_drift_rate_last_60s_deg_h": {"azimuth": float(a["bias_rate_last_deg_h"][0]),
                                           "elevation": float(a["bias_rate_last_deg_h"][1])},
    }
    if "bias_est" in a:
        fig["final_bias_error_deg_h"] = {"q": float(a["final_bias_error_deg_h"][0]),
                                         "r": float(a["final_bias_error_deg_h"][1])}
        fig["bias_within_3sigma_after_30s"] = {"q": float(a["within_3sigma"][0]), "r": float(a["within_3sigma"][1])}
        fig["bias_nees_mean_after_30s"] = a["mean_nees_bias"]
    return fig


def _plot_drift(path: Path, runs: dict[str, dict]) -> None:
    fig, axes = stacked(2, 6.5)
    for j, (axis_name, ax) in enumerate(zip(("azimuth (cross-elevation)", "elevation"), axes[:, 0])):
        for name, a in runs.items():
            ax.plot(a["t"], np.degrees(a["drift"][:, j]), label=f"{name}: LOS drift", linewidth=1.2)
        first = next(iter(runs.values()))
        ax.plot(first["t"], np.degrees(first["bias_integral"][:, j]), "k--", linewidth=0.8,
                label="−∫ true gyro bias dt")
        style(ax, f"{axis_name} [deg]")
    save_stacked(fig, axes, path, "LOS drift from the initial inertial direction (truth)")


def _plot_bias(path: Path, a: dict, title: str) -> None:
    fig, axes = stacked(2, 6.5)
    te = a["t_ekf"]
    for j, (axis_name, ax) in enumerate(zip(("q (elevation gyro)", "r (azimuth gyro)"), axes[:, 0])):
        est, sig, tru = a["bias_est"][:, j + 1] * DEG_H_PER_RAD_S, a["bias_sigma"][:, j + 1] * DEG_H_PER_RAD_S, a["bias_true"][:, j + 1] * DEG_H_PER_RAD_S
        ax.fill_between(te, est - 3 * sig, est + 3 * sig, color="C0", alpha=0.2, label="estimate ±3σ")
        ax.plot(te, est, color="C0", linewidth=1.0, label="EKF estimate")
        ax.plot(te, tru, "k", linewidth=1.0, label="truth")
        lo, hi = np.percentile(tru, [0, 100])
        pad = max(30.0, 0.5 * (hi - lo))
        ax.set_ylim(lo - pad, hi + pad)
        style(ax, f"bias {axis_name} [deg/h]")
    save_stacked(fig, axes, path, title)


def sighting_report(bag_dir: Path, out: Path) -> dict:
    """One run: drift and bias figures and plots (module docstring)."""
    metrics = generic_report(bag_dir, out)
    a = analyse(bag_dir)
    metrics["sighting"] = _figures(a)
    _plot_drift(out / "los_drift.png", {"this run": a})
    metrics["plots"].append("los_drift.png")
    if "bias_est" in a:
        _plot_bias(out / "bias_estimates.png", a, "Gyro-bias EKF estimates against the truth")
        metrics["plots"].append("bias_estimates.png")
    return metrics


def _rtf(bag_dir: Path) -> float | None:
    run = bag_dir / "run.json"
    return json.loads(run.read_text()).get("real_time_factor") if run.is_file() else None


def sighting_comparison(runs: dict[str, Path], out: Path) -> dict:
    """Variants side by side: table, drift plot of all, bias plot of each run that fed back."""
    analysed = {name: analyse(bag) for name, bag in runs.items()}
    rows = [("case", "az drift [deg]", "el drift [deg]", "az/el rate last 60 s [deg/h]",
             "final bias err q/r [deg/h]", "RTF")]
    cases = {}
    for name, a in analysed.items():
        fig = _figures(a)
        fig["real_time_factor"] = _rtf(runs[name])
        cases[name] = fig
        d, r = a["final_drift_deg"], a["drift_rate_last_deg_h"]
        berr = a.get("final_bias_error_deg_h")
        rows.append((name, f"{d[0]:+.4f}", f"{d[1]:+.4f}", f"{r[0]:+.2f} / {r[1]:+.2f}",
                     "-" if berr is None else f"{berr[0]:+.2f} / {berr[1]:+.2f}",
                     "-" if fig["real_time_factor"] is None else f"{fig['real_time_factor']:.2f}"))
    first = next(iter(analysed.values()))
    rows.append(("−∫ true bias", f"{first['bias_integral_deg'][0]:+.4f}", f"{first['bias_integral_deg'][1]:+.4f}",
                 f"{first['bias_rate_last_deg_h'][0]:+.2f} / {first['bias_rate_last_deg_h'][1]:+.2f}", "", ""))
    widths = [max(len(str(r[i])) for r in rows) for i in range(len(rows[0]))]
    table = "\n".join("  ".join(str(c).rjust(w) if i else str(c).ljust(w) for i, (c, w) in
                                enumerate(zip(r, widths))) for r in rows)
    _plot_drift(out / "los_drift.png", analysed)
    plots = ["los_drift.png"]
    for name, a in analysed.items():
        if "bias_est" in a:
            _plot_bias(out / f"bias_estimates_{name}.png", a, f"Gyro-bias EKF estimates against the truth ({name})")
            plots.append(f"bias_estimates_{name}.png")
    return {"cases": cases, "table": "LOS drift at the end of the run (paper 1):\n" + table, "plots": plots,
            "runs": {k: str(v) for k, v in runs.items()}}
