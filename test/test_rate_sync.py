"""RateSync, the multi-rate grouping of a gyro-propagated filter, on hand-made streams whose
grouping is worked out by hand (linear interpolation, stamp order), with recording callbacks
in place of a filter."""
from __future__ import annotations

import pytest

from gimbal_kinematics.timing.sync import RateSync


def _recording(max_wait_s: float = 0.05, max_gap_s: float = 0.1):
    log: list[tuple] = []
    sync = RateSync(max_wait_s, max_gap_s, lambda *a: log.append(("integrate", *a)),
                    lambda *a: log.append(("fuse", *a)) or a[0])
    return sync, log


def test_a_gyro_sample_waits_for_angles_and_rates_at_or_after_its_stamp_and_gets_them_interpolated():
    sync, log = _recording()
    sync.angles(0.0, (0.0, 0.0, 0.0))
    sync.reference(0.0, None, (1.0, 2.0, 3.0))
    sync.gyro(0.0, 0.1, 0.2)
    sync.gyro(0.004, 0.3, 0.4)  # waits: no angles or rates at or after 4 ms yet
    assert log == [("integrate", 0.0, 0.1, 0.2, (0.0, 0.0, 0.0), (1.0, 2.0, 3.0))]
    sync.angles(0.01, (1.0, 0.0, -1.0))
    assert len(log) == 1  # the rates are still missing
    sync.reference(0.01, None, (2.0, 2.0, 5.0))
    t, angles, rates = log[-1][1], log[-1][4], log[-1][5]
    assert t == 0.004
    assert angles == pytest.approx((0.4, 0.0, -0.4)) and rates == pytest.approx((1.4, 2.0, 3.8))


def test_an_attitude_between_two_gyro_samples_is_fused_at_its_own_stamp():
    sync, log = _recording()
    for t in (0.0, 0.01):
        sync.angles(t, (t, 0.0, 0.0))
        sync.reference(t, None, (0.0, 0.0, 0.0))
        sync.gyro(t, 10.0 * t, 0.0)
    sync.angles(0.02, (0.02, 0.0, 0.0))
    assert sync.reference(0.015, "attitude", (0.0, 0.0, 0.0)) is None  # the gyro has not reached it
    sync.reference(0.02, None, (0.0, 0.0, 0.0))
    assert sync.gyro(0.02, 0.2, 0.0) is None  # fused on the way, before this sample's integration
    kinds = [entry[:2] for entry in log[-3:]]
    assert kinds == [("integrate", 0.015), ("fuse", 0.015), ("integrate", 0.02)]
    assert log[-3][2] == pytest.approx(0.15)  # the gyro rate interpolated to the attitude's stamp
    assert log[-2][2:] == ("attitude", pytest.approx((0.015, 0.0, 0.0)))


def test_a_stopped_stream_releases_the_gyro_after_the_wait_and_clear_forgets_everything():
    sync, log = _recording(max_wait_s=0.05)
    sync.angles(0.0, (0.0, 0.0, 0.0))
    sync.reference(0.0, "attitude", (0.0, 0.0, 0.0))
    sync.gyro(0.0, 0.0, 0.0)
    sync.gyro(0.01, 0.0, 0.0)
    assert [e[:2] for e in log] == [("integrate", 0.0), ("fuse", 0.0)]
    sync.angles(0.07, (0.0, 0.0, 0.0))  # 60 ms past the queued gyro sample: held rates
    assert log[-1][:2] == ("integrate", 0.01)
    sync.gyro(0.08, 0.0, 0.0)
    sync.clear()
    sync.angles(0.2, (0.0, 0.0, 0.0))
    sync.reference(0.2, None, (0.0, 0.0, 0.0))
    assert log[-1][:2] == ("integrate", 0.01)  # the queued 80 ms sample went with the clear
