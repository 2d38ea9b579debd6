"""The one stamp vocabulary (gimbal_kinematics.timing.stamps) against hand-computed cases."""
import math

import pytest

from gimbal_kinematics.timing.stamps import Stamp, dropped_samples, jittered, judge


def test_stamp_verdicts():
    assert judge(1.0, None, 0.5) is Stamp.OK
    assert judge(1.001, 1.0, 0.5) is Stamp.OK
    assert judge(1.0, 1.0, 0.5) is Stamp.DUPLICATE  # a duplicate is not new data
    assert not Stamp.DUPLICATE.accepted
    assert judge(0.6, 1.0, 0.5) is Stamp.OUT_OF_ORDER
    assert judge(0.4, 1.0, 0.5) is Stamp.JUMPED_BACK
    assert judge(math.nan, 1.0, 0.5) is Stamp.NONFINITE
    assert judge(math.inf, None, 0.5) is Stamp.NONFINITE


def test_integer_nanosecond_stamps_and_the_jump_boundary():
    last = 1_800_000_000_000_000_000
    assert judge(last - 500_000_000, last, 500_000_000) is Stamp.OUT_OF_ORDER  # exactly the jump: late
    assert judge(last - 500_000_001, last, 500_000_000) is Stamp.JUMPED_BACK
    # used: in order, or the first of a confirmed new timeline either way; HELD waits for that confirmation
    assert [v for v in Stamp if v.accepted] == [Stamp.OK, Stamp.JUMPED_BACK, Stamp.JUMPED_AHEAD]


@pytest.mark.parametrize("interval, dropped, jitter", [
    (1000, 0, False),   # on time
    (1300, 0, False),   # +30 %: still within the jitter band
    (1301, 0, True),    # beyond 30 %, not a gap
    (700, 0, False),
    (699, 0, True),
    (1500, 0, True),    # 1.5 periods is not yet a gap
    (1501, 1, False),   # just over: round(1.501) - 1 = 1
    (2000, 1, False),
    (2499, 1, False),
    (2501, 2, False),   # round(2.501) - 1 = 2
    (10_000, 9, False),
])
def test_drop_rule_by_hand(interval, dropped, jitter):
    assert dropped_samples(interval, 1000) == dropped
    assert jittered(interval, 1000) is jitter
