"""Free timing's input gate (gimbal_kinematics.timing.sync.FreshInputs), without ROS: stamps from a
seeded generator whose drops, duplicates and reorderings are known by construction."""
from __future__ import annotations

import numpy as np
import pytest

from gimbal_kinematics.timing.sync import FreshInputs

EPOCH_NS = 1_800_000_000_123_456_789  # stamps near 1.8e9 s, as a driver's wall clock gives them
T_NS = 5_000_000  # 200 Hz gyro


def _gate(max_age_ns: int = 30_000_000) -> FreshInputs:
    return FreshInputs("gyro", {"enc": max_age_ns, "ins": max_age_ns}, T_NS, backjump_ns=500_000_000)


def test_steps_on_every_gyro_sample_with_the_newest_fresh_inputs_and_relative_int_ns():
    gate = _gate()
    assert gate.add("enc", EPOCH_NS - 1_000_000, "e0") is None
    assert gate.add("ins", EPOCH_NS - 2_000_000, "i0") is None
    first = gate.add("gyro", EPOCH_NS, "g0")
    # the origin is the first stamp seen (the encoders, 1 ms before): times are int ns after it
    assert first.t_ns == 1_000_000 and first.dt_ns == 0 and first.stale == ()
    assert first.inputs == {"enc": "e0", "ins": "i0"}
    gate.add("enc", EPOCH_NS + 4_000_000, "e1")
    second = gate.add("gyro", EPOCH_NS + 5_000_001, "g1")
    assert second.dt_ns == 5_000_001 and second.inputs["enc"] == "e1" and second.t_ns == 6_000_001
    # an exact integer difference: what float seconds near 1.8e9 s could not keep (their ulp is 238 ns)
    assert (EPOCH_NS + 5_000_001) * 1e-9 - EPOCH_NS * 1e-9 != 5_000_001e-9


def test_an_input_that_stops_goes_stale_after_its_maximum_age_and_each_such_step_is_counted():
    gate = _gate(max_age_ns=30_000_000)
    gate.add("ins", EPOCH_NS, "i")
    gate.add("enc", EPOCH_NS, "e")
    stale_at = []
    for k in range(20):  # the encoders stop after the first sample; the INS keeps coming
        t = EPOCH_NS + k * T_NS
        gate.add("ins", t, "i")
        step = gate.add("gyro", t, k)
        if step.stale:
            assert step.stale == ("enc",) and step.inputs["enc"] == "e"  # the last one, flagged stale
            stale_at.append(k)
    # age k·5 ms > 30 ms from k = 7 on
    assert stale_at == list(range(7, 20)) and gate.stale_steps == 13


def test_jitter_drops_duplicates_and_out_of_order_are_handled_and_counted_as_generated():
    rng = np.random.default_rng(20240616)
    n = 4000
    stamps = EPOCH_NS + np.arange(n) * T_NS + rng.uniform(-0.2, 0.2, n).astype(float) * T_NS
    stamps = stamps.astype(np.int64)
    keep = rng.random(n) > 0.02
    keep[0] = True
    kept = [int(s) for s, k in zip(stamps, keep) if k]
    # true drops: missing samples between kept ones (±20 % jitter: a single gap is 0.6–1.4 periods)
    idx = np.flatnonzero(keep)
    true_dropped = int(np.sum(np.diff(idx) - 1))
    sequence = []
    n_dup = n_ooo = 0
    for i, s in enumerate(kept):
        sequence.append(s)
        if i > 2 and rng.random() < 0.01:
            sequence.append(s)  # duplicate
            n_dup += 1
        elif i > 2 and rng.random() < 0.01:
            sequence.append(kept[i - 2])  # a late sample, out of order
            n_ooo += 1
    gate = FreshInputs("gyro", {}, T_NS, backjump_ns=500_000_000)
    steps = [st for st in (gate.add("gyro", s, None) for s in sequence) if st is not None]
    assert len(steps) == len(kept)
    assert gate.duplicates == n_dup and gate.out_of_order == n_ooo
    assert gate.dropped == true_dropped > 0
    assert all(st.dt_ns > 0 for st in steps[1:])
    assert [st.t_ns for st in steps] == [s - kept[0] for s in kept]


def test_thirty_percent_jitter_is_counted_as_jitter_not_as_drops():
    rng = np.random.default_rng(7)
    n = 2000
    jitter = rng.uniform(-0.3, 0.3, n)
    stamps = (EPOCH_NS + (np.arange(n) + jitter) * T_NS).astype(np.int64)
    gate = FreshInputs("gyro", {}, T_NS, backjump_ns=500_000_000)
    for s in stamps:
        gate.add("gyro", int(s), None)
    gaps = np.diff(stamps) / T_NS
    assert gate.dropped == int(np.sum(np.round(gaps[gaps > 1.5]) - 1))
    assert gate.dropped <= 0.02 * n  # only gaps in (1.5, 1.6] periods: a small tail
    assert gate.jittered == int(np.sum((np.abs(gaps - 1.0) > 0.3) & (gaps <= 1.5)))


def test_a_clock_jump_back_restarts_from_a_new_origin():
    gate = _gate()
    gate.add("enc", EPOCH_NS, "e")
    gate.add("gyro", EPOCH_NS + 10 * T_NS, 0)
    step = gate.add("gyro", EPOCH_NS, 1)  # 50 ms back: out of order, rejected
    assert step is None and gate.out_of_order == 1
    step = gate.add("gyro", EPOCH_NS - 10**9, 2)  # 1.05 s back: a bag looping
    assert step.restarted and step.t_ns == 0 and step.stale == ("enc", "ins") and gate.restarts == 1
    assert step.inputs == {"enc": None, "ins": None}


def test_bad_construction_is_refused():
    with pytest.raises(ValueError):
        FreshInputs("gyro", {"gyro": 1}, T_NS, 0)
    with pytest.raises(ValueError):
        FreshInputs("gyro", {}, 0, 0)
    with pytest.raises(ValueError):
        _gate().add("bias", EPOCH_NS, None)
