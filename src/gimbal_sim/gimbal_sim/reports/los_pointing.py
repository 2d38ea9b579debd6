"""The ``los_pointing`` report: paper 1's stabilization figure."""
from __future__ import annotations

from pathlib import Path

import numpy as np
from gimbal_kinematics.maths.los import inertial_los, los_from_quat

from ..bag.reader import BagError
from .common import load_series, plot, site_rate_n, vehicle_site
from .generic import generic_report


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
    lat, earth_rate = vehicle_site(bag_dir)
    los = inertial_los(los_from_quat(quats), t - t[0], site_rate_n(lat, earth_rate))
    err = np.arccos(np.clip(los @ los[0], -1.0, 1.0))
    settled = t - t[0] >= 1.0
    metrics["pointing_error_urad"] = {
        "rms": float(1e6 * np.sqrt(np.mean(err**2))),
        "rms_after_1s": float(1e6 * np.sqrt(np.mean(err[settled] ** 2))) if settled.any() else None,
        "max": float(1e6 * err.max()),
        "final": float(1e6 * err[-1]),
    }
    plot(out / "pointing_error.png", "LOS pointing error (angle to the initial inertial LOS)", t,
          {"pointing error": 1e6 * err}, "[µrad]")
    metrics["plots"].append("pointing_error.png")
    cmd = series.get("/gimbal/torque_cmd", [])
    if cmd:
        tc = np.array([s for s, _ in cmd])
        tau = np.array([list(m.effort) for _, m in cmd])
        plot(out / "torque_command.png", "Torque command", tc, {"tau_a": tau[:, 0], "tau_e": tau[:, 1]}, "[N·m]")
        metrics["plots"].append("torque_command.png")
    return metrics
