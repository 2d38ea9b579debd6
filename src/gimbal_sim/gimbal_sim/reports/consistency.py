"""The ``consistency`` report: is the gyro-bias EKF consistent on a bag without truth?

NEES needs the truth; on a user's own recording only the filter's own statistics are
there. This report replays the bag's sensor topics (``/gimbal/imu``,
``/gimbal/joint_states``, ``/ins/imu``: a recording from hardware, another tool's bag or
one of ours) into the EKF core, exactly as the ``gyro_bias_ekf`` node feeds it, and shows:

* the bias estimates with their ±3σ band [deg/h] (``bias_3sigma.png``);
* the innovations, the rotation vector between the measured and the predicted C(n,m)
  [arcsec] (``innovations.png``);
* the normalised innovation squared (NIS, chi-square with 3 degrees of freedom when the
  filter is consistent), as the mean of consecutive windows of ``WINDOW`` updates against
  its two-sided 95 % bounds, with each window's verdict (``nis.png``; the same statistic
  and words, :class:`gimbal_estimators.nis.NisWindow`, as the node's ``/diagnostics``);
* the core's counters, and the last values of every ``/diagnostics`` status the bag
  recorded (a recording of the node itself carries them).

Parameters come from the run's ``params/gyro_bias_ekf.yaml`` when the bag is one of our
runs, else the node's defaults (``config/gyro_bias_ekf.yaml``). Times on the plots are
seconds from the first estimate (the stamps may be epoch times).
"""
from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import yaml

from gimbal_estimators.gyro_bias_ekf import GyroBiasEkf
from gimbal_estimators.gyro_bias_ekf_params import PARAMS, GyroBiasEkfParams
from gimbal_estimators.gyro_bias_ekf_stamp import EkfInput
from gimbal_estimators.nis import NisWindow
from gimbal_kinematics.maths.units import ARCSEC_PER_RAD, DEG_H_PER_RAD_S
from gimbal_kinematics.timing.sync import RateSync

from ..bag.reader import BagError, read_messages
from ..bag.ekf_replay import EKF_INPUTS, ekf_outputs
from ..figures import save_stacked, stacked, style

#: Updates per NIS window (the node's default diagnostics window).
WINDOW = 100


def _ekf_values(bag_dir: Path) -> tuple[dict, str]:
    """The EKF parameter values to replay with, and where they came from."""
    values = {p.name: p.default for p in PARAMS}
    source = "node defaults"
    run_params = bag_dir / "params" / "gyro_bias_ekf.yaml"
    if run_params.is_file():
        block = yaml.safe_load(run_params.read_text()) or {}
        for node in block.values():
            values.update((node or {}).get("ros__parameters", {}))
        source = str(run_params)
    return values, source


def _diagnostics(bag_dir: Path) -> dict[str, dict[str, str]]:
    """Last key/values of each recorded ``/diagnostics`` status, by status name."""
    from rclpy.serialization import deserialize_message
    from diagnostic_msgs.msg import DiagnosticArray

    raw, _ = read_messages(bag_dir, {"/diagnostics"})
    last: dict[str, dict[str, str]] = {}
    for msg in raw:
        for status in deserialize_message(msg.data, DiagnosticArray).status:
            level = status.level[0] if isinstance(status.level, (bytes, bytearray)) else int(status.level)
            last[status.name] = {"level": str(level), "message": status.message,
                                 **{kv.key: kv.value for kv in status.values}}
    return last


def consistency_report(bag_dir: Path, out: Path) -> dict:
    """Estimates ±3σ, innovations, NIS against its bounds and the counters (module docstring)."""
    messages, contents = read_messages(bag_dir, set(EKF_INPUTS))
    missing = sorted(set(EKF_INPUTS) - {x.topic for x in messages})
    if missing:
        raise BagError(f"{bag_dir}: the consistency report needs {list(EKF_INPUTS)}; the bag lacks {missing} "
                       f"(it has {sorted(contents.topics)})")
    values, source = _ekf_values(bag_dir)
    ekf = EkfInput(GyroBiasEkf(GyroBiasEkfParams.from_values(values)), RateSync)
    stamps, bias, sigma, innov, nis, accepted = [], [], [], [], [], []
    t0 = None
    for t_ns, o in ekf_outputs(messages, ekf):
        t0 = t_ns if t0 is None else t0
        stamps.append(t_ns - t0)
        bias.append(o.bias)
        sigma.append(o.bias_sigma)
        innov.append(o.innovation)
        nis.append(o.d2)
        accepted.append(o.accepted)
    if not stamps:
        raise BagError(f"{bag_dir}: the EKF made no update from the bag's sensor topics (counters: "
                       f"{ekf.counters._asdict()})")
    t = np.array(stamps, dtype=np.int64) * 1e-9
    bias, sigma, innov = np.array(bias), np.array(sigma), np.array(innov)
    nis_arr = np.array(nis)
    accepted_arr = np.array(accepted)
    # windows over the updates after the initial alignment (its zero innovation is no update)
    updates = np.flatnonzero(accepted_arr)[1:]
    windows, overall = _nis_windows(t, nis_arr, updates)
    plots = _plots(out, t, bias, sigma, innov, windows)
    verdicts = [v for *_, v in windows]
    return {
        "bag": str(bag_dir), "closed_cleanly": contents.closed_cleanly, "read_error": contents.error,
        "parameters": source, "updates": int(accepted_arr.sum()), "outputs": len(stamps),
        "span_s": float(t[-1]),
        "bias_final_deg_h": (bias[-1] * DEG_H_PER_RAD_S).tolist(), "bias_sigma_final_deg_h": (sigma[-1] * DEG_H_PER_RAD_S).tolist(),
        "innovation_rms_arcsec": (np.sqrt(np.mean(innov[updates] ** 2, axis=0)) * ARCSEC_PER_RAD).tolist()
        if len(updates) else None,
        "nis": {"dof": 3, "mean": overall.mean, "lower_95": overall.lower, "upper_95": overall.upper,
                "samples": overall.samples, "verdict": overall.verdict, "window": WINDOW, "windows": len(windows),
                "windows_by_verdict": {v: verdicts.count(v) for v in sorted(set(verdicts))}},
        "counters": ekf.counters._asdict(),
        "diagnostics": _diagnostics(bag_dir) if "/diagnostics" in contents.topics else {},
        "plots": plots,
    }


def _nis_windows(t: np.ndarray, nis: np.ndarray, updates: np.ndarray) -> tuple[list[tuple], Any]:
    """(t, mean, lower, upper, verdict) of each window of :data:`WINDOW` updates, and the
    verdict over all of them."""
    windows = []
    for start in range(0, len(updates) - WINDOW + 1, WINDOW):
        idx = updates[start:start + WINDOW]
        w = NisWindow(3, window=WINDOW, min_samples=WINDOW)
        for value in nis[idx]:
            w.add(value)
        v = w.verdict()
        windows.append((t[idx[-1]], v.mean, v.lower, v.upper, v.verdict))
    whole = NisWindow(3, window=max(len(updates), 1), min_samples=1)
    for value in nis[updates]:
        whole.add(value)
    return windows, whole.verdict()


def _plots(out: Path, t: np.ndarray, bias: np.ndarray, sigma: np.ndarray, innov: np.ndarray,
           windows: list[tuple]) -> list[str]:
    """bias_3sigma.png, innovations.png and (with windows) nis.png; returns their names."""
    plots = []
    fig, axes = stacked(3, 8.0)
    for i, axis in enumerate(("x (roll channel)", "q", "r")):
        ax = axes[i, 0]
        ax.plot(t, bias[:, i] * DEG_H_PER_RAD_S, label=f"b_{axis}", linewidth=1.0)
        ax.fill_between(t, (bias[:, i] - 3 * sigma[:, i]) * DEG_H_PER_RAD_S, (bias[:, i] + 3 * sigma[:, i]) * DEG_H_PER_RAD_S,
                        alpha=0.25, label="±3σ")
        style(ax, "[deg/h]")
    save_stacked(fig, axes, out / "bias_3sigma.png", "Gyro bias estimates ±3σ",
                 xlabel="time from the first estimate [s]")
    plots.append("bias_3sigma.png")
    fig, axes = stacked(1, 4.5)
    for i, axis in enumerate(("x", "y", "z")):
        axes[0, 0].plot(t, innov[:, i] * ARCSEC_PER_RAD, label=f"innovation {axis}", linewidth=0.6)
    style(axes[0, 0], "[arcsec]")
    save_stacked(fig, axes, out / "innovations.png", "EKF innovations (measured vs predicted C(n,m))",
                 xlabel="time from the first estimate [s]")
    plots.append("innovations.png")
    if windows:
        w = np.array([(a, b, c, d) for a, b, c, d, _ in windows])
        fig, axes = stacked(1, 4.5)
        ax = axes[0, 0]
        ax.plot(w[:, 0], w[:, 1], "o-", label=f"mean NIS over {WINDOW} updates", markersize=3)
        ax.plot(w[:, 0], w[:, 2], "k--", linewidth=0.8, label="95 % bounds")
        ax.plot(w[:, 0], w[:, 3], "k--", linewidth=0.8)
        ax.axhline(3.0, color="g", linewidth=0.8, label="expected (3 dof)")
        ax.set_yscale("log")
        style(ax, "NIS")
        save_stacked(fig, axes, out / "nis.png", "Normalised innovation squared against its chi-square bounds",
                     xlabel="time from the first estimate [s]")
        plots.append("nis.png")
    return plots
