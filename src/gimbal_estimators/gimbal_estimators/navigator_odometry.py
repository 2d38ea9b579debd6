"""``nav_msgs/Odometry`` from the platform navigator's output, per REP 105 (pure, no rclpy).

* **Pose** in a local ENU frame (``odom_frame_id``, default ``odom``: continuous, it drifts
  as the INS does and never jumps) whose origin is the navigator's first fix, the hand-off
  point: east, north, up of each fix relative to it (:func:`gimbal_kinematics.maths.earth.enu_from_geodetic`).
* **Child frame** ``odom_child_frame_id`` (default ``base_link``, REP 103 forward-left-up):
  level, at the base's heading. The navigator knows that heading only on a static base with
  the resolver as its azimuth source (``base_heading_deg``); with ``azimuth_source: servo``
  (a moving base) it does not, and the child frame is then given the ENU axes (identity
  orientation) with the yaw marked unmeasured.
* **Twist** in the child frame (REP 105): the NED velocity turned into ENU and resolved in
  the child's axes. The angular rate is not estimated (0, variance unmeasured).
* **Covariance**, diagonal, from the figures of merit a platform INS is specified by: the
  horizontal position error grows linearly at the CEP rate (CEP50 = 1.1774 σ per axis for a
  circular normal error), the vertical channel is held to its reference height
  (``odom_vertical_sigma_m``), the horizontal and vertical velocity error is bounded by the
  Schuler oscillation (``odom_velocity_sigma_m_s``), roll, pitch and heading carry the
  alignment's residual (``odom_attitude_sigma_deg``). The mechanisation itself has no filter
  and no covariance of its own; these are the parameters a user states for it.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

from gimbal_kinematics.maths.earth import enu_from_geodetic
from gimbal_kinematics.maths.units import NMI_M

from .platform_navigator import NavigatorOutput

#: CEP50 of a circular normal error of σ per axis: σ sqrt(2 ln 2).
CEP_PER_SIGMA = math.sqrt(2.0 * math.log(2.0))


@dataclass(frozen=True)
class OdometryModel:
    """The error figures of :mod:`this module <.navigator_odometry>` in SI, and the base heading.

    ``heading_rad``: the base's heading (NED, from north towards east) or None when unknown."""

    cep_rate_m_s: float
    velocity_sigma_m_s: float
    vertical_sigma_m: float
    attitude_sigma_rad: float
    heading_rad: float | None

    @classmethod
    def from_values(cls, v: dict, heading_known: bool) -> "OdometryModel":
        return cls(cep_rate_m_s=v["odom_cep_rate_nmi_h"] * NMI_M / 3600.0,
                   velocity_sigma_m_s=v["odom_velocity_sigma_m_s"], vertical_sigma_m=v["odom_vertical_sigma_m"],
                   attitude_sigma_rad=math.radians(v["odom_attitude_sigma_deg"]),
                   heading_rad=math.radians(v["base_heading_deg"]) if heading_known else None)


class Odometry(NamedTuple):
    """One Odometry message's contents: ``position`` ENU [m], ``orientation`` (x, y, z, w) of
    the child in the ENU frame, ``pose_cov`` and ``twist_cov`` 36 row-major, ``linear``
    [m/s] and ``angular`` [rad/s] in the child frame."""

    position: tuple[float, float, float]
    orientation: tuple[float, float, float, float]
    pose_cov: tuple[float, ...]
    linear: tuple[float, float, float]
    angular: tuple[float, float, float]
    twist_cov: tuple[float, ...]


def _diag6(values: tuple[float, ...]) -> tuple[float, ...]:
    return tuple(values[i // 6] if i % 7 == 0 else 0.0 for i in range(36))


class NavigatorOdometry:
    """Turns each :class:`NavigatorOutput` into an :class:`Odometry`; the first one sets the
    origin (its fix and stamp). ``unmeasured_variance``: the variance that marks a component
    as not estimated (the ROS edge's, :data:`gimbal_kinematics.ros.messages.UNMEASURED_VARIANCE`)."""

    def __init__(self, model: OdometryModel, unmeasured_variance: float) -> None:
        self.model = model
        self.unmeasured = unmeasured_variance
        self.origin: tuple[int, float, float, float] | None = None  # (t_ns, lat, lon, h)

    def __call__(self, out: NavigatorOutput) -> Odometry:
        if self.origin is None:
            self.origin = (out.t_ns, out.lat, out.lon, out.height)
        t0, lat0, lon0, h0 = self.origin
        position = enu_from_geodetic(out.lat, out.lon, out.height, lat0, lon0, h0)
        v_n, v_e, v_d = out.velocity_n
        mod = self.model
        # the child's yaw in ENU (from east towards north) of a heading from north towards east
        yaw = 0.0 if mod.heading_rad is None else math.pi / 2.0 - mod.heading_rad
        c, s = math.cos(yaw), math.sin(yaw)
        linear = (c * v_e + s * v_n, -s * v_e + c * v_n, -v_d)
        sigma_h = mod.cep_rate_m_s * max(0.0, (out.t_ns - t0) * 1e-9) / CEP_PER_SIGMA
        att = mod.attitude_sigma_rad**2
        yaw_var = self.unmeasured if mod.heading_rad is None else att
        pose_cov = _diag6((sigma_h**2, sigma_h**2, mod.vertical_sigma_m**2, att, att, yaw_var))
        twist_cov = _diag6((mod.velocity_sigma_m_s**2,) * 3 + (self.unmeasured,) * 3)
        return Odometry(position, (0.0, 0.0, math.sin(yaw / 2.0), math.cos(yaw / 2.0)), pose_cov, linear,
                        (0.0, 0.0, 0.0), twist_cov)
