"""Paper 2 Fig. 8, "Estimated velocities during movement", from a recorded fused run's bag.

Per gimbal-gyro axis (q_m: elevation, r_m: about the azimuth motor), four inertial rates of
the inner gimbal, all from the bag:

* the truth (``/truth/gimbal/imu``);
* the MEMS gyro (``/gimbal/imu``), bias and noise included;
* the encoder speed by eq. 1 (the sensor's pulse count over its gate, ``/gimbal/joint_states``
  velocities) in the same inertial form as the encoder-only loop's feedback: the base part
  from the autopilot's rates (``/truth/host/imu``) resolved through the encoder angles, plus
  the joint speed (q: θ̇m; r: cos θm ψ̇m);
* the estimated velocity, the fused loop's feedback (``/encoder_fusion_controller/feedback_velocity``).

While the UAV moves, the gimbal turns against it at up to several °/s; the encoder speed
steps by one count per gate (eq. 1), the gyro is smooth but offset by its bias, and the
estimate follows the truth.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ..bag.reader import BagError
from ..figures import save_stacked, stacked, style
from .common import load_series
from .encoder_fusion import controller_of
from gimbal_kinematics.maths.units import DEG


def _ns(msg) -> int:
    return msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec


def fig8_series(bag_dir: Path) -> dict[str, np.ndarray]:
    """t [s] and the four rates (n, 2) (q_m, r_m) [rad/s] of the module docstring, at the
    steps every topic holds; and the joint speeds (ψ̇m, θ̇m) [rad/s], true and by eq. 1."""
    node, _ = controller_of(bag_dir)
    fb_topic = f"/{node}/feedback_velocity"
    topics = {"/truth/gimbal/imu", "/gimbal/imu", "/gimbal/joint_states", "/truth/host/imu", "/truth/gimbal/joint_states",
              fb_topic}
    series, _ = load_series(Path(bag_dir), topics)
    missing = sorted(t for t in topics if not series.get(t))
    if missing:
        raise BagError(f"{bag_dir}: no {', '.join(missing)}")
    by = {topic: {_ns(m): m for _, m in series[topic]} for topic in topics}
    stamps = sorted(set.intersection(*(set(d) for d in by.values())))
    t0 = min(by["/truth/gimbal/imu"])
    truth = np.array([[by["/truth/gimbal/imu"][s].angular_velocity.y, by["/truth/gimbal/imu"][s].angular_velocity.z]
                      for s in stamps])
    gyro = np.array([[by["/gimbal/imu"][s].angular_velocity.y, by["/gimbal/imu"][s].angular_velocity.z] for s in stamps])
    est = np.array([[by[fb_topic][s].vector.y, by[fb_topic][s].vector.z] for s in stamps])
    enc = np.zeros((len(stamps), 2))
    joint_true = np.array([by["/truth/gimbal/joint_states"][s].velocity[1:3] for s in stamps])
    joint_enc = np.array([by["/gimbal/joint_states"][s].velocity[1:3] for s in stamps])
    for k, s in enumerate(stamps):
        js, host = by["/gimbal/joint_states"][s], by["/truth/host/imu"][s]
        psi, theta = js.position[1], js.position[2]
        psi_dot, theta_dot = js.velocity[1], js.velocity[2]
        wx, wy, wz = host.angular_velocity.x, host.angular_velocity.y, host.angular_velocity.z
        cpsi, spsi, cth, sth = math.cos(psi), math.sin(psi), math.cos(theta), math.sin(theta)
        enc[k] = (-spsi * wx + cpsi * wy + theta_dot, sth * (cpsi * wx + spsi * wy) + cth * wz + cth * psi_dot)
    return {"t": (np.array(stamps) - t0) * 1e-9, "truth": truth, "gyro": gyro, "encoder": enc, "estimated": est,
            "joint_true": joint_true, "joint_encoder": joint_enc}


def fig8_plot(bag_dir: Path, png: Path, window_s: tuple[float, float] = (8.0, 12.0)) -> dict:
    """Fig. 8 into ``png`` over ``window_s``; returns the RMS of each rate's error against the
    truth over the window [deg/s] and the encoder's speed step (one count per gate)."""
    s = fig8_series(bag_dir)
    t = s["t"]
    w = (t >= window_s[0]) & (t <= window_s[1])
    fig, axes = stacked(3, 8.5)
    ax = axes[0, 0]
    for i, (name, color) in enumerate((("azimuth", "tab:blue"), ("elevation", "tab:purple"))):
        ax.plot(t[w], s["joint_encoder"][w, i] / DEG, color=color, drawstyle="steps-post", linewidth=1.0,
                label=f"{name} joint speed, encoder eq. 1")
        ax.plot(t[w], s["joint_true"][w, i] / DEG, color=color, linewidth=0.8, alpha=0.6,
                label=f"{name} joint speed, true")
    ax.set_ylim(-5.0, 7.0)
    style(ax, "joint speed [deg/s]", ncol=2, fontsize=7, legend_loc="upper left")
    colors = {"truth": "k", "gyro": "tab:orange", "encoder": "tab:blue", "estimated": "tab:green"}
    labels = {"truth": "true inertial rate", "gyro": "MEMS gyro", "encoder": "encoder, eq. 1 (+ base rates)",
              "estimated": "estimated (KF-corrected gyro)"}
    for i, axis in enumerate(("q_m (elevation)", "r_m (azimuth)")):
        ax = axes[i + 1, 0]
        for key in ("encoder", "gyro", "estimated", "truth"):
            ax.plot(t[w], s[key][w, i] / DEG, color=colors[key], label=labels[key], alpha=0.45 if key == "encoder" else 1.0,
                    linewidth=1.6 if key == "truth" else 1.0, drawstyle="steps-post" if key == "encoder" else "default")
        style(ax, f"{axis} [deg/s]", ncol=4, fontsize=7, legend_loc="upper left")
        ax.set_ylim(-4.5, 6.0)
    save_stacked(fig, axes, Path(png), "Paper 2 Fig. 8: estimated velocities during movement (fused run)")
    err = {key: (np.sqrt(np.mean((s[key][w] - s["truth"][w]) ** 2, axis=0)) / DEG).tolist()
           for key in ("gyro", "encoder", "estimated")}
    inertial = (np.sqrt(np.mean(s["truth"][w] ** 2, axis=0)) / DEG).tolist()
    joint = (np.sqrt(np.mean(s["joint_true"][w] ** 2, axis=0)) / DEG).tolist()
    return {"window_s": list(window_s), "error_rms_deg_s (q_m, r_m)": err, "true_inertial_rate_rms_deg_s": inertial,
            "true_joint_speed_rms_deg_s (azimuth, elevation)": joint}
