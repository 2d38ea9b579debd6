"""The ``mavlink_gimbal_device`` node's parameters and --help text, declared once in
:class:`MavlinkGimbalDeviceNodeParams`. The mapping to the core's parameters is
:meth:`.device_core.DeviceParams.from_values`.
"""
from __future__ import annotations

from dataclasses import dataclass

from gimbal_kinematics.params.table import TimedParams, declaration, param


@dataclass(frozen=True)
class MavlinkGimbalDeviceNodeParams(TimedParams):
    """MAVLink Gimbal Protocol v2 device over UDP: presents the simulated two-axis gimbal to a ground station or an
    autopilot (HEARTBEAT as MAV_TYPE_GIMBAL, GIMBAL_DEVICE_INFORMATION on request, GIMBAL_DEVICE_ATTITUDE_STATUS
    at status_rate_hz), takes GIMBAL_DEVICE_SET_ATTITUDE (angles and/or rates, NaN = ignore, yaw lock / follow)
    and AUTOPILOT_STATE_FOR_GIMBAL_DEVICE (earth-frame yaw while it is fresh), and drives the LOS-rate
    controller's operator input from the EKF attitude estimate. Free timing only: it runs against the wall
    clock. Binds 127.0.0.1 unless told otherwise.
    """

    bind_address: str = param("127.0.0.1", "IPv4 address the UDP socket binds (loopback by default; 0.0.0.0 exposes "
        "the device to the network)")
    port: int = param(14580, "UDP port the device listens on (0: any free port, logged); it answers every address it "
        "hears from", 0, 65535)
    peers: tuple[str, ...] = param((), "host:port addresses the device also sends to unasked, e.g. 127.0.0.1:14550 "
        "where QGroundControl listens; empty: only those it hears from", array_type="string_array")
    system_id: int = param(1, "MAVLink system id (the vehicle's)", 1, 255)
    component_id: int = param(154, "MAVLink component id (MAV_COMP_ID_GIMBAL = 154)", 1, 255)
    status_rate_hz: float = param(10.0, "GIMBAL_DEVICE_ATTITUDE_STATUS rate (wall clock)", 0.1, 200.0, unit="Hz")
    gain_1_s: float = param(2.0, "pointing loop gain k (bandwidth)", 1e-3, 100.0, unit="1/s")
    max_rate_deg_s: float = param(8.0, "LOS rate command limit per axis (below los_rate_controller's "
        "operator_max_rate_deg_s, which refuses more); a setpoint rate above it is refused", 1e-3, 1e3, unit="deg/s")
    pitch_min_deg: float = param(-85.0, "lowest pitch the device points at (reported as its pitch limit)",
        -89.9, 89.9, unit="deg")
    pitch_max_deg: float = param(85.0, "highest pitch the device points at", -89.9, 89.9, unit="deg")
    autopilot_timeout_s: float = param(1.0, "AUTOPILOT_STATE_FOR_GIMBAL_DEVICE older than this: earth-frame yaw lock "
        "dropped (wall clock)", 0.01, 60.0, unit="s")
    attitude_topic: str = param("/gyro_bias_ekf/attitude", "the gimbal attitude estimate C(n,m) (sensor_msgs/Imu): "
        "the device steps on each")
    operator_topic: str = param("/operator/los_rate", "where the LOS rate command goes: the LOS-rate controller's "
        "operator input (geometry_msgs/Vector3Stamped, sight frame, rad/s, y = q, z = r)")
    max_input_age_s: float = param(0.1, "the encoder and gyro samples may be this much older than the attitude "
        "estimate; older: no command (the controller's dead-man stops the slew)", 1e-3, 10.0, unit="s")
    ins_rate_hz: float = param(100.0, "the attitude estimate's nominal rate (drop counts)", 1e-3, 100000.0, unit="Hz")
    diagnostics_period_s: float = param(1.0, "/diagnostics with the counters every this much stamp time",
        1e-3, 3600.0, unit="s")


PARAMS, DESCRIPTION = declaration(MavlinkGimbalDeviceNodeParams)
