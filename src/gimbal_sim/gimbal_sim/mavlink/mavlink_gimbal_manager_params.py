"""The ``mavlink_gimbal_manager`` node's parameters and --help text, declared once in
:class:`MavlinkGimbalManagerNodeParams`. The mapping to the core's parameters is
:meth:`.manager_core.ManagerParams.from_values`.
"""
from __future__ import annotations

from dataclasses import dataclass

from gimbal_kinematics.params.table import declaration, param


@dataclass(frozen=True)
class MavlinkGimbalManagerNodeParams:
    """MAVLink Gimbal Protocol v2 manager client over UDP: sends geo_pointer's aim (a LOS direction) or an operator
    LOS rate as GIMBAL_DEVICE_SET_ATTITUDE to a gimbal device, or as GIMBAL_MANAGER_SET_ATTITUDE /
    GIMBAL_MANAGER_SET_PITCHYAW to a gimbal manager (an autopilot), in the earth frame; publishes the gimbal's
    GIMBAL_DEVICE_ATTITUDE_STATUS as sensor_msgs/Imu (~/attitude, orientation C(n,m) in NED). Binds 127.0.0.1
    unless told otherwise.
    """

    bind_address: str = param("127.0.0.1", "IPv4 address the UDP socket binds (loopback by default)")
    port: int = param(0, "UDP port the node binds (0: any free port, logged)", 0, 65535)
    peers: tuple[str, ...] = param(("127.0.0.1:14580",), "host:port of the gimbal device or the autopilot (the node "
        "also answers every address it hears from)")
    system_id: int = param(1, "our MAVLink system id (the vehicle's)", 1, 255)
    component_id: int = param(191, "our MAVLink component id (MAV_COMP_ID_ONBOARD_COMPUTER = 191)", 1, 255)
    target_system: int = param(1, "the gimbal's system id", 1, 255)
    target_component: int = param(154, "where setpoints go: the gimbal device (MAV_COMP_ID_GIMBAL = 154) or the "
        "autopilot's gimbal manager (1)", 1, 255)
    device_component_id: int = param(154, "the component whose GIMBAL_DEVICE_ATTITUDE_STATUS is published", 1, 255)
    send_as: str = param("device", "device: GIMBAL_DEVICE_SET_ATTITUDE; manager_attitude: "
        "GIMBAL_MANAGER_SET_ATTITUDE; manager_pitchyaw: GIMBAL_MANAGER_SET_PITCHYAW",
        choices=("device", "manager_attitude",
                                                                    "manager_pitchyaw"))
    gimbal_device_id: int = param(0, "manager messages: which of the manager's gimbals (0: all)", 0, 255)
    aim_topic: str = param("/geo_pointer/aim", "LOS direction to point at (geometry_msgs/Vector3Stamped, NED, "
        "geo_pointer's ~/aim); '' = off")
    rate_topic: str = param("", "LOS rate command (geometry_msgs/Vector3Stamped, sight frame, rad/s, y = q, z = r: "
        "the operator input's form); '' = off. Not together with aim_topic")
    max_send_rate_hz: float = param(50.0, "setpoints are sent at most this often (wall clock); the newest wins",
        0.1, 1000.0, unit="Hz")
    attitude_sigma_deg: float = param(0.0, "1-sigma of the reported attitude per axis, the orientation covariance of "
        "~/attitude; 0: unknown (all-zero covariance)", 0.0, 180.0, unit="deg")


PARAMS, DESCRIPTION = declaration(MavlinkGimbalManagerNodeParams)
