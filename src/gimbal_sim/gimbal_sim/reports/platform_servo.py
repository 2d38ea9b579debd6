"""The ``platform_servo`` report: paper 3's servo figures (Fig. 6, §4.1) from the bag.

Series (decoded one message at a time, so long 1 kHz runs stay small in memory):

* ``/platform_servo/modulation``: the commanded modulation angle φz and rate φ̇z;
* ``/platform_servo/control_error``: the servo's eq. 1 control signals, i.e. the gyro
  pickoff angles resolved onto the gimbal axes — paper 3's "control error" (sensed);
* ``/truth/platform/joint_states``: the plant's loop angles (platform attitude relative to
  level, multi-turn azimuth) and torques;
* ``/truth/platform/gyro_bias``: the platform gyros' true bias.

Figures (arc-seconds unless named otherwise):

* control error: the sensed azimuth error Δθ_am, and independently the truth tracking
  error e_a = a(t) − a(t₀) − φz(t) + ∫ε_z dt. The gyro reference drifts at the gyro bias ε_z,
  which no servo can see; adding its integral back isolates what the loop itself lets
  through (the gyro's angle random walk remains). ``steady`` means t ≥ ``SETTLE_S`` and
  outside [t_k, t_k + ``TRANSIENT_WINDOW_S``) after every reversal t_k (φ̇z changes sign);
  ``reversal`` is the largest |error| inside those windows;
* level errors: Δθ_qm, Δθ_pm, Δθ_rm (sensed) and the truth tilts relative to their start;
* torque current: the azimuth motor's armature current, truth torque / k_t (Table 1), in mA;
* the DTG torquer currents (``/platform_servo/torquer_current``, a servo with ``gyro_source:
  dtg``): the azimuth torquer current i_z, its mean and relative standard deviation over the
  steady samples of each direction of rotation (paper 3: 60 mA at 1.2 °/s), in mA.

The comparison ``platform_servo_gyro_source`` puts the variants' figures side by side.

Acceptance: steady control error < 40″ (goal 20″), reversal transient < 240″
(goal 120″), both for the sensed and the truth error.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np

from gimbal_kinematics.maths.units import ARCSEC

from ..bag.reader import BagContents, BagError, stream
from ..bag.schemas import message_class
from ..world.plant.platform_loops import PAPER3_TABLE1
from ..figures import limit_lines, save_stacked, stacked, style

SETTLE_S = 2.0
TRANSIENT_WINDOW_S = 2.0
LIMITS_ARCSEC = {"steady": (40.0, 20.0), "reversal": (240.0, 120.0)}  # (paper, goal)

MODULATION = "/platform_servo/modulation"
CONTROL_ERROR = "/platform_servo/control_error"
TRUTH_JOINTS = "/truth/platform/joint_states"
GYRO_BIAS = "/truth/platform/gyro_bias"
TORQUER = "/platform_servo/torquer_current"


def stream_columns(bag_dir: Path, extract: dict[str, Callable]) -> tuple[dict[str, tuple[np.ndarray, np.ndarray]],
                                                                          BagContents]:
    """Per topic, (header stamps [s] (N,), rows (N, m)) with rows ``extract[topic](msg)``;
    messages are deserialized one at a time and dropped. Also returns the bag summary."""
    from rclpy.serialization import deserialize_message

    rows: dict[str, list] = {topic: [] for topic in extract}
    stamps: dict[str, list] = {topic: [] for topic in extract}
    classes: dict[str, type] = {}
    contents = None
    for item in stream(bag_dir, set(extract)):
        if isinstance(item, BagContents):
            contents = item
            break
        cls = classes.get(item.type_name) or classes.setdefault(item.type_name, message_class(item.type_name))
        msg = deserialize_message(item.data, cls)
        s = msg.header.stamp
        stamps[item.topic].append(s.sec + 1e-9 * s.nanosec)
        rows[item.topic].append(extract[item.topic](msg))
    out = {topic: (np.array(stamps[topic]), np.array(rows[topic], dtype=float).reshape(len(rows[topic]), -1)
                   if rows[topic] else np.zeros((0, 1))) for topic in extract}
    return out, contents


def bag_summary(bag_dir: Path, contents: BagContents) -> dict:
    """What every report carries about its bag (gimbal-run prints it)."""
    return {"bag": str(bag_dir), "closed_cleanly": contents.closed_cleanly, "read_error": contents.error,
            "message_count": contents.message_count,
            "duration_s": ((contents.end_ns or 0) - (contents.start_ns or 0)) * 1e-9,
            "topics": {name: {"type": r.type_name, "count": r.count} for name, r in sorted(contents.topics.items())}}


def _on(t_from: np.ndarray, y_from: np.ndarray, t_to: np.ndarray) -> np.ndarray:
    """Rows of ``y_from`` at the stamps ``t_to`` (exact stamp match required)."""
    idx = np.searchsorted(t_from, t_to)
    idx = np.clip(idx, 0, len(t_from) - 1)
    if not np.allclose(t_from[idx], t_to, atol=1e-7):
        raise BagError("servo and truth series do not share their step stamps")
    return y_from[idx]


def _stats(err: np.ndarray, mask: np.ndarray) -> dict:
    if not mask.any():
        return {"rms": None, "max": None}
    e = err[mask]
    return {"rms": float(np.sqrt(np.mean(e * e))), "max": float(np.max(np.abs(e)))}


def envelope(t: np.ndarray, y: np.ndarray, bins: int = 3000) -> tuple[np.ndarray, np.ndarray]:
    """Min/max envelope of a long series for plotting (keeps every peak), ~2·bins points."""
    if len(t) <= 2 * bins:
        return t, y
    edges = np.linspace(0, len(t), bins + 1).astype(int)
    tt, yy = [], []
    for a, b in zip(edges[:-1], edges[1:]):
        seg = y[a:b]
        i, j = a + int(np.argmin(seg)), a + int(np.argmax(seg))
        for k in sorted((i, j)):
            tt.append(t[k])
            yy.append(y[k])
    return np.array(tt), np.array(yy)


def _plot(path: Path, title: str, panels: list[tuple[str, dict[str, tuple[np.ndarray, np.ndarray]]]],
          hlines: list[float | None] | None = None) -> None:
    fig, axes = stacked(len(panels), 2.8 * len(panels) + 0.6)
    for n, (ax, (ylabel, curves)) in enumerate(zip(axes[:, 0], panels)):
        for label, (t, y) in curves.items():
            ax.plot(*envelope(t, y), label=label, linewidth=0.9)
        limit = hlines[n] if hlines else None
        if limit:
            limit_lines(ax, limit)
        style(ax, ylabel)
    save_stacked(fig, axes, path, title)


@dataclass
class _ServoRun:
    """The report's series on the modulation ticks ``t`` [s], and its time windows."""

    t: np.ndarray
    phi: np.ndarray          # commanded modulation angle φz [rad]
    phi_rate: np.ndarray
    sensed: np.ndarray       # (Δθ_am, Δθ_qm, Δθ_pm, Δθ_rm) [rad]
    truth: np.ndarray        # (a, q, p, r, azimuth torque)
    drift: np.ndarray        # integrated true gyro bias [rad]
    tracking: np.ndarray     # true azimuth tracking error, gyro drift removed [rad]
    level_truth: np.ndarray  # true roll and pitch from their start [rad]
    current_a: np.ndarray    # azimuth torque current [A]
    reversals: np.ndarray    # times of the modulation's direction reversals [s]
    in_window: np.ndarray    # within TRANSIENT_WINDOW_S after a reversal
    steady: np.ndarray       # settled and outside every reversal window
    start: np.ndarray        # before SETTLE_S
    settled: np.ndarray      # after SETTLE_S


def _servo_run(cols: dict) -> _ServoRun:
    t, mod = cols[MODULATION]
    phi, phi_rate = mod[:, 0], mod[:, 1]
    sensed = _on(*cols[CONTROL_ERROR], t)
    truth = _on(*cols[TRUTH_JOINTS], t)
    tb, bias_z = cols[GYRO_BIAS]
    drift = np.zeros_like(t)
    if len(tb):
        b = np.interp(t, tb, bias_z[:, 0])
        drift[1:] = np.cumsum(0.5 * (b[1:] + b[:-1]) * np.diff(t))
    sign = np.sign(phi_rate)
    reversals = t[np.where((sign[1:] * sign[:-1]) < 0)[0] + 1]
    rel = t - t[0]
    in_window = np.zeros(len(t), dtype=bool)
    for tr in reversals:
        in_window |= (t >= tr) & (t < tr + TRANSIENT_WINDOW_S)
    return _ServoRun(t, phi, phi_rate, sensed, truth, drift, truth[:, 0] - truth[0, 0] - phi + drift,
                     truth[:, 1:3] - truth[0, 1:3], truth[:, 4] / PAPER3_TABLE1["a"][1], reversals, in_window,
                     (rel >= SETTLE_S) & ~in_window, rel < SETTLE_S, rel >= SETTLE_S)


def _arcsec(x: dict) -> dict:
    return {k: (None if v is None else v / ARCSEC) for k, v in x.items()}


def _max_arcsec(x: np.ndarray, mask: np.ndarray) -> float | None:
    return float(np.max(np.abs(x[mask])) / ARCSEC) if mask.any() else None


def _servo_figures(r: _ServoRun) -> dict:
    """Control and level errors [arcsec], torque current [mA] and the acceptance verdicts."""
    sensed, tracking, steady, win = r.sensed, r.tracking, r.steady, r.in_window
    control = {
        "sensed": {"steady": _arcsec(_stats(sensed[:, 0], steady)), "reversal": _arcsec(_stats(sensed[:, 0], win)),
                   "start": _arcsec(_stats(sensed[:, 0], r.start))},
        "truth_drift_removed": {"steady": _arcsec(_stats(tracking, steady)),
                                "reversal": _arcsec(_stats(tracking, win)),
                                "start": _arcsec(_stats(tracking, r.start))},
        "truth_with_gyro_drift": {"steady": _arcsec(_stats(tracking - r.drift, steady)),
                                  "final": float((tracking - r.drift)[-1] / ARCSEC)},
        "sensed_minus_truth_rms": float(np.sqrt(np.mean((sensed[steady, 0] - tracking[steady]) ** 2)) / ARCSEC)
        if steady.any() else None,
    }
    signals = ((1, "inner_roll"), (2, "pitch"), (3, "outer_roll"))
    level = {
        "sensed_steady_max": {name: _max_arcsec(sensed[:, i], steady) for i, name in signals},
        "sensed_reversal_max": {name: _max_arcsec(sensed[:, i], win) for i, name in signals},
        "truth_tilt_steady_max": {name: _max_arcsec(r.level_truth[:, i], steady)
                                  for i, name in ((0, "roll"), (1, "pitch"))},
    }
    current_a = r.current_a
    current = {
        "steady_mean_abs_ma": float(1e3 * np.mean(np.abs(current_a[steady]))) if steady.any() else None,
        "steady_rms_ma": float(1e3 * np.sqrt(np.mean(current_a[steady] ** 2))) if steady.any() else None,
        "reversal_peak_ma": float(1e3 * np.max(np.abs(current_a[win]))) if win.any() else None,
        "peak_after_settle_ma": float(1e3 * np.max(np.abs(current_a[r.settled]))) if r.settled.any() else None,
    }
    acceptance = {}
    for kind, (paper, goal) in LIMITS_ARCSEC.items():
        worst = [control[src][kind]["max"] for src in ("sensed", "truth_drift_removed")]
        if all(w is not None for w in worst):
            acceptance[f"{kind}_below_{paper:g}_arcsec"] = bool(max(worst) < paper)
            acceptance[f"{kind}_below_goal_{goal:g}_arcsec"] = bool(max(worst) < goal)
    acceptance["torque_current_reported"] = current["steady_mean_abs_ma"] is not None
    return {"control_error_arcsec": control, "level_error_arcsec": level, "torque_current": current,
            "acceptance": acceptance}


def _servo_plots(out: Path, r: _ServoRun) -> list[str]:
    t, sensed, tracking = r.t, r.sensed, r.tracking
    plots = []
    _plot(out / "rotation_angle.png", "Platform rotation (modulation) angle", [
        ("[deg]", {"commanded φz": (t, np.degrees(r.phi)), "platform azimuth (truth, from start)":
                   (t, np.degrees(r.truth[:, 0] - r.truth[0, 0]))}),
    ])
    plots.append("rotation_angle.png")
    paper_limits = [LIMITS_ARCSEC["steady"][0], None]
    _plot(out / "control_error.png", "Azimuth control error (steady limit ±40″ dashed)", [
        ("[arcsec]", {"sensed Δθ_am (pickoff)": (t, sensed[:, 0] / ARCSEC),
                      "truth, gyro drift removed": (t, tracking / ARCSEC)}),
        ("[arcsec]", {"truth incl. gyro drift": (t, (tracking - r.drift) / ARCSEC)}),
    ], paper_limits)
    plots.append("control_error.png")
    if len(r.reversals):
        tr = r.reversals[0]
        zoom = (t >= tr - 0.2) & (t < tr + 0.6)
        _plot(out / "reversal_transient.png", f"Reversal at {tr - t[0]:.2f} s (limit ±240″ dashed)", [
            ("[arcsec]", {"sensed Δθ_am": (t[zoom], sensed[zoom, 0] / ARCSEC),
                          "truth, drift removed": (t[zoom], tracking[zoom] / ARCSEC)}),
            ("[mA]", {"azimuth torque current": (t[zoom], 1e3 * r.current_a[zoom])}),
        ], [LIMITS_ARCSEC["reversal"][0], None])
        plots.append("reversal_transient.png")
    _plot(out / "level_error.png", "Level loops: control signals and truth tilt", [
        ("sensed [arcsec]", {"Δθ_qm": (t, sensed[:, 1] / ARCSEC), "Δθ_pm": (t, sensed[:, 2] / ARCSEC),
                             "Δθ_rm": (t, sensed[:, 3] / ARCSEC)}),
        ("truth [arcsec]", {"roll q − q₀": (t, r.level_truth[:, 0] / ARCSEC),
                            "pitch p − p₀": (t, r.level_truth[:, 1] / ARCSEC)}),
    ])
    plots.append("level_error.png")
    _plot(out / "torque_current.png", "Azimuth motor torque current", [
        ("[mA]", {"i_a = τ_a / k_t": (t, 1e3 * r.current_a)}),
    ])
    plots.append("torque_current.png")
    return plots


def _torquer_figures(r: _ServoRun, cols: dict) -> dict | None:
    """The azimuth torquer current i_z over the steady ticks of each direction [mA] (None
    without a torquer topic in the bag)."""
    t_i, cur = cols[TORQUER]
    if not len(t_i):
        return None
    i_z = _on(t_i, cur[:, 2], r.t)
    return {"azimuth": torquer_legs(i_z, np.sign(r.phi_rate), r.steady),
            "level_max_abs_ma": float(1e3 * np.max(np.abs(_on(t_i, cur[:, :2], r.t)[r.steady])))
            if r.steady.any() else None}


def torquer_legs(i_z: np.ndarray, direction: np.ndarray, steady: np.ndarray) -> dict:
    """Per direction of rotation (``direction`` ±1 per sample), the mean [mA], relative
    standard deviation and count of the azimuth torquer current ``i_z`` [A] over the
    ``steady`` samples."""
    legs = {}
    for sign, name in ((1.0, "positive_rate"), (-1.0, "negative_rate")):
        mask = steady & (direction == sign)
        if mask.any():
            leg = 1e3 * i_z[mask]
            legs[name] = {"mean_ma": float(np.mean(leg)), "rsd": float(np.std(leg) / abs(np.mean(leg))),
                          "samples": int(mask.sum())}
    return legs


def servo_metrics(bag_dir: Path) -> tuple[dict, _ServoRun]:
    """The report's figures (module docstring) without its plots, and the series."""
    cols, contents = stream_columns(bag_dir, {
        MODULATION: lambda msg: (msg.position[0], msg.velocity[0]),
        CONTROL_ERROR: lambda msg: tuple(msg.position),
        TRUTH_JOINTS: lambda msg: tuple(msg.position) + (msg.effort[0],),
        GYRO_BIAS: lambda msg: (msg.vector.z,),
        TORQUER: lambda msg: tuple(msg.effort),
    })
    for topic in (MODULATION, CONTROL_ERROR, TRUTH_JOINTS):
        if len(cols[topic][0]) < 2:
            raise BagError(f"{bag_dir}: too few {topic} messages for the platform_servo report")
    r = _servo_run(cols)
    metrics = {
        **bag_summary(bag_dir, contents), "ticks": int(len(r.t)),
        "reversal_times_s": [float(v) for v in r.reversals - r.t[0]],
        "windows": {"settle_s": SETTLE_S, "transient_window_s": TRANSIENT_WINDOW_S},
        "rotation": {"max_phi_z_deg": float(np.degrees(r.phi.max())),
                     "rate_deg_s": float(np.degrees(np.abs(r.phi_rate).max()))},
        **_servo_figures(r),
    }
    torquer = _torquer_figures(r, cols)
    if torquer is not None:
        metrics["dtg_torquer_current"] = torquer
    return metrics, r


def platform_servo_report(bag_dir: Path, out: Path) -> dict:
    """Paper 3 servo figures (module docstring) into ``out``; returns the metrics."""
    metrics, r = servo_metrics(bag_dir)
    metrics["plots"] = _servo_plots(out, r)
    return metrics


def _fmt(v) -> str:
    return "-" if v is None else f"{v:.4g}"


def platform_servo_comparison(runs: dict[str, Path], out: Path) -> dict:
    """The variants (e.g. the gyro triad against the DTGs) side by side: steady and reversal
    control errors, level tilt, and the DTG azimuth torquer current where there is one."""
    cases = {name: servo_metrics(bag)[0] for name, bag in runs.items()}
    rows = [("figure", *cases)]
    for label, get in (
            ("steady azimuth error, truth, max [arcsec]",
             lambda c: c["control_error_arcsec"]["truth_drift_removed"]["steady"]["max"]),
            ("reversal azimuth error, truth, max [arcsec]",
             lambda c: c["control_error_arcsec"]["truth_drift_removed"]["reversal"]["max"]),
            ("steady level tilt, truth, max [arcsec]",
             lambda c: max(v for v in c["level_error_arcsec"]["truth_tilt_steady_max"].values() if v is not None)
             if any(v is not None for v in c["level_error_arcsec"]["truth_tilt_steady_max"].values()) else None),
            ("azimuth torquer current, + rate [mA]",
             lambda c: c.get("dtg_torquer_current", {}).get("azimuth", {}).get("positive_rate", {}).get("mean_ma")),
            ("azimuth torquer current, - rate [mA]",
             lambda c: c.get("dtg_torquer_current", {}).get("azimuth", {}).get("negative_rate", {}).get("mean_ma"))):
        rows.append((label, *(_fmt(get(c)) for c in cases.values())))
    widths = [max(len(str(row[i])) for row in rows) for i in range(len(rows[0]))]
    table = "\n".join("  ".join(str(c).rjust(w) if i else str(c).ljust(w) for i, (c, w) in enumerate(zip(row, widths)))
                      for row in rows)
    return {"cases": cases, "table": "Platform servo by gyro source:\n" + table, "plots": [],
            "runs": {k: str(v) for k, v in runs.items()}}
