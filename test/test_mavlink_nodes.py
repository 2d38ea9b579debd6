"""The MAVLink nodes' start-up: each refuses a bad parameter with exit 2 and one line naming
it, before it touches the network (the mains run in this process, on the test's own ROS
domain)."""
import socket

import pytest

from gimbal_sim.mavlink import mavlink_gimbal_device_node as device_node
from gimbal_sim.mavlink import mavlink_gimbal_manager_node as manager_node

CASES = [
    (device_node, {"timing": "lockstep"}, "timing"),
    (device_node, {"bind_address": "localhost"}, "bind_address"),
    (device_node, {"peers": "['127.0.0.1']"}, "peers"),
    (device_node, {"pitch_min_deg": "86.0"}, "pitch_min_deg"),
    (device_node, {"autopilot_timeout_s": "0.0"}, "autopilot_timeout_s"),
    (manager_node, {"rate_topic": "/operator/los_rate"}, "rate_topic"),
    (manager_node, {"send_as": "carrier_pigeon"}, "send_as"),
    (manager_node, {"peers": "['127.0.0.1:99999']"}, "peers"),
]


@pytest.mark.parametrize("module, params, word", CASES, ids=[f"{c[0].__name__.split('.')[-1]}-{c[2]}"
                                                            for c in CASES])
def test_a_bad_parameter_is_refused_naming_it(module, params, word, capfd, monkeypatch, ros_domain_env):
    for key, value in ros_domain_env.items():
        monkeypatch.setenv(key, value)
    argv = ["node", "--ros-args"] + [a for k, v in params.items() for a in ("-p", f"{k}:={v}")]
    assert module.main(argv) == 2
    out, err = capfd.readouterr()
    assert word in out + err and "Traceback" not in out + err, out + err


def test_a_port_in_use_is_refused_naming_it(capfd, monkeypatch, ros_domain_env):
    for key, value in ros_domain_env.items():
        monkeypatch.setenv(key, value)
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as taken:
        taken.bind(("127.0.0.1", 0))
        port = taken.getsockname()[1]
        assert device_node.main(["node", "--ros-args", "-p", f"port:={port}"]) == 2
    out, err = capfd.readouterr()
    assert f"udp:127.0.0.1:{port}" in out + err and "port" in out + err, out + err


def test_the_manager_node_sends_the_aim_and_publishes_the_reported_attitude(ros_domain_env):
    """In this process: a plain rclpy publisher gives the aim, a pymavlink stub is the device
    (its setpoint parsed by pymavlink, its status packed by it), a plain subscription reads
    ~/attitude."""
    import math

    import numpy as np
    from geometry_msgs.msg import Vector3Stamped
    from pymavlink.dialects.v20 import common as mav
    from rclpy.parameter import Parameter
    from scipy.spatial.transform import Rotation
    from sensor_msgs.msg import Imu

    from ros_harness import harness_node, spin_until
    from test_mavlink_manager import DeviceStub, los_of

    stub = DeviceStub()
    stub.sock.settimeout(0.0)
    with harness_node(int(ros_domain_env["ROS_DOMAIN_ID"])) as (node, executor):
        manager = manager_node.MavlinkGimbalManagerNode(
            context=node.context, parameter_overrides=[Parameter("peers", value=[f"127.0.0.1:{stub.address[1]}"])])
        executor.add_node(manager)
        pub = node.create_publisher(Vector3Stamped, "/geo_pointer/aim", 10)
        got = []
        node.create_subscription(Imu, "/mavlink_gimbal_manager/attitude", got.append, 10)
        aim = np.array([0.6, 0.7, -0.2]) / np.linalg.norm([0.6, 0.7, -0.2])
        setpoints = []

        def exchange() -> bool:
            msg = Vector3Stamped()
            msg.vector.x, msg.vector.y, msg.vector.z = aim
            pub.publish(msg)
            try:
                data, sender = stub.sock.recvfrom(65535)
            except BlockingIOError:
                return bool(got)
            for m in mav.MAVLink(None).parse_buffer(data) or []:
                if m.get_type() == "GIMBAL_DEVICE_SET_ATTITUDE":
                    setpoints.append(m)
                    x, y, z, w = Rotation.from_euler("ZYX", [1.0, -0.2, 0.05]).as_quat()
                    stub.send(mav.MAVLink_gimbal_device_attitude_status_message(
                        0, 0, 10, 0x48, [w, x, y, z], math.nan, 0.01, 0.02, 0, math.nan, math.nan, 0), sender)
            return bool(got)

        try:
            assert spin_until(executor, exchange, 30.0), "no setpoint or no ~/attitude"
        finally:
            executor.remove_node(manager)
            manager.destroy_node()
            stub.sock.close()
    assert np.allclose(los_of(setpoints[0].q), aim, atol=1e-6)
    o = got[0].orientation
    expected = Rotation.from_euler("ZYX", [1.0, -0.2, 0.05])
    assert (Rotation.from_quat([o.x, o.y, o.z, o.w]).inv() * expected).magnitude() < 1e-6
    assert got[0].header.frame_id == "map_ned" and got[0].angular_velocity_covariance[0] == -1.0  # no roll rate
