"""The ``gyro_encoder`` report: paper 2's Figs. 2 and 3, the MEMS gyro against the 1024-line
encoders about one axis (scenarios ``gimbal_gyro_encoder_rest`` and ``gimbal_gyro_encoder_slow``).

The axis is the vertical one the turret turns about. The encoders give its angle as turret
plus gimbal azimuth (joints 0 and 1) and its speed as the sum of their pulse-count
velocities (δ/T_g steps: 1.76 °/s for 1024 lines and a 0.2 s gate). The gimbal gyro sits
on the inner gimbal, tilted by the elevation θm, so the rate about the axis is r_m / cos θm
(θm from the elevation encoder). Figures: the gyro-integrated angle (trapezoids) against
the encoder angle (paper 2 Fig. 2: at rest it is the drift, ≈ bias · t), the two speeds
(Fig. 3: the encoder's staircase against the gyro), their means, and the encoder speed's
error against the gyro's.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from gimbal_kinematics.maths.units import DEG

from ..bag.reader import BagError
from ..figures import save_stacked, stacked, style
from .common import load_series
from .generic import generic_report


@dataclass
class GyroEncoderSeries:
    """Stamps [s] from the run's start; rates [rad/s], angles [rad]."""

    t_gyro: np.ndarray       # (N,)
    gyro_r: np.ndarray       # (N,) r_m
    t_enc: np.ndarray        # (M,)
    enc_pos: np.ndarray      # (M, 3) turret, azimuth, elevation
    enc_vel: np.ndarray      # (M, 3) pulse-count velocities
    bias_r: np.ndarray       # (N,) true r_m gyro bias at the gyro samples


def figures(s: GyroEncoderSeries) -> dict:
    """The report's figures (degrees, deg/s) from the series."""
    cos_th = np.cos(np.interp(s.t_gyro, s.t_enc, s.enc_pos[:, 2]))
    rate = s.gyro_r / cos_th
    dt = np.diff(s.t_gyro)
    gyro_angle = np.concatenate([[0.0], np.cumsum(0.5 * dt * (rate[1:] + rate[:-1]))])
    enc_angle = s.enc_pos[:, 0] + s.enc_pos[:, 1]
    enc_speed = s.enc_vel[:, 0] + s.enc_vel[:, 1]
    span = s.t_gyro[-1] - s.t_gyro[0]
    bias_axis = s.bias_r / cos_th
    bias_angle = np.concatenate([[0.0], np.cumsum(0.5 * dt * (bias_axis[1:] + bias_axis[:-1]))])
    first_gate = np.argmax(enc_speed != 0.0) if np.any(enc_speed != 0.0) else len(enc_speed)
    gyro_at_enc = np.interp(s.t_enc, s.t_gyro, rate)
    return {
        "duration_s": float(span),
        "gyro_angle_final_deg": float(gyro_angle[-1] / DEG),
        "encoder_angle_change_deg": float((enc_angle[-1] - enc_angle[0]) / DEG),
        "drift_deg": float((gyro_angle[-1] - (enc_angle[-1] - enc_angle[0])) / DEG),
        "bias_integral_deg": float(bias_angle[-1] / DEG),
        "gyro_rate_mean_deg_s": float(np.mean(rate) / DEG),
        "gyro_rate_std_deg_s": float(np.std(rate) / DEG),
        "encoder_speed_mean_deg_s": float(np.mean(enc_speed[first_gate:]) / DEG) if first_gate < len(enc_speed)
        else 0.0,
        "encoder_speed_levels_deg_s": sorted({round(float(v) / DEG, 6) for v in enc_speed}),
        "encoder_speed_error_rms_deg_s": float(np.sqrt(np.mean((enc_speed - gyro_at_enc)[first_gate:] ** 2)) / DEG)
        if first_gate < len(enc_speed) else 0.0,
        "series": {"gyro_angle": gyro_angle, "rate": rate, "enc_angle": enc_angle - enc_angle[0],
                   "enc_speed": enc_speed, "bias_angle": bias_angle},
    }


def load(bag_dir: Path) -> GyroEncoderSeries:
    """The series from a bag; :class:`BagError` without the gyro or the encoders."""
    series, _ = load_series(bag_dir, {"/gimbal/imu", "/gimbal/joint_states", "/truth/gimbal/gyro_bias"})
    imu, enc = series.get("/gimbal/imu", []), series.get("/gimbal/joint_states", [])
    if not imu or not enc:
        raise BagError(f"{bag_dir}: needs /gimbal/imu and /gimbal/joint_states (sensors gimbal_gyro, encoders)")
    t0 = imu[0][0]
    bias = series.get("/truth/gimbal/gyro_bias", [])
    return GyroEncoderSeries(
        t_gyro=np.array([t for t, _ in imu]) - t0, gyro_r=np.array([m.angular_velocity.z for _, m in imu]),
        t_enc=np.array([t for t, _ in enc]) - t0, enc_pos=np.array([tuple(m.position) for _, m in enc]),
        enc_vel=np.array([tuple(m.velocity) for _, m in enc]),
        bias_r=np.array([m.vector.z for _, m in bias]) if len(bias) == len(imu) else np.zeros(len(imu)))


def plot(path: Path, s: GyroEncoderSeries, fig: dict) -> None:
    """Two panels: the speeds (Fig. 3) and the angles (Fig. 2) about the axis."""
    f, axes = stacked(2, 6.5)
    ser = fig["series"]
    ax = axes[0, 0]
    ax.plot(s.t_gyro, ser["rate"] / DEG, linewidth=0.6, label="gyro r_m / cos θm")
    ax.step(s.t_enc, ser["enc_speed"] / DEG, where="post", linewidth=1.0, label="encoder pulse-count speed (eq. 1)")
    style(ax, "speed about the axis [deg/s]", fontsize=7)
    ax = axes[1, 0]
    ax.plot(s.t_gyro, ser["gyro_angle"] / DEG, label="gyro-integrated angle")
    ax.step(s.t_enc, ser["enc_angle"] / DEG, where="post", label="encoder angle (counts)")
    ax.plot(s.t_gyro, ser["bias_angle"] / DEG, "k--", linewidth=0.8, label="∫ true bias dt")
    style(ax, "angle about the axis [deg]", fontsize=7)
    save_stacked(f, axes, path, "Gyro against encoder about one axis (paper 2 Figs. 2, 3)")


def gyro_encoder_report(bag_dir: Path, out: Path) -> dict:
    """Report of one run (module docstring)."""
    metrics = generic_report(bag_dir, out)
    s = load(bag_dir)
    fig = figures(s)
    plot(Path(out) / "gyro_vs_encoder.png", s, fig)
    fig.pop("series")
    metrics["gyro_encoder"] = fig
    metrics["plots"].append("gyro_vs_encoder.png")
    return metrics
