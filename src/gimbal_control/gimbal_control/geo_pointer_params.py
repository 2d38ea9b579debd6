"""The ``geo_pointer`` node's parameter table and --help text, readable without ROS (the
node declares them; the scenario checks read them). The mapping to the core's parameters is
:meth:`.geo_pointer.GeoPointerParams.from_values`."""
from __future__ import annotations

from gimbal_kinematics.params import TIMING_PARAM, Param

DESCRIPTION = (
    "Geo-pointing: keeps the LOS on a WGS-84 target (sensor_msgs/NavSatFix) from the INS attitude, the "
    "gyro-bias EKF's gimbal attitude and the encoders' turret angle, by publishing a LOS rate command "
    "(feed-forward of the target's inertial rate + k times the pointing error) on the LOS-rate controller's "
    "operator input; the vehicle at a fixed site or at its INS position and velocity (NavSatFix, "
    "Vector3Stamped); stops at the gimbal limits (counted); publishes the 1-sigma pointing-error budget."
)
PARAMS = (
    TIMING_PARAM,
    Param("sim_rate_hz", 1000.0, "lockstep rate [Hz]", 1.0, 100000.0),
    Param("ins_rate_hz", 100.0, "INS and EKF attitude rate [Hz]: the pointer steps at each INS sample", 1e-3,
          100000.0),
    Param("target_llh_deg", [0.0, 0.0, 0.0], "target latitude, longitude [deg] and height above the WGS-84 "
          "ellipsoid [m]; a NavSatFix on target_topic replaces it"),
    Param("target_topic", "~/target", "new targets (sensor_msgs/NavSatFix); '' = the parameter only"),
    Param("vehicle_llh_deg", [0.0, 0.0, 0.0], "INS position of the vehicle (fixed site): latitude, longitude "
          "[deg], height [m]; with vehicle_fix_topic, the start-up check's position only"),
    Param("vehicle_fix_topic", "", "the vehicle's INS position (sensor_msgs/NavSatFix), used at each step instead "
          "of vehicle_llh_deg; '' = vehicle_llh_deg (a fixed site). Free timing only"),
    Param("vehicle_velocity_topic", "", "the vehicle's velocity over the ground (geometry_msgs/Vector3Stamped, NED "
          "[m/s]) for the LOS-rate feed-forward; '' = none (zero). Needs vehicle_fix_topic"),
    Param("vehicle_fix_max_age_s", 0.2, "a fix or velocity older than this at a step is stale: no command (the "
          "controller's dead-man stops the slew) [s]", 1e-3, 10.0),
    Param("lever_arm_b_m", [0.0, 0.0, 0.0], "gimbal pivot from the INS reference point, body frame [m]"),
    Param("gain_1_s", 1.0, "pointing-error gain k (outer-loop bandwidth) [1/s]", 1e-6, 1e3),
    Param("max_rate_deg_s", 5.0, "rate command limit per axis [deg/s] (below the controller's "
          "operator_max_rate_deg_s, which refuses more)", 1e-6, 1e3),
    Param("azimuth_min_deg", -180.0, "gimbal azimuth limit (relative to the turret) [deg]", -360.0, 360.0),
    Param("azimuth_max_deg", 180.0, "gimbal azimuth limit [deg]; a span of 360 is a continuous axis", -360.0, 360.0),
    Param("elevation_min_deg", -90.0, "gimbal elevation limit [deg]", -90.0, 90.0),
    Param("elevation_max_deg", 90.0, "gimbal elevation limit [deg]", -90.0, 90.0),
    Param("ins_attitude_sigma_deg", [0.05, 0.05, 0.2], "budget: INS roll, pitch, heading 1-sigma [deg] "
          "(paper 1's INS)"),
    Param("vehicle_position_sigma_m", [0.0, 0.0], "budget: INS position 1-sigma, horizontal (per axis) and "
          "vertical [m]"),
    Param("target_position_sigma_m", [0.0, 0.0], "budget: target position 1-sigma, horizontal (per axis) and "
          "vertical [m]"),
    Param("earth_rate", True, "feed forward the earth rate (the target is fixed to the earth; false: NED is "
          "inertial, as vehicle_dynamics' earth_rate false)"),
    Param("min_range_m", 1.0, "a target nearer than this is refused (the vehicle's own position has no direction) "
          "[m]", 1e-3, 1e7),
    Param("operator_topic", "/operator/los_rate", "where the rate command goes: the LOS-rate controller's operator "
          "input (geometry_msgs/Vector3Stamped, sight frame, rad/s, y = q, z = r)"),
    Param("attitude_topic", "/gyro_bias_ekf/attitude", "gimbal attitude estimate C(n,m) (sensor_msgs/Imu)"),
    Param("diagnostics_period_s", 1.0, "/diagnostics with the counters every this much stamp time [s]", 1e-3, 3600.0),
)
