"""The controllers' input policies (:mod:`gimbal_kinematics.timing.control_policy`) against
hand-worked cases: which steps come out of a sequence of stamped inputs, with which inputs,
and when a command is held (lockstep: an input that could not be used is in the step as
None) or zeroed (free: a stale measurement), with the counts."""
from __future__ import annotations

import math

import pytest

from gimbal_kinematics.timing.control_policy import (
    RESTART_FRESH, RESTART_JUMP, FreeControl, LockstepControl, Sample, control_policy,
)

MS = 1_000_000
RATE = 100.0  # lockstep steps every 10 ms


def sec(stamp_ns: int) -> float:
    """A stamp in seconds, as the policies convert it."""
    return stamp_ns * 1e-9


def _needs(k: int) -> tuple[str, ...]:
    """gyro and encoders every step, the INS and the bias estimate every other step."""
    return ("gyro", "enc", "ins", "bias") if k % 2 == 0 else ("gyro", "enc")


def test_lockstep_releases_a_step_when_its_inputs_are_in_and_keeps_unusable_ones_as_none():
    p = LockstepControl(_needs, RATE, 1.0, estimates=("bias",))
    assert p.add("gyro", 0, "g0") == [] and p.add("enc", 0, "e0") == [] and p.add("ins", 0, "i0") == []
    (step,) = p.add("bias", 0, "b0")
    assert (step.stamp_ns, step.t, step.command, step.zero_command, step.resets) == (0, 0.0, True, False, ())
    assert step.inputs == {"gyro": Sample(0.0, "g0"), "enc": Sample(0.0, "e0"), "ins": Sample(0.0, "i0"),
                           "bias": Sample(0.0, "b0")}
    # step 1: an encoder message that could not be used completes the step as None (the node holds)
    assert p.add("gyro", 10 * MS, "g1") == []
    (step,) = p.add("enc", 10 * MS, None)
    assert step.t == 1 / RATE and step.inputs == {"gyro": Sample(sec(10 * MS), "g1"), "enc": None}
    # an estimate at a step that does not wait for one: used at once, no command
    (step,) = p.add("bias", 30 * MS, "b3")
    assert not step.command and step.inputs == {"bias": Sample(sec(30 * MS), "b3")}
    # a late input for a step already released: rejected, counted
    assert p.add("gyro", 10 * MS, "again") == [] and p.sync.rejected == 1
    assert p.counters() == {} and not p.diagnostics


def test_lockstep_sample_hold_puts_the_newest_sample_in_every_step_at_its_stamp():
    p = LockstepControl(lambda k: ("gyro", "enc") if k % 2 == 0 else ("gyro",), RATE, 1.0, eager_stale_steps=5,
                        sample_hold=("enc",), stamp_time=True)
    assert p.add("gyro", 0, "g0") == []                                  # waits for the encoders
    (s0,) = p.add("enc", 0, "e0")
    (s1,) = p.add("gyro", 10 * MS, "g1")
    assert s1.t == 10 * MS * 1e-9 and s1.inputs == {"gyro": Sample(sec(10 * MS), "g1"), "enc": Sample(sec(10 * MS), "e0")}
    p.add("enc", 20 * MS, None)                                          # unusable: held as None
    (s2,) = p.add("gyro", 20 * MS, "g2")
    assert s2.inputs["enc"] is None
    (s3,) = p.add("gyro", 30 * MS, "g3")
    assert s3.inputs["enc"] is None
    assert s0.inputs == {"gyro": Sample(0.0, "g0"), "enc": Sample(0.0, "e0")}


def test_lockstep_ticks_only_at_steps_that_need_them():
    p = LockstepControl(lambda k: ("gyro",) if k % 2 == 0 else ("clock",), RATE, 1.0, ticks=("clock",))
    assert p.ticks == ("clock",)
    assert p.add("clock", 0, "tick") == []                               # step 0 ticks on its gyro sample
    assert [s.stamp_ns for s in p.add("gyro", 0, "g0") + p.add("clock", 10 * MS, "tick")] == [0, 10 * MS]


def _free(**kw) -> FreeControl:
    warnings: list[str] = []
    p = FreeControl("gyro", {"enc": 0.02, "bias": 0.05}, 0.01, 1.0, held=("bias",), warn=warnings.append, **kw)
    p.warnings = warnings  # type: ignore[attr-defined]
    return p


def test_free_zeroes_on_a_stale_measurement_keeps_a_stale_estimate_and_restarts_when_fresh():
    p = _free()
    (s,) = p.add("gyro", 0, (1.0, 2.0))                      # no encoders, no bias yet
    assert s.zero_command and s.inputs == {} and s.resets == ()
    assert p.counts == {"stale_commands": 1, "stale_estimate_steps": 1, "restarts_after_stale": 0}
    assert p.add("enc", 5 * MS, "e") == []
    (s,) = p.add("gyro", 10 * MS, (3.0, 4.0))                # encoders fresh (5 ms old), bias still missing
    assert not s.zero_command and s.resets == (RESTART_FRESH,)
    assert s.t == pytest.approx(0.01) and s.inputs == {"gyro": Sample(sec(10 * MS), (3.0, 4.0)), "enc": Sample(sec(5 * MS), "e")}
    assert p.counts == {"stale_commands": 1, "stale_estimate_steps": 2, "restarts_after_stale": 1}
    p.add("bias", 12 * MS, "b")
    (s,) = p.add("gyro", 20 * MS, (5.0, 6.0))                # encoders 15 ms old: still fresh
    assert set(s.inputs) == {"gyro", "enc", "bias"} and s.resets == ()
    (s,) = p.add("gyro", 30 * MS, (7.0, 8.0))                # encoders 25 ms old > 20 ms: zeroed
    assert s.zero_command and p.counts["stale_commands"] == 2
    assert p.counters()["stale_steps"] == 3 and p.counters()["accepted_gyro"] == 4
    assert len(p.warnings) == 4 and all("(" in w for w in p.warnings)


def test_free_once_inputs_go_in_the_first_step_after_they_arrive_and_again_after_a_zero():
    p = FreeControl("imu", {"res": 0.1}, 0.01, 1.0, once=("res",))
    p.add("res", 0, "r0")
    assert set(p.add("imu", 0, "w0")[0].inputs) == {"imu", "res"}
    assert set(p.add("imu", 10 * MS, "w1")[0].inputs) == {"imu"}     # already given
    assert p.add("imu", 200 * MS, "w2")[0].zero_command               # 200 ms old: stale
    p.add("res", 205 * MS, "r1")
    (s,) = p.add("imu", 210 * MS, "w3")
    assert s.resets == (RESTART_FRESH,) and s.inputs["res"] == Sample(sec(205 * MS), "r1")


def test_free_drops_unusable_and_nonfinite_inputs_and_restarts_on_a_clock_jump_back():
    seen: list[str] = []
    p = _free(finite=("enc",), on_nonfinite=seen.append, on_arrival=())
    assert p.add("enc", 0, None) == [] and p.add("enc", 0, (math.nan, 0.0)) == [] and seen == ["enc"]
    assert p.gate.accepted["enc"] == 0
    p.add("enc", 0, (0.1, 0.2))
    p.add("gyro", 5 * 10**9, "g")                                       # 5 s later: encoders stale
    (s,) = p.add("gyro", 2 * MS, "g")                                   # 5 s back (> 1 s): a new run,
    assert s.resets == (RESTART_JUMP,) and s.zero_command and s.t == 0.0  # the old encoders forgotten
    p.add("enc", 3 * MS, (0.1, 0.2))
    (s,) = p.add("gyro", 4 * MS, "g")
    assert s.resets == (RESTART_FRESH,) and s.t == sec(2 * MS) and s.inputs["enc"] == Sample(sec(1 * MS), (0.1, 0.2))
    assert p.gate.restarts == 1


def test_free_on_arrival_estimates_are_steps_without_a_command_and_never_in_a_command_step():
    p = FreeControl("gyro", {"att": 0.05}, 0.01, 1.0, held=("att",), on_arrival=("att",))
    p.add("gyro", 0, "g0")
    (s,) = p.add("att", 3 * MS, "q")
    assert not s.command and s.inputs == {"att": Sample(sec(3 * MS), "q")}
    assert p.add("att", 3 * MS, "q") == []                              # a duplicate: counted, not used
    (s,) = p.add("gyro", 10 * MS, "g1")
    assert s.inputs == {"gyro": Sample(sec(10 * MS), "g1")} and not s.zero_command


def test_the_factory_builds_the_timings_policy_and_refuses_others():
    made = {"lockstep": lambda: "L", "free": lambda: "F"}
    assert control_policy("lockstep", **made) == "L" and control_policy("free", **made) == "F"
    with pytest.raises(ValueError, match="timing"):
        control_policy("realtime", **made)
    with pytest.raises(ValueError, match="not inputs"):
        FreeControl("gyro", {"enc": 0.02}, 0.01, 1.0, held=("bias",))
