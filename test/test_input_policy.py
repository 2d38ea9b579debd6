"""The input policies (gimbal_kinematics.timing.input_policy) against hand-worked cases."""
from __future__ import annotations

import pytest

from gimbal_kinematics.timing.input_policy import (
    FreeOrder, FreeSamples, LockstepGroups, LockstepOrder, LockstepSamples, order_policy, sample_policy,
)
from gimbal_kinematics.timing.stamps import JUMP_SAMPLES

EPOCH = 1_800_000_000_000_000_000
MS = 1_000_000


class _Log:
    def warning(self, *a, **k): pass
    def info(self, *a, **k): pass


def test_lockstep_order_time_and_progress():
    p = LockstepOrder(("enc", "gyro"), 0, 1000.0, progress_every=10)
    assert p.add("gyro", 8 * MS, "g8") == []                   # waits for the encoders of step 8
    (e, g) = p.add("enc", 8 * MS, "e8")
    assert (e.kind, g.kind, g.t, g.stamp_ns) == ("enc", "gyro", 0.008, 8 * MS)
    assert p.progress(g) is None
    (e, g) = p.add("enc", 9 * MS, "e9") + p.add("gyro", 9 * MS, "g9")
    assert p.progress(g) == 10 * MS                             # step 10 starts a block of 10
    assert p.stamp_of(0.009) == 9 * MS


def test_free_order_drops_late_restarts_on_a_jump_and_runs_from_the_first_stamp():
    resets = []
    p = FreeOrder(("enc", "gyro"), 0, clock_jump_ns=500 * MS, progress_every=2, on_restart=resets.append,
                  paced="gyro")
    assert p.add("enc", EPOCH, "e0") == []
    (e, g) = p.add("gyro", EPOCH, "g0")
    assert g.t == 0.0 and g.stamp_ns == EPOCH and p.progress(g) is None
    assert p.add("gyro", EPOCH, "dup") == [] and p.stats["gyro"].duplicates == 1
    assert p.add("enc", EPOCH + 2 * MS, "e2") == []
    (e, g) = p.add("gyro", EPOCH + 2 * MS, "g2")
    assert g.t == pytest.approx(0.002) and p.progress(e) is None and p.progress(g) == EPOCH + 2 * MS
    # a bag loop: believed once JUMP_SAMPLES stamps in a row agree on it, then a restart at its first
    loop = [EPOCH - 10**9 + 2 * i * MS for i in range(JUMP_SAMPLES)]
    for i, stamp in enumerate(loop[:-1]):
        assert p.add("gyro", stamp, f"loop{i}") == [] and resets == []
    p.add("gyro", loop[-1], "loop-last")
    assert len(resets) == 1 and p.t0_ns == EPOCH - 10**9
    assert p.counters()["gyro_clock_jumps"] == 1 and p.stamp_of(0.5) == EPOCH - 10**9 + 500 * MS
    assert p.counters()["gyro_outliers"] == 0 and p.counters()["gyro_dropped"] == 0


def test_lockstep_samples_report_one_sample_after_the_older_stream():
    p = LockstepSamples(("a", "b"), rate_hz=100.0, sample_rate_hz=10.0, progress_every=10)
    (s,) = p.add("a", 100 * MS, "a1")
    assert (s.t, s.dt) == (0.1, 0.1) and p.progress(s) is None  # b not seen yet
    (s,) = p.add("b", 100 * MS, "b1")
    assert p.progress(s) == 200 * MS                           # step 10 + 10 steps per sample


def test_free_samples_interval_from_stamps_and_unknown_after_a_gap():
    p = FreeSamples(("a",), sample_rate_hz=10.0, clock_jump_ns=10**9, progress_every=100, warn=lambda t: None)
    (s,) = p.add("a", EPOCH, 0)
    assert s.dt == 0.1 and s.t == 0.0                           # first: the nominal period
    (s,) = p.add("a", EPOCH + 120 * MS, 1)
    assert s.dt == pytest.approx(0.12)                          # +20 % jitter followed
    assert p.add("a", EPOCH + 320 * MS, 2) == []                # 2 periods: a gap, interval unknown
    assert p.interval_unknown["a"] == 1 and p.counters()["a_dropped"] == 1


def test_lockstep_groups_reject_off_grid_and_release_in_stream_order():
    p = LockstepGroups(("joint", "imu"), lambda k: ("joint", "imu") if k % 10 == 0 else (), 100.0, 1.0,
                       lambda k: k + 10, progress_every=10, logger=_Log())
    assert p.add("imu", 50 * MS, "x") == [] and p.off_grid == 1
    assert p.add("imu", 100 * MS, "i") == []
    (j, i) = p.add("joint", 100 * MS, "j")
    assert (j.kind, j.ends_step, i.kind, i.ends_step, i.t) == ("joint", False, "imu", True, 0.1)
    assert p.progress(j) is None and p.progress(i) == 200 * MS


def test_the_factories_refuse_an_unknown_timing():
    with pytest.raises(ValueError, match="timing"):
        order_policy("realtime", ("a",), max_wait_ns=0, rate_hz=1.0, progress_every=1, clock_jump_ns=1,
                     on_restart=print)
    with pytest.raises(ValueError, match="timing"):
        sample_policy("x", ("a",), rate_hz=1.0, sample_rate_hz=1.0, progress_every=1, clock_jump_ns=1,
                      warn=print)


def test_sample_grid_matches_a_brute_force_walk_of_the_steps():
    from gimbal_kinematics.timing.input_policy import SampleGrid

    grid = SampleGrid({"joint": 4, "imu": 10})
    for k in range(0, 200):
        assert grid.needs(k) == tuple(s for s, n in (("joint", 4), ("imu", 10)) if k % n == 0)
        assert grid.next_due(k) == next(j for j in range(k + 1, k + 50) if j % 4 == 0 or j % 10 == 0)
    with pytest.raises(ValueError, match="sampling period"):
        SampleGrid({"imu": 0})
