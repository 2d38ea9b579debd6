"""The ``geo_pointing`` report (scenario ``sighting_geo_pointing``): the true pointing error
at the target beside the budget the ``geo_pointer`` node computed.

True error: the angle between the true LOS (first column of the true C(n,m),
``/truth/gimbal/imu``) and the true direction from the sight pivot to the target
(:func:`gimbal_kinematics.maths.geo_pointing.los_to_target` with the vehicle's true site, from the
run's scenario.yaml; the truth has no position error). Measured from ``acquire_s`` on (the
initial slew onto the target is not pointing). Budget: ``/geo_pointer/budget``: x, the 1σ RMS
pointing error the node predicts, and y, z the two semi-axes of its covariance, from which
:func:`gimbal_kinematics.maths.geo_pointing.radial_quantile` gives the radius the error stays
within 95 % of the time (the node's ``PointingBudget.radius_95_rad``, one function). "Within
budget", the fraction of the time the true error is at or below the newest budget, is judged
against that 95 % radius (a ≥ 95 % requirement needs a 95 % bound: a two-axis error is within
its RMS only about 63 % of the time); the fraction within the 1σ RMS is given beside it.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import yaml
from gimbal_kinematics.maths.geo_pointing import los_to_target, radial_quantile
from gimbal_kinematics.maths.los import los_from_quat

from ..bag.reader import BagError
from .common import load_series, plot, times, vectors
from .generic import generic_report

ACQUIRE_S = 10.0
BUDGET_TOPIC = "/geo_pointer/budget"


def _geometry(bag_dir: Path) -> tuple[tuple, tuple, tuple]:
    """(vehicle site, target, lever arm) of the run: site from the vehicle's profile, the
    rest from the geo_pointer's parameters (radians, metres)."""
    scenario_file = bag_dir / "scenario.yaml"
    if not scenario_file.is_file():
        raise BagError(f"{bag_dir}: no scenario.yaml (the geometry of the run)")
    nodes = yaml.safe_load(scenario_file.read_text()).get("nodes", {})
    by_exe = {n.get("executable", name): n.get("params", {}) for name, n in nodes.items()}
    vehicle, pointer = by_exe.get("vehicle_dynamics", {}), by_exe.get("geo_pointer")
    if pointer is None:
        raise BagError(f"{bag_dir}: the run has no geo_pointer node")
    site = yaml.safe_load(vehicle.get("profile_params", "{}")) or {}
    llh = (math.radians(site.get("lat_deg", 0.0)), math.radians(site.get("lon_deg", 0.0)), site.get("height_m", 0.0))
    t = pointer["target_llh_deg"]
    return llh, (math.radians(t[0]), math.radians(t[1]), float(t[2])), tuple(pointer.get("lever_arm_b_m", (0, 0, 0)))


def analyse(bag_dir: Path, acquire_s: float = ACQUIRE_S) -> dict:
    """The true pointing error against the budget (module docstring)."""
    series, _ = load_series(bag_dir, {"/truth/gimbal/imu", BUDGET_TOPIC})
    gimbal = series.get("/truth/gimbal/imu", [])
    budget = series.get(BUDGET_TOPIC, [])
    if not gimbal or not budget:
        raise BagError(f"{bag_dir}: needs /truth/gimbal/imu and {BUDGET_TOPIC}")
    quats = np.array([[m.orientation.x, m.orientation.y, m.orientation.z, m.orientation.w] for _, m in gimbal])
    return analyse_series(bag_dir, times(gimbal), quats, times(budget), vectors(budget), acquire_s)


def analyse_series(run_dir: Path, t: np.ndarray, quat_nm: np.ndarray, tb: np.ndarray, budget: np.ndarray,
                   acquire_s: float = ACQUIRE_S) -> dict:
    """:func:`analyse` on the recorded series: the true C(n,m) quaternions (x, y, z, w) at
    log times ``t`` [s], the budgets (M, 3) [rad] at ``tb``; the geometry from ``run_dir``'s
    scenario.yaml. A bag gives them, and so does the core loop
    (``gimbal_sim.reports.core_metrics``): one computation for both engines."""
    site, target, lever = _geometry(run_dir)
    if any(lever):
        raise BagError("a lever arm needs the true vehicle attitude per sample; not in this report")
    los = los_from_quat(quat_nm)
    u = los_to_target(site, target).los_n
    err = np.arctan2(np.linalg.norm(np.cross(los, u), axis=1), los @ u)
    out = pointing_figures(t, err, tb, budget, acquire_s)
    if out is None:
        raise BagError(f"{run_dir}: the run is shorter than the acquisition time {acquire_s} s")
    return out


def pointing_figures(t: np.ndarray, err: np.ndarray, tb: np.ndarray, budget: np.ndarray,
                     acquire_s: float = ACQUIRE_S) -> dict | None:
    """The figures from the true error ``err`` [rad] at times ``t`` [s] and the budgets
    (``~/budget``: (x, y, z) [rad], (M, 3)) at ``tb``, each error sample against the newest
    budget, from ``acquire_s`` on (module docstring); None if nothing is left."""
    b = budget[:, 0]
    b95 = np.array([radial_quantile(s1, s2) for s1, s2 in budget[:, 1:]])
    idx = np.clip(np.searchsorted(tb, t, side="right") - 1, 0, len(tb) - 1)
    keep = (t - t[0] >= acquire_s) & (t >= tb[0])
    if not keep.any():
        return None
    e = err[keep]
    return {"t": t, "error_rad": err, "budget_t": tb, "budget_rad": b, "acquire_s": acquire_s,
            "error_rms_mrad": float(1e3 * np.sqrt(np.mean(e ** 2))), "error_peak_mrad": float(1e3 * e.max()),
            "error_rms_urad": float(1e6 * np.sqrt(np.mean(e ** 2))),
            "budget_mean_mrad": float(1e3 * np.mean(b[idx[keep]])),
            "budget_95_mean_mrad": float(1e3 * np.mean(b95[idx[keep]])),
            "within_budget_95_fraction": float(np.mean(e <= b95[idx[keep]])),
            "within_budget_1sigma_fraction": float(np.mean(e <= b[idx[keep]]))}


def geo_pointing_figures(a: dict) -> dict:
    """The ``geo_pointing`` entry of a run's metrics.json, from :func:`analyse`'s output."""
    return _figures(a)


def _figures(a: dict) -> dict:
    return {k: a[k] for k in ("acquire_s", "error_rms_mrad", "error_peak_mrad", "error_rms_urad", "budget_mean_mrad",
                              "budget_95_mean_mrad", "within_budget_95_fraction", "within_budget_1sigma_fraction")}


def geo_pointing_report(bag_dir: Path, out: Path) -> dict:
    metrics = generic_report(bag_dir, out)
    a = analyse(bag_dir)
    metrics["geo_pointing"] = _figures(a)
    plot(out / "pointing_error.png", "True pointing error at the target", a["t"],
         {"true error": 1e3 * a["error_rad"]}, "[mrad]")
    metrics["plots"].append("pointing_error.png")
    return metrics


def geo_pointing_comparison(runs: dict[str, Path], out: Path) -> dict:
    cases = {name: _figures(analyse(bag)) for name, bag in runs.items()}
    rows = [("case", "error RMS [mrad]", "peak [mrad]", "budget 1σ [mrad]", "budget 95 % [mrad]",
             "within 95 % budget", "within 1σ")]
    rows += [(name, f"{c['error_rms_mrad']:.4f}", f"{c['error_peak_mrad']:.4f}", f"{c['budget_mean_mrad']:.3f}",
              f"{c['budget_95_mean_mrad']:.3f}", f"{100 * c['within_budget_95_fraction']:.1f} %",
              f"{100 * c['within_budget_1sigma_fraction']:.1f} %") for name, c in cases.items()]
    widths = [max(len(r[i]) for r in rows) for i in range(len(rows[0]))]
    table = "\n".join("  ".join(c.rjust(w) if i else c.ljust(w) for i, (c, w) in enumerate(zip(r, widths)))
                      for r in rows)
    return {"cases": cases, "table": f"True pointing error after {ACQUIRE_S:g} s (geo-pointing):\n" + table,
            "plots": [], "runs": {k: str(v) for k, v in runs.items()}}
