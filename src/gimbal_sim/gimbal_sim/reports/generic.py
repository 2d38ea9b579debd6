"""The ``generic`` report: counts and span of every topic, plots of the truth a run carries."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from .common import load_series, plot, quat_to_los


#: The truth topics this report plots (the summary counts every topic).
PLOTTED = ("/truth/gimbal/imu", "/truth/gimbal/joint_states", "/truth/platform/joint_states",
           "/truth/gimbal/gyro_bias", "/truth/ship/flexure")


def generic_report(bag_dir: Path, out: Path) -> dict:
    """Counts and span of every topic; plots of the truth the run carries."""
    series, contents = load_series(bag_dir, set(PLOTTED))
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
        az_el = np.array([quat_to_los(m.orientation) for _, m in gimbal])
        plot(out / "los_truth.png", "LOS direction (truth, NED)", t,
              {"azimuth": np.degrees(np.unwrap(az_el[:, 0])), "elevation": np.degrees(az_el[:, 1])}, "[deg]")
        plots.append("los_truth.png")
        metrics["los_truth_final_deg"] = {"azimuth": float(np.degrees(az_el[-1, 0])),
                                          "elevation": float(np.degrees(az_el[-1, 1]))}
    joints = series.get("/truth/gimbal/joint_states") or series.get("/truth/platform/joint_states")
    if joints:
        t = np.array([s for s, _ in joints])
        pos = np.array([list(m.position) for _, m in joints])
        names = list(joints[0][1].name)
        plot(out / "joints_truth.png", "Joint angles (truth)", t,
              {n: np.degrees(pos[:, i]) for i, n in enumerate(names)}, "[deg]")
        plots.append("joints_truth.png")
    bias = series.get("/truth/gimbal/gyro_bias")
    if bias:
        t = np.array([s for s, _ in bias])
        b = np.array([[m.vector.y, m.vector.z] for _, m in bias])
        plot(out / "gimbal_gyro_bias_truth.png", "Gimbal gyro bias (truth)", t,
              {"q_m": np.degrees(b[:, 0]) * 3600, "r_m": np.degrees(b[:, 1]) * 3600}, "[deg/h]")
        plots.append("gimbal_gyro_bias_truth.png")
    flex = series.get("/truth/ship/flexure")
    if flex:
        t = np.array([s for s, _ in flex])
        f = np.array([[m.vector.x, m.vector.y, m.vector.z] for _, m in flex])
        plot(out / "flexure_truth.png", "Ship flexure LGU1 -> LGU2 (truth)", t,
              {axis: np.degrees(f[:, i]) * 3600 for i, axis in enumerate(("roll", "pitch", "yaw"))}, "[arcsec]")
        plots.append("flexure_truth.png")
    metrics["plots"] = plots
    return metrics
