"""The MAVLink gimbal device's core without ROS or sockets: pymavlink, whose codec we did not
write, plays the autopilot (it packs every datagram the core takes and parses every one it
sends); the gimbal is an ideal rate loop (the sight turns at the commanded inertial LOS rate,
scipy's rotations integrating it), so the pointing law is checked against closed forms."""
import math

import numpy as np
import pytest
from pymavlink.dialects.v20 import common as mav
from scipy.spatial.transform import Rotation

from gimbal_sim.mavlink.device_core import DeviceParams, GimbalDevice

DEG = math.pi / 180.0
NAN = math.nan
DT = 0.01
EARTH_LOCK = (mav.GIMBAL_DEVICE_FLAGS_ROLL_LOCK | mav.GIMBAL_DEVICE_FLAGS_PITCH_LOCK | mav.GIMBAL_DEVICE_FLAGS_YAW_LOCK
              | mav.GIMBAL_DEVICE_FLAGS_YAW_IN_EARTH_FRAME)
FOLLOW = mav.GIMBAL_DEVICE_FLAGS_PITCH_LOCK | mav.GIMBAL_DEVICE_FLAGS_YAW_IN_VEHICLE_FRAME


class Autopilot:
    """pymavlink as the autopilot / ground station (system 1, component 1)."""

    def __init__(self):
        self.mav = mav.MAVLink(None, srcSystem=1, srcComponent=1)

    def pack(self, msg) -> bytes:
        data = bytes(msg.pack(self.mav))
        self.mav.seq = (self.mav.seq + 1) % 256
        return data

    def set_attitude(self, q=(NAN,) * 4, rates=(NAN, NAN, NAN), flags=EARTH_LOCK, component=154) -> bytes:
        return self.pack(mav.MAVLink_gimbal_device_set_attitude_message(1, component, flags, list(q), *rates))

    def state(self, yaw=0.0, yaw_rate=0.0) -> bytes:
        q = Rotation.from_euler("ZYX", [yaw, 0.0, 0.0]).as_quat()  # x, y, z, w
        return self.pack(mav.MAVLink_autopilot_state_for_gimbal_device_message(
            1, 154, 0, [q[3], q[0], q[1], q[2]], 0, 0.0, 0.0, 0.0, 0, NAN, 1, 0, yaw_rate))

    @staticmethod
    def parse(data: bytes):
        parser = mav.MAVLink(None)
        msgs = parser.parse_buffer(data)
        assert msgs and len(msgs) == 1 and not isinstance(msgs[0], mav.MAVLink_bad_data)
        return msgs[0]


def q_wxyz(pitch_deg: float, yaw_deg: float) -> list[float]:
    x, y, z, w = Rotation.from_euler("ZYX", [yaw_deg * DEG, pitch_deg * DEG, 0.0]).as_quat()
    return [w, x, y, z]


class Sim:
    """The device on an ideal rate loop: Ĉ_nm turns at (0, q, r) in the sight frame."""

    def __init__(self, params=None, pitch_deg=10.0, yaw_deg=30.0):
        self.dev = GimbalDevice(params or DeviceParams())
        self.ap = Autopilot()
        self.R = Rotation.from_euler("ZYX", [yaw_deg * DEG, pitch_deg * DEG, 0.0])
        self.t = 0.0
        self.joint_az = 0.5  # the vehicle heads yaw - 0.5 rad
        self.command = (0.0, 0.0)

    def send(self, data: bytes, wall=None) -> list[bytes]:
        return self.dev.receive(data, self.t if wall is None else wall)

    def run(self, seconds: float, autopilot: bool = True, record=None) -> None:
        for _ in range(int(round(seconds / DT))):
            if autopilot and int(round(self.t / DT)) % 10 == 0:  # 10 Hz
                self.send(self.ap.state(yaw=self.yaw_n() - self.joint_az))
            self.command = self.dev.step(self.t, self.R.as_quat(), self.joint_az, self.t,
                                         (0.0, *self.command))
            self.stepped = self.R
            if record is not None:
                record.append((self.t, *self.angles_deg()))
            self.R = self.R * Rotation.from_rotvec([0.0, *(np.array(self.command) * DT)])
            self.t += DT

    def yaw_n(self) -> float:
        return self.R.as_euler("ZYX")[0]

    def angles_deg(self) -> tuple[float, float]:
        yaw, pitch, _ = self.R.as_euler("ZYX", degrees=True)
        return pitch, yaw

    def status(self):
        return Autopilot.parse(self.dev.status())


def settling_time(step_rad: float, params: DeviceParams, tolerance_rad: float) -> float:
    """Closed form of the saturated type-1 loop: at the rate limit until the error is
    max_rate / k, then e^(-k t) down to the tolerance."""
    k, w = params.gain_1_s, params.max_rate_rad_s
    return (abs(step_rad) - w / k) / w + math.log((w / k) / tolerance_rad) / k


def test_heartbeat_and_information_tell_what_the_device_is():
    dev = GimbalDevice()
    hb = Autopilot.parse(dev.heartbeat())
    assert (hb.type, hb.get_srcSystem(), hb.get_srcComponent()) == (mav.MAV_TYPE_GIMBAL, 1, 154)
    replies = dev.receive(Autopilot().pack(mav.MAVLink_command_long_message(
        1, 154, mav.MAV_CMD_REQUEST_MESSAGE, 0, mav.MAVLINK_MSG_ID_GIMBAL_DEVICE_INFORMATION, 0, 0, 0, 0, 0, 0)), 0.0)
    ack, info = (Autopilot.parse(r) for r in replies)
    assert ack.result == mav.MAV_RESULT_ACCEPTED and ack.command == mav.MAV_CMD_REQUEST_MESSAGE
    caps = info.cap_flags2
    assert caps & mav.GIMBAL_DEVICE_CAP_FLAGS_HAS_PITCH_AXIS and caps & mav.GIMBAL_DEVICE_CAP_FLAGS_HAS_YAW_LOCK
    assert caps & mav.GIMBAL_DEVICE_CAP_FLAGS_SUPPORTS_YAW_IN_EARTH_FRAME
    assert not caps & (mav.GIMBAL_DEVICE_CAP_FLAGS_HAS_ROLL_AXIS | mav.GIMBAL_DEVICE_CAP_FLAGS_HAS_PITCH_FOLLOW
                       | mav.GIMBAL_DEVICE_CAP_FLAGS_HAS_RETRACT | mav.GIMBAL_DEVICE_CAP_FLAGS_HAS_NEUTRAL)
    assert info.cap_flags == caps & 0xFFFF
    assert info.pitch_min == pytest.approx(-85 * DEG) and info.pitch_max == pytest.approx(85 * DEG)
    assert math.isnan(info.roll_min) and info.yaw_max == pytest.approx(math.pi)


def test_pitch_step_settles_in_the_closed_form_time_and_a_locked_yaw_rate_is_held():
    sim = Sim()
    sim.run(0.5)
    assert sim.status().flags & mav.GIMBAL_DEVICE_FLAGS_ACCEPTS_YAW_IN_EARTH_FRAME
    yaw0 = sim.angles_deg()[1]
    sim.send(sim.ap.set_attitude(q_wxyz(-20.0, yaw0), (NAN, NAN, 5.0 * DEG)))
    t_cmd, rec = sim.t, []
    sim.run(8.0, record=rec)
    rec = np.array(rec)
    settle = settling_time(30.0 * DEG, DeviceParams(), 0.01 * DEG)
    inside = np.abs(rec[:, 1] + 20.0) < 0.01
    first = rec[np.argmax(inside), 0] - t_cmd
    assert inside[np.argmax(inside):].all()
    assert first == pytest.approx(settle, abs=0.1)
    late = rec[rec[:, 0] > t_cmd + 5.0]
    rate = np.polyfit(late[:, 0], np.unwrap(late[:, 2] * DEG), 1)[0]
    assert rate == pytest.approx(5.0 * DEG, rel=1e-4)  # a ramp with feed-forward: no lag (the 2 % is the graph test's)
    status = sim.status()
    assert status.flags & mav.GIMBAL_DEVICE_FLAGS_YAW_LOCK and status.flags & mav.GIMBAL_DEVICE_FLAGS_YAW_IN_EARTH_FRAME
    assert status.angular_velocity_z == pytest.approx(5.0 * DEG, rel=1e-3)  # Euler yaw rate from the gyro
    assert status.angular_velocity_y == pytest.approx(0.0, abs=1e-5) and math.isnan(status.angular_velocity_x)
    x, y, z, w = sim.stepped.as_quat()  # the attitude of the device's newest step
    assert np.allclose(status.q, [w, x, y, z], atol=1e-6) or np.allclose(status.q, [-w, -x, -y, -z], atol=1e-6)


def test_nan_fields_are_ignored_each_on_its_own():
    sim = Sim()
    sim.run(0.2)
    sim.send(sim.ap.set_attitude(q_wxyz(-5.0, 40.0)))
    sim.run(7.0)
    assert sim.angles_deg() == pytest.approx((-5.0, 40.0), abs=1e-3)
    sim.send(sim.ap.set_attitude())  # all NaN: nothing changes
    sim.run(0.5)
    sim.send(sim.ap.set_attitude((NAN, 0.0, 0.0, 0.0), (3.0 * DEG, NAN, NAN)))  # q with a NaN, roll rate only
    sim.run(2.0)
    assert sim.angles_deg() == pytest.approx((-5.0, 40.0), abs=1e-3)
    sim.send(sim.ap.set_attitude(rates=(NAN, 2.0 * DEG, NAN)))  # a pitch rate; the yaw angle held
    start = sim.t
    sim.run(2.0)
    pitch, yaw = sim.angles_deg()
    assert pitch == pytest.approx(-5.0 + 2.0 * (sim.t - start), abs=0.05) and yaw == pytest.approx(40.0, abs=1e-3)
    assert sim.dev.counts["setpoints"] == 4 and sim.dev.counts["rejected_setpoints"] == 0


def test_wrong_target_component_is_ignored_and_broadcast_taken():
    sim = Sim()
    sim.run(0.2)
    before = sim.angles_deg()
    sim.send(sim.ap.set_attitude(q_wxyz(-30.0, 0.0), component=1))
    sim.send(sim.ap.pack(mav.MAVLink_gimbal_device_set_attitude_message(2, 154, EARTH_LOCK, q_wxyz(-30.0, 0.0),
                                                                         NAN, NAN, NAN)))
    sim.run(3.0)
    assert sim.angles_deg() == pytest.approx(before, abs=1e-6)
    assert sim.dev.counts["wrong_target"] == 2 and sim.dev.counts["setpoints"] == 0
    sim.send(sim.ap.set_attitude(q_wxyz(-30.0, 0.0), component=0))  # broadcast
    sim.run(10.0)
    assert sim.angles_deg() == pytest.approx((-30.0, 0.0), abs=1e-3)


def test_malformed_datagrams_are_counted_and_never_acted_on():
    sim = Sim()
    sim.run(0.2)
    before = sim.angles_deg()
    good = sim.ap.set_attitude(q_wxyz(-40.0, 0.0))
    bad_crc = bytearray(good)
    bad_crc[14] ^= 0x40  # a payload byte: the CRC no longer matches
    truncated = good[:-5]
    for data in (bytes(bad_crc), truncated, good + b"\x00\x01junk", b"", b"\xfd\x09"):
        assert sim.send(data) == []
    sim.run(3.0)
    assert sim.angles_deg() == pytest.approx(before, abs=1e-6)
    assert sim.dev.counts["malformed"] == 5 and sim.dev.counts["setpoints"] == 0
    sim.send(good)
    sim.run(0.1)
    assert sim.dev.counts["setpoints"] == 1


@pytest.mark.parametrize("bad", [
    dict(q=(0.5, 0.5, 0.5, 0.1)),  # not a unit quaternion
    dict(rates=(NAN, NAN, 20.0 * DEG)),  # above the rate limit
    dict(rates=(NAN, math.inf, NAN)),
    dict(flags=EARTH_LOCK | mav.GIMBAL_DEVICE_FLAGS_YAW_IN_VEHICLE_FRAME),  # both frames
    dict(flags=FOLLOW | mav.GIMBAL_DEVICE_FLAGS_RETRACT),  # not a capability
])
def test_setpoints_the_device_cannot_honour_are_refused(bad):
    sim = Sim()
    sim.run(0.2)
    sim.send(sim.ap.set_attitude(**{"q": q_wxyz(-40.0, 0.0), **bad}))
    sim.run(0.1)
    assert sim.dev.counts["rejected_setpoints"] == 1 and sim.dev.counts["setpoints"] == 0


def test_losing_the_autopilot_for_more_than_the_timeout_drops_the_earth_lock_with_its_flags():
    sim = Sim()
    sim.run(0.2)
    yaw0 = sim.angles_deg()[1]
    sim.send(sim.ap.set_attitude(q_wxyz(0.0, yaw0), (NAN, NAN, 2.0 * DEG)))
    sim.run(2.0)
    assert sim.status().delta_yaw == pytest.approx(sim.yaw_n() - sim.joint_az, abs=0.02)  # the 10 Hz state's
    last_state = sim.t - DT * (int(round((sim.t - DT) / DT)) % 10)  # the newest 10 Hz state
    drop_at = None
    while sim.t < last_state + 2.0:
        sim.run(DT, autopilot=False)
        if not sim.status().flags & mav.GIMBAL_DEVICE_FLAGS_YAW_LOCK and drop_at is None:
            drop_at = sim.t - DT
    assert drop_at - last_state == pytest.approx(1.0, abs=1.5 * DT)  # wall clock > timeout, one step late at most
    status = sim.status()
    assert status.flags & mav.GIMBAL_DEVICE_FLAGS_YAW_IN_VEHICLE_FRAME
    assert not status.flags & (mav.GIMBAL_DEVICE_FLAGS_YAW_IN_EARTH_FRAME
                               | mav.GIMBAL_DEVICE_FLAGS_ACCEPTS_YAW_IN_EARTH_FRAME)
    assert math.isnan(status.delta_yaw) and sim.dev.counts["earth_lock_drops"] == 1
    assert math.isnan(status.angular_velocity_z)  # the vehicle's yaw rate is the autopilot's: unknown now
    assert sim.send(sim.ap.set_attitude(q_wxyz(0.0, 0.0))) == [] and sim.dev.counts["rejected_setpoints"] == 1
    sim.run(1.0)  # the autopilot back: the lock the last setpoint asked for comes back
    assert sim.status().flags & mav.GIMBAL_DEVICE_FLAGS_YAW_LOCK


def test_the_vehicle_heading_changing_source_does_not_move_the_sight():
    """Held in the vehicle frame on the encoders' heading, then the autopilot arrives with a
    heading 10 deg off it: the sight stays where it points."""
    sim = Sim()
    sim.run(1.0, autopilot=False)
    before = sim.angles_deg()
    for _ in range(30):
        sim.send(sim.ap.state(yaw=sim.yaw_n() - sim.joint_az + 10.0 * DEG))
        sim.run(0.1, autopilot=False)
    assert sim.status().flags & mav.GIMBAL_DEVICE_FLAGS_ACCEPTS_YAW_IN_EARTH_FRAME
    assert sim.angles_deg() == pytest.approx(before, abs=1e-6)


def test_an_all_nan_setpoint_right_after_another_does_not_cancel_it():
    sim = Sim()
    sim.run(0.2)
    sim.send(sim.ap.set_attitude(q_wxyz(-5.0, 40.0)))
    sim.send(sim.ap.set_attitude())  # before the device's next estimate
    sim.run(7.0)
    assert sim.angles_deg() == pytest.approx((-5.0, 40.0), abs=1e-3)
