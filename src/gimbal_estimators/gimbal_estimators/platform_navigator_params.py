"""Parameters of the platform INS navigator (:mod:`.platform_navigator`), readable without ROS:
the core's frozen :class:`PlatformNavigatorParams` (engineering units at this edge, SI
properties for the core), the ``platform_navigator`` parameter table :data:`PARAMS` and
:meth:`PlatformNavigatorParams.from_values`, the one mapping from a node's values to the core's
parameters.

The hand-off fields (site, drift and accelerometer-bias estimates, the misalignment to torque
out) carry the fine alignment's result when navigation runs as a second run chained through a
params file; one run with phases hands over with
:meth:`.platform_navigator.PlatformNavigator.hand_off` instead.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, fields

from gimbal_kinematics.params import CLOCK_JUMP_ALIASES, TIMING_PARAM, Param, ParameterError
from gimbal_kinematics.validate import finite, per_axis, positive

_DEG = math.pi / 180.0
_DEG_H = _DEG / 3600.0
_ARCSEC = _DEG / 3600.0
#: 1 µg [m/s²] (standard gravity, as the sensor models' µg).
_UG = 9.80665e-6
#: Where the platform azimuth comes from: the azimuth resolver (+ a fixed base heading) or the
#: servo's rotation angle φz (+ the platform's azimuth at φz = 0).
AZIMUTH_SOURCES = ("resolver", "servo")


@dataclass(frozen=True)
class PlatformNavigatorParams:
    """Navigator parameters (validated, immutable; SI through the properties).

    Site (hand-off position, a static base): ``lat_deg``, ``lon_deg`` [°] geodetic,
    ``height_m`` [m] above the ellipsoid (also the vertical channel's reference altitude);
    ``base_heading_deg`` [°]: added to the azimuth angle to give the platform azimuth about NED
    down: with ``azimuth_source`` ``resolver`` the (fixed) heading of the base, with ``servo``
    the platform's azimuth at φz = 0 (:mod:`.platform_navigator`, "Azimuth source").
    ``azimuth_source``: :data:`AZIMUTH_SOURCES`, the azimuth resolver angle θ_a or the
    servo's rotation angle φz (a moving base).

    Hand-off estimates: ``gyro_drift_deg_h`` (x, y, z) platform gyro drifts [°/h] in platform
    axes (the alignment's ε_x, ε_y; it does not estimate ε_z); ``north_drift_deg_h`` the
    alignment's ε_N [°/h] (fixed in NED); ``accel_bias_ug`` (x, y, z) [µg] subtracted from the
    specific force; ``misalignment_arcsec`` (δφE, δφN, δφU) [″] in the alignment's ENU
    convention, torqued out over ``torque_out_s`` [s] after the first sample.

    ``vertical_tau_s`` [s]: time constant of the triple pole of the damped vertical channel.
    ``clock_jump_s`` [s]: a stamp this far before the last one restarts navigation from the
    hand-off (a bag looping); smaller reversals and repeats are rejected and counted.
    """

    lat_deg: float = 40.0
    lon_deg: float = 0.0
    height_m: float = 0.0
    base_heading_deg: float = 0.0
    gyro_drift_deg_h: tuple[float, float, float] = (0.0, 0.0, 0.0)
    north_drift_deg_h: float = 0.0
    accel_bias_ug: tuple[float, float, float] = (0.0, 0.0, 0.0)
    misalignment_arcsec: tuple[float, float, float] = (0.0, 0.0, 0.0)
    torque_out_s: float = 10.0
    vertical_tau_s: float = 100.0
    clock_jump_s: float = 1.0
    azimuth_source: str = "resolver"

    def __post_init__(self) -> None:
        lat = finite("lat_deg", self.lat_deg)
        if abs(lat) >= 89.0:
            raise ValueError(f"lat_deg must be within (-89, 89) (tan L of the transport rate), got {lat}")
        finite("lon_deg", self.lon_deg)
        finite("height_m", self.height_m)
        finite("base_heading_deg", self.base_heading_deg)
        finite("north_drift_deg_h", self.north_drift_deg_h)
        for name in ("gyro_drift_deg_h", "accel_bias_ug", "misalignment_arcsec"):
            object.__setattr__(self, name, per_axis(name, getattr(self, name), 3))
        for name in ("torque_out_s", "vertical_tau_s", "clock_jump_s"):
            positive(name, getattr(self, name))
        if self.azimuth_source not in AZIMUTH_SOURCES:
            raise ValueError(f"azimuth_source must be one of {AZIMUTH_SOURCES}, got {self.azimuth_source!r}")

    @classmethod
    def field_names(cls) -> tuple[str, ...]:
        return tuple(f.name for f in fields(cls))

    @classmethod
    def from_values(cls, values: dict) -> PlatformNavigatorParams:
        """The parameters from a ``platform_navigator`` node's values (name -> value, as
        declared in :data:`PARAMS`); :class:`ParameterError` names the parameter refused."""
        try:
            return cls(**{name: values[name] for name in cls.field_names()})
        except ValueError as exc:
            raise ParameterError(f"parameter {exc}") from exc

    # -- SI views ------------------------------------------------------------------------
    @property
    def lat_rad(self) -> float:
        return self.lat_deg * _DEG

    @property
    def lon_rad(self) -> float:
        return self.lon_deg * _DEG

    @property
    def base_heading_rad(self) -> float:
        return self.base_heading_deg * _DEG

    @property
    def gyro_drift_rad_s(self) -> tuple[float, float, float]:
        return tuple(v * _DEG_H for v in self.gyro_drift_deg_h)  # type: ignore[return-value]

    @property
    def north_drift_rad_s(self) -> float:
        return self.north_drift_deg_h * _DEG_H

    @property
    def accel_bias_m_s2(self) -> tuple[float, float, float]:
        return tuple(v * _UG for v in self.accel_bias_ug)  # type: ignore[return-value]

    @property
    def misalignment_enu_rad(self) -> tuple[float, float, float]:
        return tuple(v * _ARCSEC for v in self.misalignment_arcsec)  # type: ignore[return-value]


DESCRIPTION = (
    "Paper 3 local-level platform INS navigator: resolves the stable element's accelerometers through the "
    "azimuth rotation angle into NED, adds WGS-84 normal gravity, removes the Coriolis terms and integrates "
    "velocity and position (latitude, longitude; height damped by a reference altitude). Publishes the fix, "
    "the NED velocity and the platform command rate (earth rate + transport rate - drift compensation, "
    "resolved in NED) that closes the Schuler loop through the platform servo."
)

_D = PlatformNavigatorParams()
PARAMS = (
    TIMING_PARAM,
    Param("lat_deg", _D.lat_deg, "hand-off latitude, geodetic [deg]", -88.999, 88.999),
    Param("lon_deg", _D.lon_deg, "hand-off longitude [deg]", -360.0, 360.0),
    Param("height_m", _D.height_m, "hand-off height above the ellipsoid, also the vertical channel's "
          "reference altitude [m]", -1e4, 1e5),
    Param("base_heading_deg", _D.base_heading_deg, "added to the azimuth angle: the heading of the base "
          "(azimuth_source resolver) or the platform's azimuth at phi_z = 0 (servo) [deg]", -360.0, 360.0),
    Param("azimuth_source", _D.azimuth_source, "platform azimuth from the azimuth resolver (joint_topic; "
          "static base) or from the servo's rotation angle phi_z (/platform_servo/modulation; a moving base, "
          "free timing only)", choices=AZIMUTH_SOURCES),
    Param("gyro_drift_deg_h", list(_D.gyro_drift_deg_h), "platform gyro drift estimate (x, y, z in platform "
          "axes) compensated in the command [deg/h]"),
    Param("north_drift_deg_h", _D.north_drift_deg_h, "north drift estimate (fixed in NED) compensated in the "
          "command [deg/h]", -1e3, 1e3),
    Param("accel_bias_ug", list(_D.accel_bias_ug), "accelerometer bias estimate (x, y, z in platform axes) "
          "subtracted from the specific force [micro-g]"),
    Param("misalignment_arcsec", list(_D.misalignment_arcsec), "misalignment at hand-off (dphiE, dphiN, "
          "dphiU; ENU as the alignment reports it), torqued out over torque_out_s [arcsec]"),
    Param("torque_out_s", _D.torque_out_s, "duration of the command-rate pulse that torques the "
          "misalignment out [s]", 1e-3, 1e4),
    Param("vertical_tau_s", _D.vertical_tau_s, "time constant of the damped vertical channel's triple "
          "pole [s]", 1.0, 1e5),
    Param("clock_jump_s", _D.clock_jump_s, "a stamp this far before the last one restarts navigation "
          "from the hand-off [s]", 1e-9, 1e9, aliases=CLOCK_JUMP_ALIASES),
    # the node's own parameters (platform_navigator_node), not the core's
    Param("sim_rate_hz", 1000.0, "lockstep rate [Hz], to turn stamps into steps", 1.0, 100000.0),
    Param("imu_rate_hz", 1000.0, "platform IMU rate [Hz]; divides sim_rate_hz", 1e-3, 100000.0),
    Param("joint_rate_hz", 1000.0, "rate of the azimuth joint topic [Hz]; divides sim_rate_hz", 1e-3, 100000.0),
    Param("joint_topic", "/platform/resolvers", "sensor_msgs/JointState topic carrying the azimuth joint "
          "(azimuth_source resolver)"),
    Param("azimuth_joint", "platform_azimuth", "name of the azimuth gimbal joint in joint_topic (azimuth_source "
          "resolver)"),
    Param("max_joint_age_s", 0.1, "largest gap [s] between an accelerometer sample and the azimuth joint sample "
          "extrapolated to it; older: the sample is refused as without a resolver angle", 1e-9, 1e9),
    Param("fix_every_samples", 1, "publish ~/fix and ~/velocity every N accepted samples (~/command_rate goes "
          "out every sample: the servo follows it)", 1, 10**9),
    Param("max_sync_wait_s", 0.05, "free timing: longest a sample waits for the other stream's stamp to pass "
          "it (stamp order) [s]", 0.0, 10.0),
    Param("diagnostics_period_s", 1.0, "free timing: counters on /diagnostics every this much stamp time [s]",
          1e-3, 1e6),
    Param("progress_every_steps", 10, "report on ~/progress (time of the next step needed) every N steps; "
          "vehicle_dynamics waits for and paces on it", 1, 10**6),
    Param("wait_for_subscribers", 0, "matched subscriptions each output needs before ~/progress reports ready",
          0, 1000),
    Param("odom_frame_id", "odom", "~/odom (nav_msgs/Odometry): frame of the pose, a local ENU frame whose origin is "
          "the first fix (REP 105: odom, continuous; map if this INS is your global reference)"),
    Param("odom_child_frame_id", "base_link", "~/odom: the child frame the twist is resolved in (REP 105 "
          "base_link, forward-left-up, level at the base heading)"),
    Param("odom_cep_rate_nmi_h", 0.38, "~/odom pose covariance: horizontal position error growth, CEP50 per hour "
          "of navigation [n mile/h] (paper 3 with rotation: 0.38)", 0.0, 1000.0),
    Param("odom_velocity_sigma_m_s", 0.6, "~/odom twist covariance: 1-sigma velocity error per axis [m/s] (paper 3's "
          "Schuler oscillation peaks at about 0.6 m/s over 3 h)", 0.0, 1000.0),
    Param("odom_vertical_sigma_m", 1.0, "~/odom pose covariance: 1-sigma height error [m], that of the reference "
          "height the vertical channel is held to", 0.0, 1e6),
    Param("odom_attitude_sigma_deg", 1.0 / 60.0, "~/odom pose covariance: 1-sigma roll, pitch and heading "
          "[deg] (the residual of a fine alignment, about 1 arcmin)", 0.0, 180.0),
)
