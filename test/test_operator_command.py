"""Operator LOS rate command shaper (gimbal_control.operator_command) behind its node's
command policy (timing.control_policy.CommandStamps), against closed forms:
the acceleration-limited ramp of a step command (its times and values), the dead-man's stop
at last stamp + timeout + v/a, the joystick's scaled axes, and bad input refused or counted."""
from __future__ import annotations

import math
import random

import pytest

from gimbal_control.operator_command import OperatorCommandParams
from operator_shaper import Shaper

DEG = math.pi / 180.0
MS = 1_000_000  # ns
A = 100.0 * DEG  # default acceleration limit [rad/s²]
V_MAX = 10.0 * DEG  # default rate limit [rad/s]


def ramp(v: float, t_ns: int, t0_ns: int, v0: float = 0.0) -> float:
    """Closed form: from v0 towards v at A, starting at t0 [ns]."""
    dt = max(0, t_ns - t0_ns) * 1e-9
    return v if abs(v - v0) <= A * dt else v0 + math.copysign(A * dt, v - v0)


def test_step_command_is_the_acceleration_limited_ramp_from_its_own_stamp():
    """A step (2 °/s elevation, 5 °/s azimuth) stamped between two steps: each axis is
    min(v, a (t − t_c)); the azimuth reaches 5 °/s at t_c + 50 ms, the elevation 2 °/s at
    t_c + 20 ms; a reversal to −5 °/s takes 2v/a = 100 ms."""
    shaper = Shaper()
    q, r = 2.0 * DEG, 5.0 * DEG
    t_c = 12_345_678
    shaper.step(0)
    assert shaper.set_rate(t_c, q, r)
    seen = {}
    for k in range(1, 201):
        t = k * MS
        out = shaper.step(t)
        assert out[0] == pytest.approx(ramp(q, t, t_c), abs=1e-12)
        assert out[1] == pytest.approx(ramp(r, t, t_c), abs=1e-12)
        for axis, v in ((0, q), (1, r)):
            if axis not in seen and out[axis] == v:
                seen[axis] = t
    # first 1 kHz step at or after t_c + v/a
    assert seen[0] == math.ceil((t_c + 0.02e9) / MS) * MS
    assert seen[1] == math.ceil((t_c + 0.05e9) / MS) * MS
    t_rev = 200 * MS + 400_000
    assert shaper.set_rate(t_rev, q, -r)
    for k in range(201, 400):
        t = k * MS
        out = shaper.step(t)
        assert out[1] == pytest.approx(ramp(-r, t, t_rev, r), abs=1e-12)
        assert out[0] == q
    assert shaper.output[1] == -r
    assert not shaper.holding


def test_rate_limit_command_at_the_limit_plateaus_above_it_is_rejected_and_never_acted_on():
    shaper = Shaper()
    shaper.step(0)
    assert shaper.set_rate(1 * MS, 0.0, V_MAX)
    for k in range(2, 300):
        shaper.step(k * MS)
    assert shaper.output == (0.0, V_MAX)
    assert not shaper.set_rate(300 * MS, 0.0, -1.01 * V_MAX)
    assert not shaper.set_rate(301 * MS, 1.5 * V_MAX, 0.0)
    for k in range(300, 400):
        assert shaper.step(k * MS) == (0.0, V_MAX)
    assert shaper.counters()["rejected_over_limit"] == 2
    assert shaper.counters()["commands_accepted"] == 1


def test_random_commands_never_exceed_the_rate_limit_nor_the_acceleration_limit():
    rng = random.Random(24)
    shaper = Shaper()
    t, prev = 0, (0.0, 0.0)
    shaper.step(0)
    for _ in range(3000):
        if rng.random() < 0.05:
            shaper.set_rate(t + rng.randrange(0, 2 * MS), rng.uniform(-V_MAX, V_MAX), rng.uniform(-V_MAX, V_MAX))
        dt = rng.randrange(MS // 2, 3 * MS)
        t += dt
        out = shaper.step(t)
        for i in (0, 1):
            assert abs(out[i]) <= V_MAX
            assert abs(out[i] - prev[i]) <= A * dt * 1e-9 * (1 + 1e-12)
        prev = out


def test_deadman_stops_the_slew_within_timeout_plus_v_over_a_and_counts_it():
    """Commands at 20 Hz until t_L = 1 s, then none: the output holds v until t_L + T, then
    ramps to zero at a, reaching it at t_L + T + v/a = 1.55 s (T = 0.5 s, v = 5 °/s)."""
    shaper = Shaper()
    v = 5.0 * DEG
    t_last = 1_000 * MS
    t_stop = t_last + 500 * MS + round(v / A * 1e9)
    for k in range(0, 2001):
        t = k * MS
        if k % 50 == 0 and t <= t_last:
            assert shaper.set_rate(t, 0.0, v)
        out = shaper.step(t)
        if t >= 100 * MS:
            expected = max(0.0, min(v, v - A * (t - t_last - 500 * MS) * 1e-9))
            assert out == (0.0, pytest.approx(expected, abs=1e-12)), t
        if t < t_stop:
            assert not shaper.holding
    assert shaper.holding
    c = shaper.counters()
    assert c["deadman_stops"] == 1
    print(f"dead-man stop at {shaper.last_stop_ns * 1e-9:.6f} s (t_L + T + v/a = {t_stop * 1e-9:.6f} s)")
    assert abs(shaper.last_stop_ns - t_stop) <= 1
    # a new command takes over; a zero command that lapses is no slew to stop
    assert shaper.set_rate(2_001 * MS, 0.0, 0.0)
    for k in range(2_001, 3_000):
        shaper.step(k * MS)
    assert shaper.counters()["deadman_stops"] == 1 and shaper.holding


def test_joy_axes_are_scaled_and_signed_as_teleop_does():
    """Defaults: axis 0 (stick left = +1) → azimuth, inverted (left is −r in FRD); axis 1
    (stick up = +1) → elevation; full deflection = the rate limit."""
    shaper = Shaper()
    shaper.step(0)
    assert shaper.set_joy(1 * MS, [0.5, -0.25, 0.9, 1.0])
    for k in range(2, 200):
        shaper.step(k * MS)
    assert shaper.output == (pytest.approx(-0.25 * V_MAX, abs=1e-15), pytest.approx(-0.5 * V_MAX, abs=1e-15))
    params = OperatorCommandParams(joy_azimuth_axis=3, joy_elevation_axis=2, joy_scale_rad_s=0.05,
                                   joy_invert_azimuth=False, joy_invert_elevation=True)
    shaper = Shaper(params)
    shaper.step(0)
    assert shaper.set_joy(1 * MS, (0.0, 0.0, 0.4, -1.0))
    for k in range(2, 200):
        shaper.step(k * MS)
    assert shaper.output == (pytest.approx(-0.02, abs=1e-15), pytest.approx(-0.05, abs=1e-15))


def test_bad_joy_messages_are_counted_and_never_acted_on():
    shaper = Shaper()
    shaper.step(0)
    assert not shaper.set_joy(1 * MS, [0.3])  # too short for axis 1
    assert not shaper.set_joy(2 * MS, [1.5, 0.0])  # outside [-1, 1]
    assert not shaper.set_joy(3 * MS, [float("nan"), 0.0])
    assert not shaper.set_joy(4 * MS, None)
    for k in range(1, 100):
        assert shaper.step(k * MS) == (0.0, 0.0)
    c = shaper.counters()
    assert (c["rejected_joy"], c["rejected_nonfinite"], c["commands_accepted"]) == (3, 1, 0)


def test_bad_rates_and_stamps_are_counted_and_never_acted_on():
    shaper = Shaper()
    v = 3.0 * DEG
    b = 2_000 * MS
    shaper.step(b)
    assert shaper.set_rate(b + 1 * MS, 0.0, v)
    for bad in (float("nan"), float("inf"), -float("inf")):
        assert not shaper.set_rate(b + 2 * MS, bad, 0.0)
    assert not shaper.set_rate(b + 3 * MS, 0.0, "x")
    assert not shaper.set_rate(b + 1 * MS, 0.0, -v)  # duplicate stamp
    assert not shaper.set_rate(b, 0.0, -v)  # before the last accepted command
    for k in range(1, 100):
        shaper.step(b + k * MS)
    assert shaper.output == (0.0, v)
    assert not shaper.set_rate(b + 99 * MS - 500 * MS, 0.0, -v)  # older than the timeout: stale
    assert not shaper.set_rate(b + 99 * MS + 501 * MS, 0.0, -v)  # more than the timeout ahead
    assert shaper.step(b + 98 * MS) == (0.0, v)  # step stamp back within clock_jump_s: rejected
    assert shaper.step(b + 99 * MS) == (0.0, v)  # duplicate step
    with pytest.raises(TypeError):
        shaper.set_rate(0.2, 0.0, v)
    with pytest.raises(TypeError):
        shaper.step(0.2e9)
    c = shaper.counters()
    assert (c["rejected_nonfinite"], c["rejected_duplicate"], c["rejected_out_of_order"]) == (4, 1, 1)
    assert (c["rejected_stale"], c["rejected_future"], c["rejected_step_stamps"]) == (1, 1, 2)
    assert c["commands_accepted"] == 1 and c["resets"] == 0
    # a clock jump back by more than clock_jump_s (a bag loop) resets: output and commands forgotten
    assert shaper.step(10 * MS) == (0.0, 0.0)
    assert shaper.counters()["resets"] == 1 and shaper.holding
    assert shaper.set_rate(11 * MS, 0.0, v)
    shaper.step(12 * MS)
    assert shaper.output[1] == pytest.approx(A * 1e-3)


def test_commands_before_the_first_step_are_judged_by_it():
    shaper = Shaper()
    assert shaper.set_rate(1 * MS, 0.0, DEG)  # stale by the first step
    assert shaper.set_rate(2 * MS, 0.0, DEG)  # ... and so is this one
    assert shaper.set_rate(10_000 * MS, 0.0, DEG)  # far ahead of it
    assert shaper.step(1_000 * MS) == (0.0, 0.0)
    c = shaper.counters()
    assert (c["rejected_stale"], c["rejected_future"]) == (2, 1)
    assert shaper.set_rate(1_001 * MS, 0.0, DEG)  # the far one no longer blocks the stream
    shaper.step(1_002 * MS)
    assert shaper.output[1] == pytest.approx(A * 1e-3)


@pytest.mark.parametrize("name, value", [
    ("max_rate_deg_s", 0.0), ("max_rate_deg_s", float("nan")), ("max_rate_deg_s", float("inf")),
    ("max_accel_deg_s2", -1.0), ("timeout_s", 0.0),
    ("joy_azimuth_axis", -1), ("joy_azimuth_axis", 1.0), ("joy_elevation_axis", True), ("joy_elevation_axis", 0),
    ("joy_scale_rad_s", 0.0), ("joy_scale_rad_s", 10.01 * DEG), ("joy_invert_azimuth", 1),
])
def test_bad_parameters_are_refused_naming_them(name, value):
    with pytest.raises(ValueError, match=name):
        OperatorCommandParams(**{name: value})
