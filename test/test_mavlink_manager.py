"""The MAVLink gimbal manager client against a pymavlink device stub on loopback UDP: the
geo pointer's aim on a 20 m/s pass reaches the device as setpoints whose LOS is pymap3d's
direction to the target; LOS rates become the Euler rates a numerical derivative of scipy's
rotations gives back; the device's reports come back in the earth frame as the message
definition composes them. No ROS: the core and our UDP link, pymavlink on the other side."""
import math
import socket
import time

import numpy as np
import pytest
from pymavlink.dialects.v20 import common as mav
from scipy.spatial.transform import Rotation

from gimbal_sim.mavlink.link import UdpLink
from gimbal_sim.mavlink.manager_core import GimbalManagerClient, ManagerParams
from test_geo_pointer_moving import _C_nm_along, _angle, _los_ned, _pointer, _vehicle

NAN = math.nan
EARTH_LOCK = (mav.GIMBAL_DEVICE_FLAGS_ROLL_LOCK | mav.GIMBAL_DEVICE_FLAGS_PITCH_LOCK | mav.GIMBAL_DEVICE_FLAGS_YAW_LOCK
              | mav.GIMBAL_DEVICE_FLAGS_YAW_IN_EARTH_FRAME)


class DeviceStub:
    """A gimbal device as far as the test needs one: a loopback socket and pymavlink."""

    def __init__(self):
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.bind(("127.0.0.1", 0))
        self.sock.settimeout(2.0)
        self.address = self.sock.getsockname()
        self.mav = mav.MAVLink(None, srcSystem=1, srcComponent=154)

    def receive(self):
        data, sender = self.sock.recvfrom(65535)
        msgs = mav.MAVLink(None).parse_buffer(data)
        assert msgs and len(msgs) == 1 and msgs[0].get_type() != "BAD_DATA"
        return msgs[0], sender

    def send(self, msg, to) -> None:
        self.sock.sendto(bytes(msg.pack(self.mav)), to)


@pytest.fixture
def link_and_stub():
    stub = DeviceStub()
    link = UdpLink("127.0.0.1", 0, [stub.address])
    yield link, stub
    link.close()
    stub.sock.close()


def los_of(q_wxyz) -> np.ndarray:
    w, x, y, z = q_wxyz
    return Rotation.from_quat([x, y, z, w]).as_matrix()[:, 0]


@pytest.mark.parametrize("send_as", ["device", "manager_attitude", "manager_pitchyaw"])
def test_geo_pointer_aim_on_a_20_m_s_pass_is_pymap3d_direction_at_the_device(link_and_stub, send_as):
    link, stub = link_and_stub
    target_component = 1 if send_as.startswith("manager") else 154
    client = GimbalManagerClient(ManagerParams(target_component=target_component, send_as=send_as))
    pointer = _pointer(earth_rate=False, max_rate_rad_s=1.0)
    worst = 0.0
    for t in np.arange(0.0, 60.5, 2.0):  # closest approach (400 m) at 30 s
        llh, v_n = _vehicle(t)
        assert pointer.set_vehicle(llh, v_n)
        u = _los_ned(t)
        out = pointer.step(Rotation.from_matrix(_C_nm_along(u)).as_quat(), np.eye(3), 0.0)
        link.send(client.point(out.aim_n))
        msg, sender = stub.receive()
        assert sender == link.address and (msg.get_srcSystem(), msg.get_srcComponent()) == (1, 191)
        assert (msg.target_system, msg.target_component, msg.flags) == (1, target_component, EARTH_LOCK)
        if send_as == "manager_pitchyaw":
            assert msg.get_type() == "GIMBAL_MANAGER_SET_PITCHYAW" and math.isnan(msg.pitch_rate)
            los = np.array([math.cos(msg.pitch) * math.cos(msg.yaw), math.cos(msg.pitch) * math.sin(msg.yaw),
                            -math.sin(msg.pitch)])
        else:
            expected = "GIMBAL_DEVICE_SET_ATTITUDE" if send_as == "device" else "GIMBAL_MANAGER_SET_ATTITUDE"
            assert msg.get_type() == expected and math.isnan(msg.angular_velocity_z)
            los = los_of(msg.q)
        worst = max(worst, _angle(los, u))
    print(f"{send_as}: worst LOS error {worst * 1e3:.2e} mrad")
    assert worst < 1e-4  # 0.1 mrad; float32 on the wire leaves ~1e-7


def _report(q_xyzw, flags, delta_yaw=NAN, rates=(NAN, NAN, NAN), delta_rate=NAN):
    x, y, z, w = q_xyzw
    return mav.MAVLink_gimbal_device_attitude_status_message(0, 0, 1234, flags, [w, x, y, z], *rates, 0,
                                                             delta_yaw, delta_rate, 0)


def test_reports_come_back_in_the_earth_frame_and_rates_become_euler_rates(link_and_stub):
    link, stub = link_and_stub
    client = GimbalManagerClient()
    assert client.rate(0.01, 0.02) is None and client.counts["rates_without_attitude"] == 1
    roll, pitch, yaw_v, heading = 0.1, -0.3, 0.4, 1.2
    q_vehicle = Rotation.from_euler("ZYX", [yaw_v, pitch, roll])
    follow = mav.GIMBAL_DEVICE_FLAGS_PITCH_LOCK | mav.GIMBAL_DEVICE_FLAGS_YAW_IN_VEHICLE_FRAME
    link.send(client.heartbeat())
    _, manager_address = stub.receive()
    stub.send(_report(q_vehicle.as_quat(), follow, heading, (NAN, 0.01, 0.02), 0.03), manager_address)
    stub.send(_report(q_vehicle.as_quat(), follow), manager_address)  # no delta_yaw: earth frame unknown
    other = mav.MAVLink(None, srcSystem=1, srcComponent=155)  # another gimbal
    stub.sock.sendto(bytes(_report(q_vehicle.as_quat(), EARTH_LOCK).pack(other)), manager_address)
    reports = []
    for _ in range(200):
        for datagram in link.receive():
            reports += client.receive(datagram)
        if len(reports) == 2 and client.counts["other_reports"] == 1:
            break
        time.sleep(0.005)
    assert len(reports) == 2 and client.counts["vehicle_frame_only"] == 1
    earth = Rotation.from_euler("z", heading) * q_vehicle  # q_earth = q_delta_yaw * q_vehicle
    got = Rotation.from_quat(reports[0].quat_earth)
    assert (got.inv() * earth).magnitude() < 1e-6
    assert reports[0].euler_rates[1:] == pytest.approx((0.01, 0.05), abs=1e-7)
    assert reports[1].quat_earth is None and math.isnan(reports[1].euler_rates[2])
    client.last_report = reports[0]
    q_cmd, r_cmd = 0.02, -0.03
    msg = mav.MAVLink(None).parse_buffer(client.rate(q_cmd, r_cmd))[0]
    assert all(math.isnan(c) for c in msg.q) and math.isnan(msg.angular_velocity_x)
    # the body rate of the Euler-angle motion (roll held), by a central difference on scipy's rotations
    y0, p0, r0 = got.as_euler("ZYX")
    h = 1e-4

    def at(s: float) -> Rotation:
        return Rotation.from_euler("ZYX", [y0 + msg.angular_velocity_z * s, p0 + msg.angular_velocity_y * s, r0])

    omega = (at(-h).inv() * at(h)).as_rotvec() / (2 * h)
    assert omega[1:] == pytest.approx((q_cmd, r_cmd), abs=1e-8)
