"""The ``mavlink_gimbal_device`` node's parameter table and --help text, readable without
ROS (the node declares them; the config generator and the scenario checks read them). The
mapping to the core's parameters is :meth:`.device_core.DeviceParams.from_values`."""
from __future__ import annotations

from gimbal_kinematics.params import TIMING_PARAM, Param

DESCRIPTION = (
    "MAVLink Gimbal Protocol v2 device over UDP: presents the simulated two-axis gimbal to a ground station or "
    "an autopilot (HEARTBEAT as MAV_TYPE_GIMBAL, GIMBAL_DEVICE_INFORMATION on request, "
    "GIMBAL_DEVICE_ATTITUDE_STATUS at status_rate_hz), takes GIMBAL_DEVICE_SET_ATTITUDE (angles and/or rates, "
    "NaN = ignore, yaw lock / follow) and AUTOPILOT_STATE_FOR_GIMBAL_DEVICE (earth-frame yaw while it is fresh), "
    "and drives the LOS-rate controller's operator input from the EKF attitude estimate. Free timing only: it "
    "runs against the wall clock. Binds 127.0.0.1 unless told otherwise."
)
PARAMS = (
    TIMING_PARAM,
    Param("bind_address", "127.0.0.1", "IPv4 address the UDP socket binds (loopback by default; 0.0.0.0 exposes "
          "the device to the network)"),
    Param("port", 14580, "UDP port the device listens on (0: any free port, logged); it answers every address "
          "it hears from", 0, 65535),
    Param("peers", [], "host:port addresses the device also sends to unasked, e.g. 127.0.0.1:14550 where "
          "QGroundControl listens; empty: only those it hears from", array_type="string_array"),
    Param("system_id", 1, "MAVLink system id (the vehicle's)", 1, 255),
    Param("component_id", 154, "MAVLink component id (MAV_COMP_ID_GIMBAL = 154)", 1, 255),
    Param("status_rate_hz", 10.0, "GIMBAL_DEVICE_ATTITUDE_STATUS rate [Hz] (wall clock)", 0.1, 200.0),
    Param("gain_1_s", 2.0, "pointing loop gain k (bandwidth) [1/s]", 1e-3, 100.0),
    Param("max_rate_deg_s", 8.0, "LOS rate command limit per axis [deg/s] (below los_rate_controller's "
          "operator_max_rate_deg_s, which refuses more); a setpoint rate above it is refused", 1e-3, 1e3),
    Param("pitch_min_deg", -85.0, "lowest pitch the device points at [deg] (reported as its pitch limit)",
          -89.9, 89.9),
    Param("pitch_max_deg", 85.0, "highest pitch the device points at [deg]", -89.9, 89.9),
    Param("autopilot_timeout_s", 1.0, "AUTOPILOT_STATE_FOR_GIMBAL_DEVICE older than this: earth-frame yaw lock "
          "dropped [s] (wall clock)", 0.01, 60.0),
    Param("attitude_topic", "/gyro_bias_ekf/attitude", "the gimbal attitude estimate C(n,m) (sensor_msgs/Imu): the "
          "device steps on each"),
    Param("operator_topic", "/operator/los_rate", "where the LOS rate command goes: the LOS-rate controller's "
          "operator input (geometry_msgs/Vector3Stamped, sight frame, rad/s, y = q, z = r)"),
    Param("max_input_age_s", 0.1, "the encoder and gyro samples may be this much older than the attitude "
          "estimate [s]; older: no command (the controller's dead-man stops the slew)", 1e-3, 10.0),
    Param("ins_rate_hz", 100.0, "the attitude estimate's nominal rate [Hz] (drop counts)", 1e-3, 100000.0),
    Param("diagnostics_period_s", 1.0, "/diagnostics with the counters every this much stamp time [s]", 1e-3, 3600.0),
)
