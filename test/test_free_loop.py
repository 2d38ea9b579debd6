"""The controllers' free-timing stale-input policy
(:class:`gimbal_kinematics.timing.control_policy.FreeControl` with its :class:`StaleRule`): a stale
or missing measurement zeroes the command and restarts the loop when it is fresh again; a
stale or missing estimate (held stream) keeps the loop running on the last estimate. Fed by
hand-made stamps; what the policy returns says what the node does with each gyro sample."""
from __future__ import annotations

import pytest

from gimbal_kinematics.timing.control_policy import RESTART_FRESH, FreeControl

MS = 1_000_000


def _loop() -> FreeControl:
    # gyro drives at 100 Hz; encoders may be 20 ms old, the bias estimate 50 ms
    return FreeControl("gyro", {"enc": 0.02, "bias": 0.05}, 0.01, 1.0, held=("bias",))


def _gyro(loop: FreeControl, stamp_ns: int, value: str):
    (step,) = loop.add("gyro", stamp_ns, value)
    return step


def test_a_missing_estimate_keeps_the_loop_running_and_is_counted():
    loop, resets = _loop(), []
    loop.add("enc", 0, "e0")
    step = _gyro(loop, 0, "g0")                       # no bias estimate yet
    assert "bias" not in step.inputs                  # stale: the core keeps what it has
    assert not step.zero_command
    assert loop.counts["stale_estimate_steps"] == 1 and loop.counts["stale_commands"] == 0
    loop.add("bias", 5 * MS, "b5")
    loop.add("enc", 10 * MS, "e10")
    step = _gyro(loop, 10 * MS, "g10")
    assert not step.zero_command
    assert step.inputs["bias"].value == "b5"
    # the estimator stops: its last estimate stays in use past its maximum age
    for k in range(2, 10):
        loop.add("enc", k * 10 * MS, f"e{k}")
        step = _gyro(loop, k * 10 * MS, f"g{k}")
        assert not step.zero_command
        resets += step.resets
    assert loop.counts["stale_estimate_steps"] == 1 + 4   # 60..90 ms: older than 50 ms
    assert loop.counts["stale_commands"] == 0 and resets == []


def test_a_stale_measurement_zeroes_the_command_and_the_loop_restarts_when_fresh():
    loop, resets = _loop(), []
    loop.add("bias", 0, "b0")
    loop.add("enc", 0, "e0")
    assert not _gyro(loop, 0, "g0").zero_command
    # encoders stop: 30 ms later they are older than 20 ms
    assert not _gyro(loop, 10 * MS, "g1").zero_command
    assert not _gyro(loop, 20 * MS, "g2").zero_command
    step = _gyro(loop, 30 * MS, "g3")
    assert step.zero_command
    resets += step.resets
    assert loop.counts["stale_commands"] == 1 and resets == []
    # both stale: zeroed and counted as a stale command, the estimate's staleness counted too
    assert _gyro(loop, 60 * MS, "g6").zero_command
    assert loop.counts["stale_commands"] == 2 and loop.counts["stale_estimate_steps"] == 1
    loop.add("bias", 65 * MS, "b65")
    loop.add("enc", 70 * MS, "e7")
    step = _gyro(loop, 70 * MS, "g7")
    assert not step.zero_command
    assert step.resets == (RESTART_FRESH,) and loop.counts["restarts_after_stale"] == 1


def test_a_held_stream_must_be_an_input():
    with pytest.raises(ValueError, match="not inputs"):
        FreeControl("gyro", {"enc": 0.02}, 0.01, 1.0, held=("bias",))
