"""The ``alignment`` report and comparisons: paper 3's rotation-modulated fine alignment
(§2.2, Table 2) from the ``platform_alignment`` node's outputs and the plant truth.

Truth, from the bag (and the run's scenario.yaml for the static base's attitude and the
heading the filter assumes):

* misalignment: the platform attitude C_ns = C_nb C_bs(θ_a, θ_q, θ_p, θ_r) (the true gimbal
  angles of ``/truth/platform/joint_states`` on the static base) measured against the frame
  the filter believes in, the level frame turned by ψ = θ_a + ``base_heading_deg`` (the
  resolver's ±1.2″ quantisation of θ_a is below the figures); the initial misalignment is
  taken at the alignment start t₀ = stamp − age of ``~/status``;
* level accelerometer biases: ``/truth/platform/accel_bias``; level platform drifts: the
  negative of ``/truth/platform/gyro_bias`` (the gyros' rate bias b makes the servo, which
  holds the measured rate at the command, turn the platform at −b);
* north drift ε_N: 0 — the simulated platform has no drift fixed in the level frame (its gyro
  biases are fixed in the platform and turn with it).

Errors are estimate − truth; tilts in arc-seconds, azimuth in arc-minutes, drifts in °/h,
biases in µg. Eq. 9 without rotation: the level accelerometers then measure only the
apparent tilts δφE0 + ∇N/g and δφN0 − ∇E/g; the report gives the error of that combination
next to the errors of its parts, whose split the data cannot decide.
"""
from __future__ import annotations

import math
from pathlib import Path
from typing import Sequence

import numpy as np
import yaml

from gimbal_kinematics.maths.earth import normal_gravity
from gimbal_kinematics.maths.four_gimbal import dcm_bs, platform_misalignment_enu
from gimbal_kinematics.maths.rotations import euler321_to_dcm
from gimbal_kinematics.maths.units import ARCMIN, ARCSEC, DEG_H, UG

from ..bag.reader import BagError
from ..figures import limit_lines, save_stacked, stacked, style
from .platform_servo import bag_summary, stream_columns

#: paper 3 Table 2 accuracy: horizontal misalignment, azimuth, north drift
LIMITS = {"tilt_arcsec": 3.0, "azimuth_arcmin": 1.5, "north_drift_deg_h": 0.006}

NODE = "/platform_alignment"
VECTORS = ("initial_misalignment", "initial_misalignment_sigma", "misalignment", "misalignment_sigma",
           "north_drift", "north_drift_sigma", "gyro_drift", "gyro_drift_sigma", "accel_bias", "accel_bias_sigma",
           "status")
TRUTH_JOINTS = "/truth/platform/joint_states"


def _ned_to_enu(v: np.ndarray, sigma: bool = False) -> np.ndarray:
    """(N, 3) NED components → ENU; a σ vector keeps its (positive) values."""
    return np.column_stack((v[:, 1], v[:, 0], v[:, 2] if sigma else -v[:, 2]))


def _run_setup(bag_dir: Path) -> tuple[np.ndarray, float, float, str]:
    """(C_nb of the static base, heading the filter assumes [rad], latitude [rad], the
    servo's rotation mode) from the run's scenario.yaml."""
    path = bag_dir / "scenario.yaml"
    if not path.is_file():
        raise BagError(f"{bag_dir}: no scenario.yaml (the alignment report needs the base attitude)")
    nodes = yaml.safe_load(path.read_text()).get("nodes", {})
    by_exe = {n.get("executable"): n.get("params", {}) for n in nodes.values()}
    vehicle = by_exe.get("vehicle_dynamics", {})
    if vehicle.get("profile") != "static":
        raise BagError(f"{bag_dir}: the alignment report needs a static base, got {vehicle.get('profile')!r}")
    pp = yaml.safe_load(vehicle.get("profile_params", "{}")) or {}
    C_nb = euler321_to_dcm(*(math.radians(float(pp.get(k, 0.0))) for k in ("roll_deg", "pitch_deg", "yaw_deg")))
    heading = math.radians(float(by_exe.get("platform_alignment", {}).get("base_heading_deg", 0.0)))
    rotation = str(by_exe.get("platform_servo", {}).get("rotation", "bidirectional"))
    return C_nb, heading, math.radians(float(pp.get("lat_deg", 0.0))), rotation


def _truth_misalignment(joints: np.ndarray, C_nb: np.ndarray, heading: float) -> np.ndarray:
    """Misalignment (δφE, δφN, δφU) [rad] of the platform with gimbal angles ``joints``
    (a, q, p, r) against the frame the filter believes in (module docstring)."""
    return platform_misalignment_enu(C_nb @ dcm_bs(joints), joints[0] + heading)


def alignment_series(bag_dir: Path) -> dict:
    """Estimates, σ and truth of one run at the node's estimate stamps (SI, ENU for the
    misalignment); raises :class:`BagError` when the bag lacks them."""
    bag_dir = Path(bag_dir)
    vec = lambda msg: (msg.vector.x, msg.vector.y, msg.vector.z)  # noqa: E731
    extract = {f"{NODE}/{name}": vec for name in VECTORS}
    extract[TRUTH_JOINTS] = lambda msg: tuple(msg.position)
    extract["/truth/platform/gyro_bias"] = vec
    extract["/truth/platform/accel_bias"] = vec
    cols, contents = stream_columns(bag_dir, extract)
    t, status = cols[f"{NODE}/status"]
    if len(t) < 1:
        raise BagError(f"{bag_dir}: no {NODE}/status message: the alignment never updated")
    est = {name: cols[f"{NODE}/{name}"][1] for name in VECTORS}
    for name, (tn, _) in ((n, cols[f"{NODE}/{n}"]) for n in VECTORS):
        if not np.array_equal(tn, t):
            raise BagError(f"{bag_dir}: {NODE}/{name} is not stamped like {NODE}/status")
    tj, joints = cols[TRUTH_JOINTS]
    if len(tj) < 1 or len(cols["/truth/platform/accel_bias"][0]) < 1:
        raise BagError(f"{bag_dir}: no platform truth recorded")
    C_nb, heading, lat, rotation = _run_setup(bag_dir)
    t0 = float(t[-1] - status[-1, 0])

    def joints_at(tt: float) -> np.ndarray:
        i = int(np.argmin(np.abs(tj - tt)))
        if abs(tj[i] - tt) > 1e-6:
            raise BagError(f"{bag_dir}: no truth at t = {tt:.6f} s")
        return joints[i]

    phi0 = _truth_misalignment(joints_at(t0), C_nb, heading)
    phi_now = np.array([_truth_misalignment(joints_at(tt), C_nb, heading) for tt in t])
    accel_bias = cols["/truth/platform/accel_bias"][1][0]
    gyro_bias = cols["/truth/platform/gyro_bias"][1][0]
    return {
        "bag": bag_dir, "contents": contents, "t": t, "t0": t0, "age_s": status[:, 0], "updates": status[:, 1],
        "converged": status[:, 2] > 0.5, "lat": lat, "rotation": rotation,
        "initial": _ned_to_enu(est["initial_misalignment"]),
        "initial_sigma": _ned_to_enu(est["initial_misalignment_sigma"], sigma=True),
        "current": _ned_to_enu(est["misalignment"]),
        "current_sigma": _ned_to_enu(est["misalignment_sigma"], sigma=True),
        "north_drift": est["north_drift"][:, 0], "north_drift_sigma": est["north_drift_sigma"][:, 0],
        "gyro_drift": est["gyro_drift"][:, :2], "gyro_drift_sigma": est["gyro_drift_sigma"][:, :2],
        "accel_bias": est["accel_bias"][:, :2], "accel_bias_sigma": est["accel_bias_sigma"][:, :2],
        "truth_initial": phi0, "truth_current": phi_now, "truth_north_drift": 0.0,
        "truth_gyro_drift": -gyro_bias[:2], "truth_accel_bias": accel_bias[:2],
        "start_azimuth": float(joints_at(t0)[0] + heading),
        "heading": heading, "true_gyro_bias": gyro_bias, "true_accel_bias": accel_bias,
        "final_joints": joints_at(float(t[-1])),
    }


def final_errors(s: dict) -> dict:
    """The run's final estimate errors and σ, in the report's units (module docstring)."""
    g = normal_gravity(s["lat"])
    e0 = s["initial"][-1] - s["truth_initial"]
    sig0 = s["initial_sigma"][-1]
    c, sn = math.cos(s["start_azimuth"]), math.sin(s["start_azimuth"])
    db = s["accel_bias"][-1] - s["truth_accel_bias"]
    # eq. 9 at the start azimuth: Z_E = δφE0 + ∇N/g, Z_N = δφN0 − ∇E/g
    apparent = np.array([e0[0] + (c * db[0] - sn * db[1]) / g, e0[1] - (sn * db[0] + c * db[1]) / g])
    return {
        "tilt_error_arcsec": {"east": float(e0[0] / ARCSEC), "north": float(e0[1] / ARCSEC)},
        "tilt_sigma_arcsec": {"east": float(sig0[0] / ARCSEC), "north": float(sig0[1] / ARCSEC)},
        "azimuth_error_arcmin": float(e0[2] / ARCMIN), "azimuth_sigma_arcmin": float(sig0[2] / ARCMIN),
        "north_drift_error_deg_h": float((s["north_drift"][-1] - s["truth_north_drift"]) / DEG_H),
        "north_drift_sigma_deg_h": float(s["north_drift_sigma"][-1] / DEG_H),
        "gyro_drift_error_deg_h": [float(v / DEG_H) for v in s["gyro_drift"][-1] - s["truth_gyro_drift"]],
        "accel_bias_error_ug": [float(v / UG) for v in db],
        "accel_bias_sigma_ug": [float(v / UG) for v in s["accel_bias_sigma"][-1]],
        "apparent_tilt_error_arcsec": {"east": float(apparent[0] / ARCSEC), "north": float(apparent[1] / ARCSEC)},
        "current_misalignment_error_arcsec": [float(v / ARCSEC) for v in s["current"][-1] - s["truth_current"][-1]],
        "truth_initial_misalignment_arcsec": [float(v / ARCSEC) for v in s["truth_initial"]],
        "converged": bool(s["converged"][-1]),
        "converged_after_s": float(s["age_s"][np.argmax(s["converged"])]) if s["converged"].any() else None,
        "age_s": float(s["age_s"][-1]), "updates": int(s["updates"][-1]),
    }


def _band_plot(ax, t, err, sigma, label: str) -> None:
    line, = ax.plot(t, err, linewidth=1.0, label=f"{label} error")
    ax.fill_between(t, -sigma, sigma, color=line.get_color(), alpha=0.15, label=f"{label} ±σ")


def _figure(path: Path, title: str, runs: dict[str, dict]) -> None:
    """Estimate errors with their ±σ over time: tilts, azimuth, north drift; one colour per run."""
    fig, axes = stacked(4, 11.0)
    panels = ((0, ARCSEC, "δφE0 [arcsec]", LIMITS["tilt_arcsec"]), (1, ARCSEC, "δφN0 [arcsec]", LIMITS["tilt_arcsec"]),
              (2, ARCMIN, "δφU0 [arcmin]", LIMITS["azimuth_arcmin"]))
    for name, s in runs.items():
        age = s["age_s"]
        for ax, (i, unit, _, _) in zip(axes[:, 0], panels):
            _band_plot(ax, age, (s["initial"][:, i] - s["truth_initial"][i]) / unit, s["initial_sigma"][:, i] / unit,
                       name)
        _band_plot(axes[3, 0], age, (s["north_drift"] - s["truth_north_drift"]) / DEG_H, s["north_drift_sigma"] / DEG_H,
                   name)
    for ax, (_, _, label, limit) in zip(axes[:, 0], panels + ((3, DEG_H, "ε_N [deg/h]", LIMITS["north_drift_deg_h"]),)):
        limit_lines(ax, limit)
        ax.set_ylim(-8 * limit, 8 * limit)
        style(ax, label, legend_loc="upper right", fontsize=7, ncol=2)
    save_stacked(fig, axes, path, title + " (dashed: Table 2 accuracy)", xlabel="alignment time [s]")


def alignment_report(bag_dir: Path, out: Path) -> dict:
    """One alignment run: final errors and σ against the truth, convergence, plots."""
    s = alignment_series(bag_dir)
    metrics = bag_summary(Path(bag_dir), s["contents"])
    f = final_errors(s)
    metrics["rotation"] = s["rotation"]
    metrics["alignment"] = f
    metrics["within_table2_accuracy"] = {
        "tilt": max(abs(v) for v in f["tilt_error_arcsec"].values()) < LIMITS["tilt_arcsec"],
        "azimuth": abs(f["azimuth_error_arcmin"]) < LIMITS["azimuth_arcmin"],
        "north_drift": abs(f["north_drift_error_deg_h"]) < LIMITS["north_drift_deg_h"],
    }
    _figure(out / "alignment_errors.png", "Alignment estimate errors", {"estimate": s})
    metrics["plots"] = ["alignment_errors.png"]
    return metrics


def rotation_comparison(runs: dict[str, Path], out: Path) -> dict:
    """Rotation on against off (paper 3 eqs. 9–10) and the static gyrocompass: final errors and
    σ of each variant side by side, and how the level bias and the tilt separate only when the
    platform turns."""
    series = {name: alignment_series(Path(bag)) for name, bag in runs.items()}
    table = {name: final_errors(s) for name, s in series.items()}
    separated = {}
    for name, f in table.items():
        tilt_sigma = max(f["tilt_sigma_arcsec"].values())
        separated[name] = {
            "rotation": series[name]["rotation"],
            "tilt_sigma_arcsec": tilt_sigma,
            "accel_bias_sigma_ug": max(f["accel_bias_sigma_ug"]),
            # the data pin down each tilt on its own (σ well under the bias-equivalent 100 µg ≈ 20″),
            # the biases estimated (a gyrocompass takes them as zero and their σ as 0)
            "tilt_and_bias_separated": bool(tilt_sigma < LIMITS["tilt_arcsec"] and max(f["accel_bias_sigma_ug"]) > 0.0),
        }
    _figure(out / "alignment_rotation_on_off.png", " vs ".join(series), series)
    return {"variants": list(runs), "final": table, "separation": separated,
            "plots": ["alignment_rotation_on_off.png"]}


def column_stats(cols: dict[str, Sequence[float]]) -> dict[str, dict[str, float]]:
    """Table 2's statistics of each column of run values: mean, std (ddof = 1, as the
    paper), RMS and max |·|."""
    out = {}
    for name, vals in cols.items():
        a = np.asarray(vals, dtype=float)
        out[name] = {"mean": float(a.mean()), "std": float(a.std(ddof=1)) if a.size > 1 else 0.0,
                     "rms": float(np.sqrt(np.mean(a * a))), "max_abs": float(np.max(np.abs(a)))}
    return out


def alignment_campaign(runs: dict[str, Path], out: Path) -> dict:
    """Table 2 over seeded runs: per-run final errors, their mean and std (ddof = 1, as the
    paper), RMS and max |·|, and the Table 2 acceptance (RMS over the runs under the limits)."""
    series = {name: alignment_series(Path(bag)) for name, bag in runs.items()}
    per_run = {name: final_errors(s) for name, s in series.items()}
    cols = {
        "east_tilt_error_arcsec": [f["tilt_error_arcsec"]["east"] for f in per_run.values()],
        "north_tilt_error_arcsec": [f["tilt_error_arcsec"]["north"] for f in per_run.values()],
        "azimuth_error_arcmin": [f["azimuth_error_arcmin"] for f in per_run.values()],
        "north_drift_error_deg_h": [f["north_drift_error_deg_h"] for f in per_run.values()],
        "gyro_drift_x_error_deg_h": [f["gyro_drift_error_deg_h"][0] for f in per_run.values()],
        "gyro_drift_y_error_deg_h": [f["gyro_drift_error_deg_h"][1] for f in per_run.values()],
    }
    stats = column_stats(cols)
    acceptance = {
        "horizontal_below_3_arcsec": max(stats["east_tilt_error_arcsec"]["rms"],
                                         stats["north_tilt_error_arcsec"]["rms"]) < LIMITS["tilt_arcsec"],
        "azimuth_below_1.5_arcmin": stats["azimuth_error_arcmin"]["rms"] < LIMITS["azimuth_arcmin"],
        "north_drift_below_0.006_deg_h": stats["north_drift_error_deg_h"]["rms"] < LIMITS["north_drift_deg_h"],
    }
    _figure(out / "alignment_campaign.png", f"Alignment over {len(runs)} runs", series)
    return {"runs": per_run, "statistics": stats, "acceptance": acceptance, "plots": ["alignment_campaign.png"]}
