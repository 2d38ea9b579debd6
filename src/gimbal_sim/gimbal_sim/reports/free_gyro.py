"""The ``free_gyro`` report: paper 4's position fix and heading against the truth.

From the bag alone: the fixes (``/free_gyro_positioning/fix``, NavSatFix), the headings and
the geometry the node published, against the ship's true position
(``/truth/free_gyro/position``) and attitude (``/truth/host/imu``), and, when the node
published them (``predict_error``), against the error model's predictions. Figures: north/east fix
error vs time with the ±1σ the NavSatFix covariance claims, heading errors (free-gyro and
earth-rate) with their σ, FDOP vs time, and the error scatter against the FDOP²σ² ellipse.
Everything is timed by the messages' header stamps (a fix is stamped at its window's mean
time, which is earlier than the step it was published at).
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from gimbal_kinematics.maths.earth import earth_rate_n, meridian_radius, prime_vertical_radius
from gimbal_kinematics.maths.free_gyro import heading_error
from gimbal_kinematics.maths.rotations import quat_to_dcm, quat_to_euler321
from gimbal_kinematics.maths.units import ARCSEC

from ..bag.reader import BagError
from .common import load_series, plot
from ..figures import pyplot, save, save_stacked, stacked, style
from .generic import generic_report

NODE = "/free_gyro_positioning"
TOPICS = {f"{NODE}/fix", f"{NODE}/heading", f"{NODE}/heading_earth_rate", f"{NODE}/geometry",
          f"{NODE}/predicted_position", f"{NODE}/predicted_heading",
          "/truth/free_gyro/position", "/truth/free_gyro/triad_bias", "/truth/host/imu"}


def _stamp(msg) -> float:
    return msg.header.stamp.sec + 1e-9 * msg.header.stamp.nanosec


def _yaw(q) -> float:
    """3-2-1 heading [rad] of an (x, y, z, w) orientation of b in NED."""
    return math.atan2(2.0 * (q.x * q.y + q.z * q.w), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))


def fix_errors(fixes: list, truth: list) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """North/east errors [m] of NavSatFix messages against the true-position NavSatFix
    messages (the one with the nearest stamp), and the fixes' north/east covariances [m²].

    Returns (t (k,), errors (k, 2), covariances (k, 2, 2)); ENU covariance → (N, E) block.
    """
    tt = np.array([_stamp(m) for m in truth])
    t, err, cov = [], [], []
    for fix in fixes:
        tf = _stamp(fix)
        true = truth[int(np.argmin(np.abs(tt - tf)))]
        lat = math.radians(true.latitude)
        rm, rn = meridian_radius(lat) + true.altitude, prime_vertical_radius(lat) + true.altitude
        d_lon = math.remainder(math.radians(fix.longitude - true.longitude), math.tau)
        err.append((math.radians(fix.latitude - true.latitude) * rm, d_lon * rn * math.cos(lat)))
        c = fix.position_covariance
        cov.append(((c[4], c[1]), (c[3], c[0])))
        t.append(tf)
    return np.array(t), np.array(err).reshape(-1, 2), np.array(cov, dtype=float).reshape(-1, 2, 2)


def heading_errors(estimates: list, attitude: list) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Errors [rad] of heading messages (x = ψ, y = σ, z = averaging span [s]) against the
    circular mean of the true heading over each span. Returns (t, errors, σ), each (k,)."""
    ta = np.array([_stamp(m) for m in attitude])
    yaw = np.array([_yaw(m.orientation) for m in attitude])
    t, err, sig = [], [], []
    for msg in estimates:
        tc, psi, sigma, span = _stamp(msg), msg.vector.x, msg.vector.y, msg.vector.z
        inside = np.abs(ta - tc) <= 0.5 * span + 1e-6
        if not inside.any() or not math.isfinite(psi):
            continue
        mean = math.atan2(float(np.sin(yaw[inside]).sum()), float(np.cos(yaw[inside]).sum()))
        t.append(tc)
        err.append(math.remainder(psi - mean, math.tau))
        sig.append(sigma)
    return np.array(t), np.array(err), np.array(sig)


def eq29_heading_errors(estimates: list, attitude: list, triad_bias: list, lat: float) -> np.ndarray:
    """First-order earth-rate heading error [rad] that paper 4's eq. 29 predicts for each
    heading message (x = ψ, z = window length [s]) from the true triad bias: the window mean
    of δψ = (ω_ly δω_lx − ω_lx δω_ly)/(ω_lx² + ω_ly²) over the true attitudes in it, with ω
    the earth rate at latitude ``lat`` [rad] in the body and δω the bias levelled alike."""
    ta = np.array([_stamp(m) for m in attitude])
    tb = np.array([_stamp(m) for m in triad_bias])
    w_n = earth_rate_n(lat)
    out = []
    for msg in estimates:
        tc, span = _stamp(msg), msg.vector.z
        bias = triad_bias[int(np.argmin(np.abs(tb - tc)))].vector
        terms = []
        for i in np.flatnonzero(np.abs(ta - tc) <= 0.5 * span + 1e-6):
            q = attitude[i].orientation
            quat = (q.x, q.y, q.z, q.w)
            roll, pitch, _ = quat_to_euler321(quat)
            terms.append(heading_error(quat_to_dcm(quat).T @ w_n, (bias.x, bias.y, bias.z), roll, pitch))
        out.append(float(np.mean(terms)) if terms else math.nan)
    return np.array(out)


def covariance_consistency(errors: np.ndarray, covs: np.ndarray) -> dict:
    """Empirical north/east error covariance (zero-mean: the fix is unbiased) against the mean
    claimed covariance, and the NEES (2 on average when consistent)."""
    emp = errors.T @ errors / len(errors)
    pred = covs.mean(axis=0)
    nees = np.array([e @ np.linalg.solve(c, e) for e, c in zip(errors, covs)])
    return {
        "n_fixes": int(len(errors)),
        "empirical_cov_ne_m2": emp.tolist(),
        "claimed_cov_ne_m2": pred.tolist(),
        "trace_ratio": float(np.trace(emp) / np.trace(pred)),
        "variance_ratio_north": float(emp[0, 0] / pred[0, 0]),
        "variance_ratio_east": float(emp[1, 1] / pred[1, 1]),
        "mean_error_ne_m": errors.mean(axis=0).tolist(),
        "mean_nees": float(nees.mean()),
    }


def prediction_consistency(t: np.ndarray, errors: np.ndarray, position: list, heading: list) -> dict:
    """The fixes' north/east errors (stamps ``t`` (k,), ``errors`` (k, 2) [m]) against the
    error model's predictions the node published with them (``predicted_position``: x, y =
    σ north, east [m], z = correlation; ``predicted_heading``: z = eq. 38's FDOP·σ_θ [m]):
    RMS error over predicted drms, and the fraction of fixes inside the FDOP·σ_θ circle."""
    by_stamp = {_stamp(p): p.vector for p in position}
    radius = {_stamp(h): h.vector.z for h in heading}
    rows = [(e, by_stamp[tk], radius[tk]) for tk, e in zip(t, errors) if tk in by_stamp and tk in radius]
    if not rows:
        return {"n": 0}
    drms = np.sqrt(np.mean([v.x**2 + v.y**2 for _, v, _ in rows]))
    rms = np.sqrt(np.mean([e @ e for e, _, _ in rows]))
    return {"n": len(rows), "predicted_drms_m": float(drms), "rms_over_predicted": float(rms / drms),
            "inside_fdop_circle": float(np.mean([math.hypot(*e) <= r for e, _, r in rows]))}


def _band_plot(path: Path, title: str, t: np.ndarray, panels: list[tuple[str, np.ndarray, np.ndarray]],
               ylabel: str, reference: tuple[str, np.ndarray] | None = None) -> None:
    """One panel per (label, error, σ): the error against the ±1σ band the node claimed;
    ``reference`` (label, values) adds a predicted error to the first panel."""
    fig, axes = stacked(len(panels), 2.2 + 2.3 * len(panels))
    for ax, (label, err, sig) in zip(axes[:, 0], panels):
        ax.fill_between(t, -sig, sig, color="C1", alpha=0.25, label="±1σ claimed")
        ax.plot(t, err, ".-", linewidth=0.8, markersize=4, label=f"{label} error")
        if reference is not None and ax is axes[0, 0]:
            ax.plot(t, reference[1], "x--", color="C3", linewidth=0.8, label=reference[0])
        style(ax, ylabel, legend_loc="upper right")
    save_stacked(fig, axes, path, title)


def _scatter(path: Path, errors: np.ndarray, cov: np.ndarray) -> None:
    fig, ax = pyplot().subplots(figsize=(6, 6), constrained_layout=True)
    ax.plot(errors[:, 1], errors[:, 0], ".", markersize=4, label="fix errors")
    w, v = np.linalg.eigh(cov)
    a = np.linspace(0.0, 2.0 * math.pi, 200)
    for k, line in ((1.0, "-"), (2.0, "--")):
        pts = v @ (k * np.sqrt(w)[:, None] * np.array([np.cos(a), np.sin(a)]))
        ax.plot(pts[1], pts[0], line, color="C1", label=f"{k:g}σ ellipse of FDOP²σ² (NavSatFix covariance)")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("east error [m]")
    ax.set_title("Fix errors vs the claimed covariance")
    style(ax, "north error [m]")
    save(fig, path)


def free_gyro_report(bag_dir: Path, out: Path) -> dict:
    """Fix error (north/east, m) vs time, heading errors, FDOP, and the NavSatFix covariance
    against the actual error."""
    metrics = generic_report(bag_dir, out)
    series, _ = load_series(bag_dir, TOPICS)
    msgs = {topic: [m for _, m in series.get(topic, [])] for topic in TOPICS}
    truth = msgs["/truth/free_gyro/position"]
    if not truth:
        raise BagError(f"{bag_dir}: no /truth/free_gyro/position to measure the fixes against")
    geometry = msgs[f"{NODE}/geometry"]
    status = np.array([g.vector.z for g in geometry])
    result: dict = {"windows": len(geometry), "fixes": len(msgs[f"{NODE}/fix"]),
                    "degenerate_windows": int(np.sum(status == 1.0))}
    if geometry:
        tg = np.array([_stamp(g) for g in geometry])
        fdop = np.array([g.vector.x for g in geometry])
        result["fdop_mean"] = float(np.nanmean(fdop)) if np.isfinite(fdop).any() else None
        result["crossing_angle_deg_mean"] = float(np.degrees(np.mean([g.vector.y for g in geometry])))
        plot(out / "fdop.png", "Fix geometry: FDOP (NaN: not computable)", tg, {"FDOP": fdop}, "[-]")
        metrics["plots"].append("fdop.png")
    if msgs[f"{NODE}/fix"]:
        t, err, cov = fix_errors(msgs[f"{NODE}/fix"], truth)
        result["position"] = covariance_consistency(err, cov)
        result["position"]["rms_error_m"] = float(np.sqrt(np.mean(np.sum(err**2, axis=1))))
        result["position"]["claimed_drms_m"] = float(np.sqrt(np.mean(cov[:, 0, 0] + cov[:, 1, 1])))
        _band_plot(out / "fix_error.png", "Free-gyro fix error and the NavSatFix covariance's 1σ", t,
                   [("north", err[:, 0], np.sqrt(cov[:, 0, 0])), ("east", err[:, 1], np.sqrt(cov[:, 1, 1]))], "[m]")
        if msgs[f"{NODE}/predicted_position"]:
            result["predicted"] = prediction_consistency(t, err, msgs[f"{NODE}/predicted_position"],
                                                         msgs[f"{NODE}/predicted_heading"])
        _scatter(out / "fix_error_scatter.png", err, cov.mean(axis=0))
        metrics["plots"] += ["fix_error.png", "fix_error_scatter.png"]
    attitude = msgs["/truth/host/imu"]
    for key, topic, title in (("heading", f"{NODE}/heading", "Free-gyro heading ψ = α − ζ (Fig. 4)"),
                              ("heading_earth_rate", f"{NODE}/heading_earth_rate",
                               "Earth-rate heading (Fig. 3, eq. 3–4)")):
        if not msgs[topic] or not attitude:
            continue
        t, err, sig = heading_errors(msgs[topic], attitude)
        if not len(t):
            continue
        result[key] = {"n": int(len(t)), "rms_error_arcsec": float(np.sqrt(np.mean(err**2)) / ARCSEC),
                       "mean_error_arcsec": float(np.mean(err) / ARCSEC),
                       "mean_sigma_arcsec": float(np.mean(sig) / ARCSEC),
                       "mean_normalised_error_squared": float(np.mean((err / sig) ** 2))}
        reference = None
        if key == "heading_earth_rate" and msgs["/truth/free_gyro/triad_bias"]:
            # the estimates that heading_errors kept (finite, with truth in their window)
            kept = [msg for msg in msgs[topic] if any(abs(_stamp(msg) - tk) < 1e-9 for tk in t)]
            pred = eq29_heading_errors(kept, attitude, msgs["/truth/free_gyro/triad_bias"],
                                       math.radians(truth[0].latitude))
            result[key]["errors_arcsec"] = (err / ARCSEC).tolist()
            result[key]["eq29_predicted_arcsec"] = (pred / ARCSEC).tolist()
            result[key]["eq29_residual_rms_arcsec"] = float(np.sqrt(np.mean((err - pred) ** 2)) / ARCSEC)
            reference = ("eq. 29 from the true triad bias", pred / ARCSEC)
        _band_plot(out / f"{key}_error.png", f"{title}: error vs the true window-mean heading", t,
                   [("heading", err / ARCSEC, sig / ARCSEC)], "[arcsec]", reference)
        metrics["plots"].append(f"{key}_error.png")
    metrics["free_gyro"] = result
    return metrics
