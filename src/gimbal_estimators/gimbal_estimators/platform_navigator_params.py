"""Parameters of the platform INS navigator (:mod:`.platform_navigator`), readable without ROS:
the core's frozen :class:`PlatformNavigatorParams` (engineering units at this edge, SI
properties for the core) and the node's own :class:`PlatformNavigatorNodeParams` (its docstring
is the node's --help text), declared once: they give the ``platform_navigator`` parameter table :data:`PARAMS`; and
:meth:`PlatformNavigatorParams.from_values`, the one mapping from a node's values to the core's
parameters.

The hand-off fields (site, drift and accelerometer-bias estimates, the misalignment to torque
out) carry the fine alignment's result when navigation runs as a second run chained through a
params file; one run with phases hands over with
:meth:`.platform_navigator.PlatformNavigator.hand_off` instead.
"""
from __future__ import annotations

from dataclasses import dataclass

from gimbal_kinematics.params.table import (
    CLOCK_JUMP_ALIASES, SHARED, TimedParams, declaration, from_values, param, same_as,
)
from gimbal_kinematics.maths.validate import finite, per_axis, positive

#: Where the platform azimuth comes from: the azimuth resolver (+ a fixed base heading) or the
#: servo's rotation angle φz (+ the platform's azimuth at φz = 0).
AZIMUTH_SOURCES = ("resolver", "servo")


@dataclass(frozen=True)
class PlatformNavigatorParams:
    """Navigator parameters (validated, immutable; SI through the properties), each a node
    parameter of the same name.

    The site is the hand-off position on a static base. ``base_heading_deg`` gives the
    platform azimuth about NED down (:mod:`.platform_navigator`, "Azimuth source"). The
    hand-off estimates are the alignment's: the platform gyro drifts ε_x, ε_y (it does not
    estimate ε_z), ε_N fixed in NED, the accelerometer biases and the misalignment in its ENU
    convention, torqued out after the first sample.
    """

    lat_deg: float = param(40.0, "hand-off latitude, geodetic", -88.999, 88.999, unit="deg")
    lon_deg: float = param(0.0, "hand-off longitude", -360.0, 360.0, unit="deg")
    height_m: float = param(0.0, "hand-off height above the ellipsoid, also the vertical channel's reference "
                            "altitude", -1e4, 1e5, unit="m")
    base_heading_deg: float = param(0.0, "added to the azimuth angle: the heading of the base (azimuth_source "
                                    "resolver) or the platform's azimuth at phi_z = 0 (servo)", -360.0, 360.0,
                                    unit="deg")
    azimuth_source: str = param("resolver", "platform azimuth from the azimuth resolver (joint_topic; static base) "
                                "or from the servo's rotation angle phi_z (a moving base: free timing "
                                "/platform_servo/modulation; lockstep /platform_servo/modulation_next, the servo "
                                "with modulation_next true)", choices=AZIMUTH_SOURCES)
    gyro_drift_deg_h: tuple[float, float, float] = param((0.0, 0.0, 0.0), "platform gyro drift estimate (x, y, z in "
                                                         "platform axes) compensated in the command", unit="deg/h")
    north_drift_deg_h: float = param(0.0, "north drift estimate (fixed in NED) compensated in the command",
                                     -1e3, 1e3, unit="deg/h")
    accel_bias_ug: tuple[float, float, float] = param((0.0, 0.0, 0.0), "accelerometer bias estimate (x, y, z in "
                                                      "platform axes) subtracted from the specific force",
                                                      unit="micro-g")
    misalignment_arcsec: tuple[float, float, float] = param((0.0, 0.0, 0.0), "misalignment at hand-off (dphiE, "
                                                            "dphiN, dphiU; ENU as the alignment reports it), "
                                                            "torqued out over torque_out_s", unit="arcsec")
    torque_out_s: float = param(10.0, "duration of the command-rate pulse that torques the misalignment out",
                                1e-3, 1e4, unit="s")
    vertical_tau_s: float = param(100.0, "time constant of the damped vertical channel's triple pole", 1.0, 1e5,
                                  unit="s")

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
        for name in ("torque_out_s", "vertical_tau_s"):
            positive(name, getattr(self, name))
        if self.azimuth_source not in AZIMUTH_SOURCES:
            raise ValueError(f"azimuth_source must be one of {AZIMUTH_SOURCES}, got {self.azimuth_source!r}")

    @classmethod
    def from_values(cls, values: dict) -> PlatformNavigatorParams:
        """The parameters from a ``platform_navigator`` node's values (name -> value, as
        declared in :data:`PARAMS`); :class:`ParameterError` names the parameter refused."""
        return from_values(cls, values)


@dataclass(frozen=True)
class PlatformNavigatorNodeParams(TimedParams):
    """Paper 3 local-level platform INS navigator: resolves the stable element's accelerometers through the azimuth
    rotation angle into NED, adds WGS-84 normal gravity, removes the Coriolis terms and integrates velocity and
    position (latitude, longitude; height damped by a reference altitude). Publishes the fix, the NED velocity
    and the platform command rate (earth rate + transport rate - drift compensation, resolved in NED) that
    closes the Schuler loop through the platform servo.
    """

    sim_rate_hz: float = param(1000.0, "lockstep rate, to turn stamps into steps", 1.0, 100000.0, unit="Hz")
    imu_rate_hz: float = param(1000.0, "platform IMU rate; divides sim_rate_hz", 1e-3, 100000.0, unit="Hz")
    joint_rate_hz: float = param(1000.0, "rate of the azimuth joint topic; divides sim_rate_hz", 1e-3, 100000.0,
                                 unit="Hz")
    joint_topic: str = param("/platform/resolvers", "sensor_msgs/JointState topic carrying the azimuth joint "
                             "(azimuth_source resolver)")
    azimuth_joint: str = param("platform_azimuth", "name of the azimuth gimbal joint in joint_topic (azimuth_source "
                               "resolver)")
    max_joint_age_s: float = param(0.1, "largest gap between an accelerometer sample and the azimuth joint sample "
                                   "extrapolated to it; older: the sample is refused as without a resolver angle",
                                   1e-9, 1e9, unit="s")
    fix_every_samples: int = param(1, "publish ~/fix and ~/velocity every N accepted samples (~/command_rate goes "
                                   "out every sample: the servo follows it)", 1, 10**9)
    max_sync_wait_s: float = param(0.05, "free timing: longest a sample waits for the other stream's stamp to pass "
                                   "it (stamp order)", 0.0, 10.0, unit="s")
    clock_jump_s: float = param(1.0, "a stamp this far before the last one restarts navigation from the hand-off",
                                1e-9, 1e9, unit="s", aliases=CLOCK_JUMP_ALIASES)
    diagnostics_period_s: float = param(1.0, "free timing: counters on /diagnostics every this much stamp time",
                                        1e-3, 1e6, unit="s")
    progress_every_steps: int = same_as(SHARED["progress_every_steps"])
    wait_for_subscribers: int = same_as(SHARED["wait_for_subscribers"])
    odom_frame_id: str = param("odom", "~/odom (nav_msgs/Odometry): frame of the pose, a local ENU frame whose "
                               "origin is the first fix (REP 105: odom, continuous; map if this INS is your global "
                               "reference)")
    odom_child_frame_id: str = param("base_link", "~/odom: the child frame the twist is resolved in (REP 105 "
                                     "base_link, forward-left-up, level at the base heading)")
    odom_cep_rate_nmi_h: float = param(0.38, "~/odom pose covariance: horizontal position error growth, CEP50 per "
                                       "hour of navigation (paper 3 with rotation: 0.38)", 0.0, 1000.0,
                                       unit="n mile/h")
    odom_velocity_sigma_m_s: float = param(0.6, "~/odom twist covariance: 1-sigma velocity error per axis (paper "
                                           "3's Schuler oscillation peaks at about 0.6 m/s over 3 h)", 0.0, 1000.0,
                                           unit="m/s")
    odom_vertical_sigma_m: float = param(1.0, "~/odom pose covariance: 1-sigma height error, that of the reference "
                                         "height the vertical channel is held to", 0.0, 1e6, unit="m")
    odom_attitude_sigma_deg: float = param(1.0 / 60.0, "~/odom pose covariance: 1-sigma roll, pitch and heading "
                                           "(the residual of a fine alignment, about 1 arcmin)", 0.0, 180.0,
                                           unit="deg")


PARAMS, DESCRIPTION = declaration(PlatformNavigatorNodeParams, PlatformNavigatorParams)
