"""Reports from recorded bags: ``report/metrics.json`` plus PNG plots.

``gimbal-report DIR`` regenerates the report of any bag; the orchestrator writes it at the
end of each run. Every figure comes from the bag itself, decoded from the recorded bytes.
Scenario-specific reports register in :data:`REPORTS`; ``generic`` works for any run.
"""
from __future__ import annotations

import argparse
import json
import math
import sys
from collections import defaultdict
from pathlib import Path
from typing import Callable

import numpy as np
import yaml

from .bag.reader import BagContents, BagError, read_messages
from .bag.schemas import message_class


def load_series(bag_dir: Path, topics: set[str] | None = None) -> tuple[dict[str, list], BagContents]:
    """Decoded messages by topic (each a list of (t [s], message)), and the bag summary."""
    from rclpy.serialization import deserialize_message

    raw, contents = read_messages(bag_dir, topics)
    series: dict[str, list] = defaultdict(list)
    classes: dict[str, type] = {}
    for msg in raw:
        cls = classes.get(msg.type_name) or classes.setdefault(msg.type_name, message_class(msg.type_name))
        series[msg.topic].append((msg.log_time_ns * 1e-9, deserialize_message(msg.data, cls)))
    return series, contents


def _quat_to_los(q) -> tuple[float, float]:
    x, y, z, w = q.x, q.y, q.z, q.w
    lx, ly, lz = 1 - 2 * (y * y + z * z), 2 * (x * y + z * w), 2 * (x * z - y * w)
    return math.atan2(ly, lx), math.atan2(-lz, math.hypot(lx, ly))


def _plot(path: Path, title: str, t: np.ndarray, curves: dict[str, np.ndarray], ylabel: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(9, 4.5), constrained_layout=True)
    for label, y in curves.items():
        ax.plot(t, y, label=label, linewidth=1.0)
    ax.set_title(title)
    ax.set_xlabel("sim time [s]")
    ax.set_ylabel(ylabel)
    ax.grid(True, alpha=0.3)
    ax.legend(loc="best", fontsize=8)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def generic_report(bag_dir: Path, out: Path) -> dict:
    """Counts and span of every topic; plots of the truth the run carries."""
    series, contents = load_series(bag_dir)
    metrics: dict = {
        "bag": str(bag_dir), "closed_cleanly": contents.closed_cleanly, "read_error": contents.error,
        "message_count": contents.message_count,
        "duration_s": ((contents.end_ns or 0) - (contents.start_ns or 0)) * 1e-9,
        "topics": {name: {"type": t.type_name, "count": t.count} for name, t in sorted(contents.topics.items())},
    }
    plots = []
    gimbal = series.get("/truth/gimbal/imu")
    if gimbal:
        t = np.array([s for s, _ in gimbal])
        az_el = np.array([_quat_to_los(m.orientation) for _, m in gimbal])
        _plot(out / "los_truth.png", "LOS direction (truth, NED)", t,
              {"azimuth": np.degrees(np.unwrap(az_el[:, 0])), "elevation": np.degrees(az_el[:, 1])}, "[deg]")
        plots.append("los_truth.png")
        metrics["los_truth_final_deg"] = {"azimuth": float(np.degrees(az_el[-1, 0])),
                                          "elevation": float(np.degrees(az_el[-1, 1]))}
    joints = series.get("/truth/gimbal/joint_states") or series.get("/truth/platform/joint_states")
    if joints:
        t = np.array([s for s, _ in joints])
        pos = np.array([list(m.position) for _, m in joints])
        names = list(joints[0][1].name)
        _plot(out / "joints_truth.png", "Joint angles (truth)", t,
              {n: np.degrees(pos[:, i]) for i, n in enumerate(names)}, "[deg]")
        plots.append("joints_truth.png")
    bias = series.get("/truth/gimbal/gyro_bias")
    if bias:
        t = np.array([s for s, _ in bias])
        b = np.array([[m.vector.y, m.vector.z] for _, m in bias])
        _plot(out / "gimbal_gyro_bias_truth.png", "Gimbal gyro bias (truth)", t,
              {"q_m": np.degrees(b[:, 0]) * 3600, "r_m": np.degrees(b[:, 1]) * 3600}, "[deg/h]")
        plots.append("gimbal_gyro_bias_truth.png")
    flex = series.get("/truth/ship/flexure")
    if flex:
        t = np.array([s for s, _ in flex])
        f = np.array([[m.vector.x, m.vector.y, m.vector.z] for _, m in flex])
        _plot(out / "flexure_truth.png", "Ship flexure LGU1 -> LGU2 (truth)", t,
              {axis: np.degrees(f[:, i]) * 3600 for i, axis in enumerate(("roll", "pitch", "yaw"))}, "[arcsec]")
        plots.append("flexure_truth.png")
    metrics["plots"] = plots
    return metrics


def _vehicle_site(bag_dir: Path) -> tuple[float, bool]:
    """(latitude [rad], earth rate on) of the run, from its scenario.yaml (defaults if absent)."""
    scenario_file = bag_dir / "scenario.yaml"
    params = {}
    if scenario_file.is_file():
        nodes = yaml.safe_load(scenario_file.read_text()).get("nodes", {})
        params = next((n.get("params", {}) for n in nodes.values() if n.get("executable") == "vehicle_dynamics"), {})
    profile_params = yaml.safe_load(params.get("profile_params", "{}")) or {}
    return math.radians(float(profile_params.get("lat_deg", 0.0))), bool(params.get("earth_rate", True))


def inertial_los(t: np.ndarray, quats: np.ndarray, lat: float, earth_rate: bool) -> np.ndarray:
    """LOS unit vectors (N, 3) in the inertial frame that coincides with NED at t = 0.

    NED turns with the earth at ω_ie^n (constant in n at a fixed site), so the direction of
    a vector fixed in inertial space, seen from NED at t, is rotated by exp(-[ω_ie^n ×] t).
    """
    from scipy.spatial.transform import Rotation

    from gimbal_kinematics.earth import earth_rate_n

    los_n = Rotation.from_quat(quats).apply([1.0, 0.0, 0.0])
    if not earth_rate:
        return los_n
    return Rotation.from_rotvec(np.outer(t, earth_rate_n(lat))).apply(los_n)


def los_pointing_report(bag_dir: Path, out: Path) -> dict:
    """Paper 1 stabilization figure: the angle between the LOS and its initial inertial
    direction over the run (truth from /truth/gimbal/imu)."""
    metrics = generic_report(bag_dir, out)
    series, _ = load_series(bag_dir, {"/truth/gimbal/imu", "/gimbal/torque_cmd"})
    gimbal = series.get("/truth/gimbal/imu", [])
    if not gimbal:
        raise BagError(f"{bag_dir}: no /truth/gimbal/imu to measure pointing from")
    t = np.array([s for s, _ in gimbal])
    quats = np.array([[m.orientation.x, m.orientation.y, m.orientation.z, m.orientation.w] for _, m in gimbal])
    lat, earth_rate = _vehicle_site(bag_dir)
    los = inertial_los(t - t[0], quats, lat, earth_rate)
    err = np.arccos(np.clip(los @ los[0], -1.0, 1.0))
    settled = t - t[0] >= 1.0
    metrics["pointing_error_urad"] = {
        "rms": float(1e6 * np.sqrt(np.mean(err**2))),
        "rms_after_1s": float(1e6 * np.sqrt(np.mean(err[settled] ** 2))) if settled.any() else None,
        "max": float(1e6 * err.max()),
        "final": float(1e6 * err[-1]),
    }
    _plot(out / "pointing_error.png", "LOS pointing error (angle to the initial inertial LOS)", t,
          {"pointing error": 1e6 * err}, "[µrad]")
    metrics["plots"].append("pointing_error.png")
    cmd = series.get("/gimbal/torque_cmd", [])
    if cmd:
        tc = np.array([s for s, _ in cmd])
        tau = np.array([list(m.effort) for _, m in cmd])
        _plot(out / "torque_command.png", "Torque command", tc, {"tau_a": tau[:, 0], "tau_e": tau[:, 1]}, "[N·m]")
        metrics["plots"].append("torque_command.png")
    return metrics


#: report name -> function(bag_dir, report_dir) -> metrics
REPORTS: dict[str, Callable[[Path, Path], dict]] = {"generic": generic_report, "los_pointing": los_pointing_report}


def write_report(bag_dir: Path, name: str | None = None) -> tuple[Path, dict]:
    """Write ``<bag_dir>/report/`` with the scenario's report (from ``scenario.yaml`` when
    ``name`` is None); returns the report directory and its metrics."""
    bag_dir = Path(bag_dir)
    if name is None:
        scenario_file = bag_dir / "scenario.yaml"
        name = yaml.safe_load(scenario_file.read_text()).get("report", "generic") if scenario_file.is_file() \
            else "generic"
    if name not in REPORTS:
        raise BagError(f"unknown report {name!r}; known: {', '.join(sorted(REPORTS))}")
    out = bag_dir / "report"
    out.mkdir(exist_ok=True)
    metrics = REPORTS[name](bag_dir, out)
    metrics["report"] = name
    (out / "metrics.json").write_text(json.dumps(metrics, indent=2, default=float) + "\n")
    return out, metrics


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="gimbal-report",
        description="Write (or rewrite) the report of a recorded run: DIR/report/metrics.json and PNG plots, "
                    "computed from the bag alone.")
    parser.add_argument("bag", help="bag directory (a gimbal-run output or any rosbag2 MCAP bag)")
    parser.add_argument("--report", help=f"report to write (default: the run's own); one of {sorted(REPORTS)}")
    args = parser.parse_args(argv)
    try:
        out, metrics = write_report(Path(args.bag), args.report)
    except BagError as exc:
        print(f"gimbal-report: {exc}", file=sys.stderr)
        return 2
    print(f"report written to {out} ({len(metrics.get('plots', []))} plots)")
    if not metrics.get("closed_cleanly", True):
        print(f"warning: the bag was not closed cleanly: {metrics.get('read_error')}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
