"""The controllers' free-timing stale-input policy (:class:`gimbal_kinematics.ros.free_loop.FreeLoop`):
a stale or missing measurement zeroes the command and restarts the loop when it is fresh
again; a stale or missing estimate (held stream) keeps the loop running on the last estimate.
Fed by hand-made stamps; the node and its publisher are stand-ins that record what the loop
does with them."""
from __future__ import annotations

import pytest

from gimbal_kinematics.ros.free_loop import FreeLoop

MS = 1_000_000


class _Logger:
    def __init__(self) -> None:
        self.warnings: list[str] = []

    def warning(self, text: str, **_: object) -> None:
        self.warnings.append(text)


class _Node:
    def __init__(self) -> None:
        self.logger = _Logger()

    def get_logger(self) -> _Logger:
        return self.logger

    def get_name(self) -> str:
        return "controller"


class _Io:
    incompatible_qos = 0

    def advertise(self, *_: object) -> object:
        return None


def _loop() -> FreeLoop:
    # gyro drives at 100 Hz; encoders may be 20 ms old, the bias estimate 50 ms
    return FreeLoop(_Node(), _Io(), "gyro", {"enc": 0.02, "bias": 0.05}, 0.01, 1.0, 1.0, held=("bias",))


def test_a_missing_estimate_keeps_the_loop_running_and_is_counted():
    loop, resets = _loop(), []
    loop.gate.add("enc", 0, "e0")
    step = loop.gate.add("gyro", 0, "g0")            # no bias estimate yet
    assert step.stale == ("bias",)
    assert loop.fresh(step, resets.append)
    assert loop.counts["stale_estimate_steps"] == 1 and loop.counts["stale_commands"] == 0
    loop.gate.add("bias", 5 * MS, "b5")
    loop.gate.add("enc", 10 * MS, "e10")
    step = loop.gate.add("gyro", 10 * MS, "g10")
    assert step.stale == () and loop.fresh(step, resets.append)
    assert step.inputs["bias"] == "b5"
    # the estimator stops: its last estimate stays in use past its maximum age
    for k in range(2, 10):
        loop.gate.add("enc", k * 10 * MS, f"e{k}")
        step = loop.gate.add("gyro", k * 10 * MS, f"g{k}")
        assert loop.fresh(step, resets.append)
    assert loop.counts["stale_estimate_steps"] == 1 + 4   # 60..90 ms: older than 50 ms
    assert loop.counts["stale_commands"] == 0 and resets == []


def test_a_stale_measurement_zeroes_the_command_and_the_loop_restarts_when_fresh():
    loop, resets = _loop(), []
    loop.gate.add("bias", 0, "b0")
    loop.gate.add("enc", 0, "e0")
    assert loop.fresh(loop.gate.add("gyro", 0, "g0"), resets.append)
    # encoders stop: 30 ms later they are older than 20 ms
    assert loop.fresh(loop.gate.add("gyro", 10 * MS, "g1"), resets.append)
    assert loop.fresh(loop.gate.add("gyro", 20 * MS, "g2"), resets.append)
    assert not loop.fresh(loop.gate.add("gyro", 30 * MS, "g3"), resets.append)
    assert loop.counts["stale_commands"] == 1 and resets == []
    # both stale: zeroed and counted as a stale command, the estimate's staleness counted too
    assert not loop.fresh(loop.gate.add("gyro", 60 * MS, "g6"), resets.append)
    assert loop.counts["stale_commands"] == 2 and loop.counts["stale_estimate_steps"] == 1
    loop.gate.add("bias", 65 * MS, "b65")
    loop.gate.add("enc", 70 * MS, "e7")
    assert loop.fresh(loop.gate.add("gyro", 70 * MS, "g7"), resets.append)
    assert len(resets) == 1 and loop.counts["restarts_after_stale"] == 1


def test_a_held_stream_must_be_an_input():
    with pytest.raises(ValueError, match="held streams"):
        FreeLoop(_Node(), _Io(), "gyro", {"enc": 0.02}, 0.01, 1.0, 1.0, held=("bias",))
