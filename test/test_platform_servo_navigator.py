"""Paper 3 platform servo following a navigator's command rate (command_source=navigator):
the pickoff against closed forms built with gimbal_kinematics.maths.rotations.rot3, the fallback to
the internal command before the first command and when commands go stale, and the bad-input
counters. No ROS."""
import math

import numpy as np
import pytest

from gimbal_control.platform_servo import PlatformServo, PlatformServoParams
from gimbal_control.platform_servo_params import PARAMS
from gimbal_kinematics.maths.earth import earth_rate_n
from gimbal_kinematics.maths.rotations import rot3
from gimbal_kinematics.params.table import ParameterError, defaults

DEG = math.pi / 180.0
ARCSEC = DEG / 3600.0
DT = 1e-3


def _tick(servo, t, sched, extra_n=(0.0, 0.0, 0.0), lat=0.0):
    """Gyros reading the earth rate (plus ``extra_n``, NED) turned by φz, plus φ̇z."""
    phi, rate, _ = sched.state(t)
    omega = rot3(phi) @ (earth_rate_n(lat) + np.asarray(extra_n)) + np.array([0.0, 0.0, rate])
    servo.on_resolvers(t, (phi, 0.0, 0.0, 0.0))
    return servo.on_gyro(t, omega).output


def _navigator_servo(**kw):
    params = PlatformServoParams(lat_deg=0.0, sweep_deg=90.0, command_source="navigator", **kw)
    return PlatformServo(params), params.schedule()


def test_pickoff_stays_null_when_the_platform_follows_the_navigator_rate():
    """A navigator rate unlike the internal one (transport rate, drift compensation: any
    ω^n) and gyros that read rot3(φz) ω^n + φ̇z: the pickoff stays at 0 through the turn."""
    servo, sched = _navigator_servo()
    w_n = np.array([3e-5, -2e-5, 1e-5])
    extra = w_n - earth_rate_n(0.0)
    for k in range(5000):
        servo.on_command_rate(k * DT, w_n)
        _tick(servo, k * DT, sched, extra)
    assert np.max(np.abs(servo.pickoff)) < 1e-3 * ARCSEC
    assert servo.ticks_without_command == 0 and servo.stale_command_ticks == 0


def test_a_north_command_torques_the_reference_about_north_through_the_turn():
    """The navigator asks for Δ more about north than the platform turns: the reference leaves
    the platform about NED north at Δ, so in s the pickoff is δ = −Δ t rot3(φz) e_N while φz
    sweeps 36° (earth-rate cross terms: ω_ie t ≈ 2e-3 relative)."""
    servo, sched = _navigator_servo()
    delta = 20.0 * DEG / 3600.0
    w_n = earth_rate_n(0.0) + np.array([delta, 0.0, 0.0])
    n = 30001
    for k in range(n):
        servo.on_command_rate(k * DT, w_n)
        _tick(servo, k * DT, sched)
    t = (n - 1) * DT
    phi, _, _ = sched.state(t)
    assert phi == pytest.approx(36.0 * DEG, rel=1e-9)
    expected = -delta * t * (rot3(phi) @ np.array([1.0, 0.0, 0.0]))
    assert np.asarray(servo.pickoff) == pytest.approx(expected, abs=5e-3 * abs(delta * t))


def test_internal_command_before_the_first_navigator_command_and_when_it_goes_stale():
    """No command yet, or the newest older than command_max_age_s: the servo runs on its own
    earth rate minus drift_deg_h, counting the ticks. Gyros read exactly that internal command,
    so the pickoff stays null without a command, grows at the commanded difference Δ while a
    command is fresh, and keeps its size once the command is stale (it only turns with s)."""
    drift = (0.05, -0.02, 0.01)
    servo, sched = _navigator_servo(drift_deg_h=drift, command_max_age_s=0.2)
    drift_s = np.array(drift) * DEG / 3600.0

    def tick(k):
        t = k * DT
        phi, rate, _ = sched.state(t)
        servo.on_resolvers(t, (phi, 0.0, 0.0, 0.0))
        servo.on_gyro(t, rot3(phi) @ earth_rate_n(0.0) + np.array([0.0, 0.0, rate]) - drift_s)

    for k in range(300):  # 0.3 s without any command
        tick(k)
    assert servo.ticks_without_command == 300 and np.max(np.abs(servo.pickoff)) < 1e-3 * ARCSEC

    delta = 5e-5
    servo.on_command_rate(0.3, earth_rate_n(0.0) + np.array([delta, 0.0, 0.0]))
    for k in range(300, 501):  # held through 0.5 s (age 0.2 s): the navigator's rate
        tick(k)
    assert servo.stale_command_ticks == 0
    assert np.linalg.norm(servo.pickoff) == pytest.approx(delta * 0.2, rel=0.02)
    tick(501)  # now stale: the internal rate again (this tick's trapezoid takes half of Δ)
    size = np.linalg.norm(servo.pickoff)
    for k in range(502, 800):
        tick(k)
    assert servo.stale_command_ticks == 299
    assert np.linalg.norm(servo.pickoff) == pytest.approx(size, rel=1e-6)

    servo.on_command_rate(0.8, earth_rate_n(0.0))
    tick(800)
    assert servo.stale_command_ticks == 299 and servo.ticks_without_command == 300


def test_internal_source_ignores_navigator_commands_and_keeps_its_data():
    """The default (internal): commands change nothing, so existing runs keep their data."""
    params = PlatformServoParams(lat_deg=30.0, sweep_deg=90.0)
    assert params.command_source == "internal"
    a, b = PlatformServo(params), PlatformServo(params)
    sched = params.schedule()
    for k in range(500):
        b.on_command_rate(k * DT, (1e-3, 2e-3, 3e-3))
        ca = _tick(a, k * DT, sched, (1e-6, 0.0, 0.0), lat=30.0 * DEG)
        cb = _tick(b, k * DT, sched, (1e-6, 0.0, 0.0), lat=30.0 * DEG)
        assert ca == cb
    assert b.ticks_without_command == 0


def test_bad_command_rates_are_counted_and_never_used():
    servo, sched = _navigator_servo()
    good = earth_rate_n(0.0)
    servo.on_command_rate(0.0, good)
    servo.on_command_rate(0.001, (math.nan, 0.0, 0.0))
    servo.on_command_rate(0.002, (0.0, math.inf, 0.0))
    assert servo.rejected_nonfinite == 2
    for k in range(200):  # the good command is the one held: pickoff null
        _tick(servo, k * DT, sched)
    assert np.max(np.abs(servo.pickoff)) < 1e-3 * ARCSEC
    with pytest.raises(ValueError, match="3 elements"):
        servo.on_command_rate(6.0, (0.0, 0.0))


def test_params_refuse_bad_command_source_and_age():
    with pytest.raises(ValueError, match="command_source"):
        PlatformServoParams(command_source="gps")
    with pytest.raises(ValueError, match="command_max_age_s"):
        PlatformServoParams(command_max_age_s=0.0)
    v = defaults(PARAMS)
    assert PlatformServoParams.from_values(v) == PlatformServoParams()
    v.update(command_source="navigator", command_max_age_s=2.0)
    p = PlatformServoParams.from_values(v)
    assert (p.command_source, p.command_max_age_s) == ("navigator", 2.0)
    v["command_source"] = "gps"
    with pytest.raises(ParameterError, match="command_source"):
        PlatformServoParams.from_values(v)
