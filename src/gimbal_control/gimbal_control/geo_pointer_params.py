"""The ``geo_pointer`` node's parameters and --help text, declared once in
:class:`GeoPointerNodeParams`. The mapping to the core's parameters is
:meth:`.geo_pointer.GeoPointerParams.from_values`.
"""
from __future__ import annotations

from dataclasses import dataclass

from gimbal_kinematics.params.table import TimedParams, declaration, param
from gimbal_kinematics.ros.input_kinds import InputKind


@dataclass(frozen=True)
class GeoPointerNodeParams(TimedParams):
    """Geo-pointing: keeps the LOS on a WGS-84 target (sensor_msgs/NavSatFix) from the INS attitude, the gyro-bias
    EKF's gimbal attitude and the encoders' turret angle, by publishing a LOS rate command (feed-forward of the
    target's inertial rate + k times the pointing error) on the LOS-rate controller's operator input; the
    vehicle at a fixed site or at its INS position and velocity (NavSatFix, Vector3Stamped); stops at the gimbal
    limits (counted); publishes the 1-sigma pointing-error budget.
    """

    sim_rate_hz: float = param(1000.0, "lockstep rate", 1.0, 100000.0, unit="Hz")
    ins_rate_hz: float = param(100.0, "INS and EKF attitude rate: the pointer steps at each INS sample",
        1e-3, 100000.0, unit="Hz")
    target_llh_deg: tuple[float, ...] = param((0.0, 0.0, 0.0), "target latitude, longitude and height above the "
        "WGS-84 ellipsoid; a NavSatFix on target_topic replaces it", unit="deg, deg, m")
    target_topic: str = param("~/target", "new targets (sensor_msgs/NavSatFix); '' = the parameter only")
    vehicle_llh_deg: tuple[float, ...] = param((0.0, 0.0, 0.0), "INS position of the vehicle (fixed site): latitude, "
        "longitude, height; with vehicle_fix_topic, the start-up check's position only", unit="deg, deg, m")
    vehicle_fix_topic: str = param("", "the vehicle's INS position (sensor_msgs/NavSatFix), used at each step "
        "instead of vehicle_llh_deg; '' = vehicle_llh_deg (a fixed site). Free timing only")
    vehicle_velocity_topic: str = param("", "the vehicle's velocity over the ground (geometry_msgs/Vector3Stamped, "
        "NED [m/s]) for the LOS-rate feed-forward; '' = none (zero). Needs vehicle_fix_topic")
    vehicle_fix_max_age_s: float = param(0.2, "a fix or velocity older than this at a step is stale: no command (the "
        "controller's dead-man stops the slew)", 1e-3, 10.0, unit="s")
    lever_arm_b_m: tuple[float, ...] = param((0.0, 0.0, 0.0), "gimbal pivot from the INS reference point, body frame",
        unit="m")
    gain_1_s: float = param(1.0, "pointing-error gain k (outer-loop bandwidth)", 1e-6, 1e3, unit="1/s")
    max_rate_deg_s: float = param(5.0, "rate command limit per axis (below the controller's operator_max_rate_deg_s, "
        "which refuses more)", 1e-6, 1e3, unit="deg/s")
    azimuth_min_deg: float = param(-180.0, "gimbal azimuth limit (relative to the turret)", -360.0, 360.0, unit="deg")
    azimuth_max_deg: float = param(180.0, "gimbal azimuth limit; a span of 360 is a continuous axis",
        -360.0, 360.0, unit="deg")
    elevation_min_deg: float = param(-90.0, "gimbal elevation limit", -90.0, 90.0, unit="deg")
    elevation_max_deg: float = param(90.0, "gimbal elevation limit", -90.0, 90.0, unit="deg")
    ins_attitude_sigma_deg: tuple[float, ...] = param((0.05, 0.05, 0.2), "budget: INS roll, pitch, heading 1-sigma "
        "(paper 1's INS)", unit="deg")
    vehicle_position_sigma_m: tuple[float, ...] = param((0.0, 0.0), "budget: INS position 1-sigma, horizontal (per "
        "axis) and vertical", unit="m")
    target_position_sigma_m: tuple[float, ...] = param((0.0, 0.0), "budget: target position 1-sigma, horizontal (per "
        "axis) and vertical", unit="m")
    earth_rate: bool = param(True, "feed forward the earth rate (the target is fixed to the earth; false: NED is "
        "inertial, as vehicle_dynamics' earth_rate false)")
    min_range_m: float = param(1.0, "a target nearer than this is refused (the vehicle's own position has no "
        "direction)", 1e-3, 1e7, unit="m")
    operator_topic: str = param("/operator/los_rate", "where the rate command goes: the LOS-rate controller's "
        "operator input (geometry_msgs/Vector3Stamped, sight frame, rad/s, y = q, z = r)")
    attitude_topic: str = param("/gyro_bias_ekf/attitude", "gimbal attitude estimate C(n,m) (sensor_msgs/Imu)")
    diagnostics_period_s: float = param(1.0, "/diagnostics with the counters every this much stamp time",
        1e-3, 3600.0, unit="s")


PARAMS, DESCRIPTION = declaration(GeoPointerNodeParams)


def vehicle_inputs(values: dict) -> tuple[str, ...]:
    """The vehicle's inputs the parameters ask for; ValueError naming the parameter when they
    cannot be had (a velocity without a position, or either in lockstep)."""
    inputs = tuple(kind for kind, name in ((InputKind.FIX, "vehicle_fix_topic"),
                                           (InputKind.VELOCITY, "vehicle_velocity_topic")) if values[name])
    if InputKind.VELOCITY in inputs and InputKind.FIX not in inputs:
        raise ValueError("parameter vehicle_velocity_topic needs vehicle_fix_topic (a moving vehicle's position)")
    if inputs and values["timing"] == "lockstep":
        raise ValueError("parameter vehicle_fix_topic: free timing only (a lockstep step cannot wait for a "
                         "position no simulated INS publishes)")
    return inputs
