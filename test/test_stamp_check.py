import math

from gimbal_kinematics.sync import Stamp, check_stamp


def test_stamp_verdicts():
    assert check_stamp(1.0, None, 0.5) is Stamp.OK
    assert check_stamp(1.001, 1.0, 0.5) is Stamp.OK
    assert check_stamp(1.0, 1.0, 0.5) is Stamp.OUT_OF_ORDER  # a duplicate is not new data
    assert check_stamp(0.6, 1.0, 0.5) is Stamp.OUT_OF_ORDER
    assert check_stamp(0.4, 1.0, 0.5) is Stamp.JUMPED_BACK
    assert check_stamp(math.nan, 1.0, 0.5) is Stamp.NONFINITE
    assert check_stamp(math.inf, None, 0.5) is Stamp.NONFINITE
