"""The ``encoder_fusion`` report and comparison: paper 2's figures from recorded bags.

Per bag (one feedback mode of ``encoder_fusion_controller``):

* stabilization error: the angle between the LOS (inner-gimbal x axis, from
  ``/truth/gimbal/imu``) and its initial inertial direction; RMS and peak after a settling
  time ``min(5 s, duration / 4)`` (the fused loop's filter converges within it);
* feedback velocity vs truth: the controller's ``~/feedback_velocity`` minus the true
  inertial rate of the inner gimbal (q_m, r_m) at the same step; its mean over the second
  half of the run against the mean true gyro bias (``/truth/gimbal/gyro_bias``) over the
  same span. ``bias_in_velocity_fraction`` = mean velocity error / mean bias per axis: 1
  when the bias passes into the feedback (raw gyro), ≈ 0 once the filter removes it;
* the filter's drift correction ``~/drift_correction`` (fused mode) against −(gyro bias).

The comparison takes the bags of the variants (``encoder``, ``gyro``, ``fused``) and writes
a table (``comparison.md`` and ``metrics["table"]``) and plots: error against time, RMS
bars, and the velocity error against the gyro bias. Paper 2's figure is
``fusion_improvement`` = RMS(encoder) / RMS(fused) (paper: 10×).
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import yaml
from gimbal_kinematics.maths.los import inertial_los, los_from_quat
from gimbal_kinematics.maths.units import DEG

from ..bag.reader import BagError
from .common import load_series, plot, site_rate_n, vehicle_site
from ..figures import pyplot, save, save_stacked, stacked, style
from .generic import generic_report

SETTLE_S = 5.0
CONTROLLER = "encoder_fusion_controller"
PAPER_IMPROVEMENT = 10.0


def _stamp_ns(msg) -> int:
    return msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec


def controller_of(bag_dir: Path) -> tuple[str, str]:
    """(node name, mode) of the run's encoder_fusion_controller, from its scenario.yaml."""
    scenario_file = Path(bag_dir) / "scenario.yaml"
    if scenario_file.is_file():
        nodes = yaml.safe_load(scenario_file.read_text()).get("nodes", {})
        for name, spec in nodes.items():
            if (spec or {}).get("executable", name) == CONTROLLER:
                return name, str((spec.get("params") or {}).get("mode", "fused"))
    return CONTROLLER, "fused"


@dataclass
class FusionRun:
    """Series of one run (times [s] from the header stamps, rates [rad/s], angles [rad])."""

    mode: str
    t: np.ndarray              # (N,) truth steps
    error: np.ndarray          # (N,) stabilization error
    true_rate: np.ndarray      # (N, 2) inertial rate of m, (q_m, r_m)
    fb_t: np.ndarray           # (M,) feedback stamps
    fb_error: np.ndarray       # (M, 2) feedback velocity − truth at the same step
    bias_t: np.ndarray         # (L,)
    bias: np.ndarray           # (L, 2) true gimbal-gyro bias (q_m, r_m)
    corr_t: np.ndarray         # (C,)
    corr: np.ndarray           # (C, 2) drift correction E
    torque_t: np.ndarray       # (K,)
    torque: np.ndarray         # (K, 2) (τ_a, τ_e) [N·m]

    @property
    def duration(self) -> float:
        return float(self.t[-1] - self.t[0]) if len(self.t) > 1 else 0.0

    @property
    def settle_s(self) -> float:
        return min(SETTLE_S, 0.25 * self.duration)


def load_run(bag_dir: Path) -> FusionRun:
    """Decode the topics the report needs from ``bag_dir``; :class:`BagError` if the run has
    no gimbal truth or no controller feedback."""
    bag_dir = Path(bag_dir)
    node, mode = controller_of(bag_dir)
    fb_topic, corr_topic = f"/{node}/feedback_velocity", f"/{node}/drift_correction"
    series, _ = load_series(bag_dir, {"/truth/gimbal/imu", "/truth/gimbal/gyro_bias", "/gimbal/torque_cmd",
                                      fb_topic, corr_topic})
    gimbal = series.get("/truth/gimbal/imu", [])
    if not gimbal:
        raise BagError(f"{bag_dir}: no /truth/gimbal/imu to measure the stabilization error from")
    feedback = series.get(fb_topic, [])
    if not feedback:
        raise BagError(f"{bag_dir}: no {fb_topic} (is {CONTROLLER} in the run?)")
    stamps = np.array([_stamp_ns(msg) for _, msg in gimbal])
    t = (stamps - stamps[0]) * 1e-9
    quats = np.array([[g.orientation.x, g.orientation.y, g.orientation.z, g.orientation.w] for _, g in gimbal])
    lat, earth_rate = vehicle_site(bag_dir)
    los = inertial_los(los_from_quat(quats), t, site_rate_n(lat, earth_rate))
    # atan2 form: accurate for the µrad angles of a good loop, where arccos is not
    error = np.arctan2(np.linalg.norm(np.cross(los, los[0]), axis=1), los @ los[0])
    true_rate = np.array([[g.angular_velocity.y, g.angular_velocity.z] for _, g in gimbal])
    index = {int(s): i for i, s in enumerate(stamps)}
    fb_stamps = np.array([_stamp_ns(msg) for _, msg in feedback])
    keep = np.array([int(s) in index for s in fb_stamps])
    rows = np.array([index[int(s)] for s in fb_stamps[keep]], dtype=int)
    fb = np.array([[msg.vector.y, msg.vector.z] for _, msg in feedback]).reshape(-1, 2)[keep]

    def pairs(topic: str, get) -> tuple[np.ndarray, np.ndarray]:
        items = series.get(topic, [])
        ts = np.array([(_stamp_ns(msg) - stamps[0]) * 1e-9 for _, msg in items])
        return ts, np.array([get(msg) for _, msg in items]).reshape(-1, 2)

    bias_t, bias = pairs("/truth/gimbal/gyro_bias", lambda msg: (msg.vector.y, msg.vector.z))
    corr_t, corr = pairs(corr_topic, lambda msg: (msg.vector.y, msg.vector.z))
    torque_t, torque = pairs("/gimbal/torque_cmd", lambda msg: tuple(msg.effort))
    return FusionRun(mode=mode, t=t, error=error, true_rate=true_rate, fb_t=t[rows], fb_error=fb - true_rate[rows],
                     bias_t=bias_t, bias=bias, corr_t=corr_t, corr=corr, torque_t=torque_t, torque=torque)


def run_metrics(run: FusionRun) -> dict:
    """The figures of one run (module docstring); errors in µrad, rates in deg/s."""
    after = run.t >= run.settle_s
    half_t = run.t[0] + 0.5 * run.duration
    fb_half = run.fb_t >= half_t
    bias_half = run.bias_t >= half_t
    vel_mean = run.fb_error[fb_half].mean(axis=0) if fb_half.any() else np.full(2, np.nan)
    vel_rms = np.sqrt(np.mean(run.fb_error[fb_half] ** 2, axis=0)) if fb_half.any() else np.full(2, np.nan)
    bias_mean = run.bias[bias_half].mean(axis=0) if bias_half.any() else np.full(2, np.nan)
    metrics = {
        "mode": run.mode,
        "settle_s": run.settle_s,
        "stabilization_error_urad": {
            "rms_after_settle": float(1e6 * np.sqrt(np.mean(run.error[after] ** 2))),
            "peak_after_settle": float(1e6 * run.error[after].max()),
            "rms": float(1e6 * np.sqrt(np.mean(run.error ** 2))),
            "final": float(1e6 * run.error[-1]),
        },
        "velocity_error_mean_deg_s": (vel_mean / DEG).tolist(),
        "velocity_error_rms_deg_s": (vel_rms / DEG).tolist(),
        "gyro_bias_mean_deg_s": (bias_mean / DEG).tolist(),
        # the encoder-mode velocity involves no gyro: the fraction means nothing there
        "bias_in_velocity_fraction": None if run.mode == "encoder" else (vel_mean / bias_mean).tolist(),
        "kf_updates": int(len(run.corr_t)),
    }
    if len(run.corr_t) and len(run.bias_t):
        k = int(np.searchsorted(run.bias_t, run.corr_t[-1]))
        b = run.bias[min(k, len(run.bias_t) - 1)]
        metrics["final_drift_correction_deg_s"] = (run.corr[-1] / DEG).tolist()
        metrics["final_drift_residual_deg_s"] = ((run.corr[-1] + b) / DEG).tolist()
    return metrics


def _window_means(t: np.ndarray, y: np.ndarray, width_s: float) -> tuple[np.ndarray, np.ndarray]:
    """Means of ``y`` (n, 2) over consecutive windows of ``width_s`` [s]: (centres, means).
    A window with less than half the samples of the fullest (the run's last) is left out."""
    if len(t) == 0:
        return np.zeros(0), np.zeros((0, 2))
    bins = np.floor((t - t[0]) / width_s).astype(int)
    counts = np.bincount(bins)
    ok = counts >= 0.5 * counts.max()
    means = np.stack([np.bincount(bins, weights=y[:, i])[ok] / counts[ok] for i in range(y.shape[1])], axis=1)
    return t[0] + (np.nonzero(ok)[0] + 0.5) * width_s, means


def _velocity_vs_bias_plot(path: Path, runs: dict[str, FusionRun]) -> None:
    fig, axes = stacked(2, 6.5)
    for i, (ax, axis) in enumerate(zip(axes[:, 0], ("q_m (elevation)", "r_m (azimuth)"))):
        first = next(iter(runs.values()))
        ax.plot(first.bias_t, first.bias[:, i] / DEG, "k--", linewidth=1.2, label="true gyro bias")
        for name, run in runs.items():
            tc, mean = _window_means(run.fb_t, run.fb_error, 0.5)
            ax.plot(tc, mean[:, i] / DEG, label=f"{name}: feedback − true velocity (0.5 s means)", linewidth=1.0)
            if len(run.corr_t):
                ax.plot(run.corr_t, -run.corr[:, i] / DEG, ":", label=f"{name}: −drift correction", linewidth=1.2)
        style(ax, f"{axis} [deg/s]", fontsize=7)
    save_stacked(fig, axes, path, "Estimated velocity error against the gyro bias")


def encoder_fusion_report(bag_dir: Path, out: Path) -> dict:
    """Report of one run (module docstring)."""
    metrics = generic_report(bag_dir, out)
    run = load_run(bag_dir)
    metrics.update(run_metrics(run))
    plot(out / "stabilization_error.png", f"Stabilization error ({run.mode} feedback): angle to the initial "
         "inertial LOS", run.t, {"error": 1e3 * run.error}, "[mrad]")
    _velocity_vs_bias_plot(out / "velocity_error_vs_bias.png", {run.mode: run})
    metrics["plots"] += ["stabilization_error.png", "velocity_error_vs_bias.png"]
    if len(run.torque_t):
        plot(out / "torque_command.png", "Torque command", run.torque_t,
             {"tau_a": run.torque[:, 0], "tau_e": run.torque[:, 1]}, "[N·m]")
        metrics["plots"].append("torque_command.png")
    return metrics


def _pair(values: list[float] | None, fmt: str) -> str:
    return "n/a" if values is None else ", ".join(format(v, fmt) for v in values)


def _table(rows: list[dict]) -> str:
    lines = ["| variant | mode | RMS error after settle [µrad] | peak [µrad] | velocity error mean q, r [deg/s] "
             "| gyro bias mean q, r [deg/s] | bias in velocity q, r | KF updates |",
             "|---|---|---:|---:|---|---|---|---:|"]
    for r in rows:
        lines.append(f"| {r['variant']} | {r['mode']} | {r['rms_after_settle_urad']:.1f} "
                     f"| {r['peak_after_settle_urad']:.1f} "
                     f"| {_pair(r['velocity_error_mean_deg_s'], '+.4f')} | {_pair(r['gyro_bias_mean_deg_s'], '+.4f')} "
                     f"| {_pair(r['bias_in_velocity_fraction'], '+.3f')} "
                     f"| {r['kf_updates']} |")
    return "\n".join(lines) + "\n"


def _rms_bars(path: Path, rows: list[dict]) -> None:
    fig, ax = pyplot().subplots(figsize=(6.5, 4.5), constrained_layout=True)
    names = [r["variant"] for r in rows]
    values = [r["rms_after_settle_urad"] for r in rows]
    bars = ax.bar(names, values, color=["tab:blue", "tab:orange", "tab:green", "tab:red"][:len(rows)])
    for bar, v in zip(bars, values):
        ax.annotate(f"{v:,.0f}", (bar.get_x() + bar.get_width() / 2, v), ha="center", va="bottom", fontsize=9)
    ax.set_yscale("log")
    ax.set_ylabel("RMS stabilization error after settle [µrad]")
    ax.set_title("Stabilization error by feedback velocity")
    ax.grid(True, axis="y", which="both", alpha=0.3)
    save(fig, path)


def _error_plot(path: Path, runs: dict[str, FusionRun]) -> None:
    fig, axes = stacked(1, 4.5)
    ax = axes[0, 0]
    for name, run in runs.items():
        ax.plot(run.t, 1e3 * run.error, label=name, linewidth=1.0)
    settle = next(iter(runs.values())).settle_s
    ax.axvline(settle, color="grey", linestyle=":", label=f"settle ({settle:g} s)")
    ax.set_yscale("log")
    style(ax, "angle to the initial inertial LOS [mrad]")
    ax.grid(True, which="both", alpha=0.3)
    save_stacked(fig, axes, path, "Stabilization error: encoder, gyro and fused feedback")


def encoder_fusion_comparison(runs: dict[str, Path], out: Path) -> dict:
    """Compare the variants' bags (``runs``: variant -> bag dir, in order) into ``out``:
    table, plots and ``fusion_improvement`` = RMS(encoder) / RMS(fused)."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    loaded = {name: load_run(path) for name, path in runs.items()}
    rows = []
    per_variant = {}
    for name, run in loaded.items():
        m = run_metrics(run)
        per_variant[name] = m | {"bag": str(runs[name])}
        rows.append({"variant": name, "mode": m["mode"],
                     "rms_after_settle_urad": m["stabilization_error_urad"]["rms_after_settle"],
                     "peak_after_settle_urad": m["stabilization_error_urad"]["peak_after_settle"],
                     "velocity_error_mean_deg_s": m["velocity_error_mean_deg_s"],
                     "gyro_bias_mean_deg_s": m["gyro_bias_mean_deg_s"],
                     "bias_in_velocity_fraction": m["bias_in_velocity_fraction"], "kf_updates": m["kf_updates"]})
    metrics: dict = {"variants": per_variant, "table": rows}
    by_mode = {r["mode"]: r["rms_after_settle_urad"] for r in rows}
    if "encoder" in by_mode and "fused" in by_mode:
        metrics["fusion_improvement"] = by_mode["encoder"] / by_mode["fused"]
        metrics["meets_paper_10x"] = bool(metrics["fusion_improvement"] >= PAPER_IMPROVEMENT)
    if "gyro" in by_mode and "fused" in by_mode:
        metrics["fused_vs_gyro_improvement"] = by_mode["gyro"] / by_mode["fused"]
    text = _table(rows)
    if "fusion_improvement" in metrics:
        text += (f"\nRMS(encoder) / RMS(fused) = {metrics['fusion_improvement']:.1f} "
                 f"(paper 2: {PAPER_IMPROVEMENT:g}x)\n")
    (out / "comparison.md").write_text(text)
    _error_plot(out / "error_vs_time.png", loaded)
    _rms_bars(out / "rms_bars.png", rows)
    # the encoder velocity's gate lag (degrees per second) would hide the bias scale
    _velocity_vs_bias_plot(out / "velocity_error_vs_bias.png",
                           {n: r for n, r in loaded.items() if r.mode != "encoder"} or loaded)
    metrics["plots"] = ["error_vs_time.png", "rms_bars.png", "velocity_error_vs_bias.png"]
    metrics["files"] = ["comparison.md"]
    return metrics
