"""The one /diagnostics builder (gimbal_kinematics.ros.diagnostics): its levels, in order."""
from __future__ import annotations

import pytest
from diagnostic_msgs.msg import DiagnosticStatus

from gimbal_kinematics.ros.diagnostics import health_level, health_msg

OK, WARN, STALE = DiagnosticStatus.OK, DiagnosticStatus.WARN, DiagnosticStatus.STALE


@pytest.mark.parametrize("fields, kwargs, level, text", [
    ({"resets": 0}, {}, OK, "running"),
    ({"resets": 0}, {"warn": ("resets",)}, OK, "running"),
    ({"resets": 2}, {"warn": ("resets",)}, WARN, "running; inputs rejected or filter reset (see values)"),
    ({"resets": 2}, {}, OK, "running"),                           # a counter not named in warn
    ({}, {"warn": ("gated",)}, OK, "running"),                    # a warn key absent: zero
    ({}, {"nis_verdict": "consistent"}, OK, "running"),
    ({}, {"nis_verdict": "insufficient"}, OK, "running"),
    ({}, {"nis_verdict": "overconfident"}, WARN, "running; NIS overconfident (see nis_*)"),
    ({}, {"nis_verdict": "conservative"}, WARN, "running; NIS conservative (see nis_*)"),
    ({}, {"stale": True}, WARN, "an input is stale: command zeroed"),
    # the first that holds wins: not ready, then stale, then counters, then NIS
    ({"resets": 1}, {"ready": False, "stale": True, "warn": ("resets",)}, STALE, "not aligned"),
    ({}, {"ready": False, "not_ready": "no estimate yet"}, STALE, "no estimate yet"),
    ({"resets": 1}, {"stale": True, "warn": ("resets",)}, WARN, "an input is stale: command zeroed"),
    ({"resets": 1}, {"warn": ("resets",), "nis_verdict": "overconfident"}, WARN,
     "running; inputs rejected or filter reset (see values)"),
])
def test_levels(fields, kwargs, level, text):
    assert health_level(fields, **kwargs) == (level, text)


def test_message_carries_every_field_and_the_stamp():
    t_ns = 1_800_000_000_123_456_789
    arr = health_msg(t_ns, "gyro_bias_ekf", {"updates": 3, "jitter_rms": 0.25}, ready=True)
    assert (arr.header.stamp.sec, arr.header.stamp.nanosec) == (1_800_000_000, 123_456_789)
    (status,) = arr.status
    assert status.name == "gyro_bias_ekf: health" and status.hardware_id == "gyro_bias_ekf"
    assert [(kv.key, kv.value) for kv in status.values] == [("updates", "3"), ("jitter_rms", "0.25")]
    assert (status.level, status.message) == (OK, "running")
