"""The LOS rate controller's operator input: the shaped operator command
joins the stabilisation reference (LosRateController.reference), its parameters come from
the node's values, and a controller nobody commands computes what it did without one.

References: the slew-rate limiter's closed form for a step command (min(|v|, a (t − t_c)));
the dead-man deadline (stamp + timeout + |v|/a); a controller built without the shaper.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from gimbal_control.los_rate_controller import LosRateController, LosRateControllerParams
from gimbal_control.los_rate_controller_params import PARAMS
from gimbal_control.operator_command import OperatorCommandParams
from gimbal_kinematics.params.table import ParameterError, defaults
from gimbal_kinematics.timing.stamps import step_stamp_ns
from operator_shaper import Shaper

RATE = 1000.0
AZ, EL = math.radians(5.0), math.radians(2.0)


def _values(**kw):
    v = defaults(PARAMS)
    v.update(kw)
    return v


def _inputs(rng, n):
    """Seeded random controller inputs (gyro, encoders, rates, INS) of n steps."""
    return [((rng.normal(0, 1e-2), rng.normal(0, 1e-2)), tuple(rng.normal(0, 0.2, 3)), tuple(rng.normal(0, 0.1, 3)),
             tuple(rng.normal(0, 0.05, 3))) for _ in range(n)]


def test_node_values_map_to_the_shaper_with_the_default_limits():
    p = OperatorCommandParams.from_values(_values())
    assert p == OperatorCommandParams()  # defaults of the node = the shaper's argued defaults
    assert OperatorCommandParams.from_values(_values(joy_scale_rad_s=0.1)).joy_scale_rad_s == 0.1


@pytest.mark.parametrize("name,value", [("operator_max_rate_deg_s", -1.0), ("operator_max_accel_deg_s2", 0.0),
                                        ("operator_timeout_s", math.nan), ("joy_scale_rad_s", 1.0),
                                        ("joy_elevation_axis", 0)])
def test_bad_operator_params_refused_naming_the_node_parameter(name, value):
    with pytest.raises(ParameterError, match=name):
        OperatorCommandParams.from_values(_values(**{name: value}))


def test_no_command_no_change():
    rng = np.random.default_rng(7)
    plain = LosRateController(LosRateControllerParams())
    op = Shaper()
    shaped = LosRateController(LosRateControllerParams(), operator=op.core)
    for k, (gyro, ang, rates, ins) in enumerate(_inputs(rng, 400)):
        ref = shaped.reference(op.stamps.step(step_stamp_ns(k, RATE)))
        assert ref is None
        assert shaped.step(k / RATE, gyro, ang, rates, ins, ref) == plain.step(k / RATE, gyro, ang, rates, ins)


def test_step_command_is_added_to_the_outer_loop_command_with_the_accel_limit():
    op = Shaper()
    core = LosRateController(LosRateControllerParams(), operator=op.core)
    hold = (1e-4, -2e-4)
    core.set_rate_command(*hold)
    t_c = step_stamp_ns(10, RATE) + 300_000  # between two steps
    assert op.set_rate(t_c, EL, AZ)
    a = op.max_accel
    for k in range(0, 200):
        t = step_stamp_ns(k, RATE)
        ref = core.reference(op.stamps.step(t))
        ramp = max(0.0, (t - t_c) * 1e-9) * a
        want = (min(EL, ramp), min(AZ, ramp))
        if want == (0.0, 0.0):
            assert ref is None
        else:
            np.testing.assert_allclose(ref, (hold[0] + want[0], hold[1] + want[1]), rtol=0, atol=1e-12)


def test_deadman_stops_the_slew_and_counts_it():
    op = Shaper()
    core = LosRateController(LosRateControllerParams(), operator=op.core)
    timeout_ns = int(op.params.timeout_s * 1e9)
    t_c = 0
    for k in range(0, 50):  # commands at 20 Hz for the first 50 ms... then they stop
        if k % 50 == 0:
            assert op.set_rate(step_stamp_ns(k, RATE), 0.0, AZ)
    stop_by = t_c + timeout_ns + int(AZ / op.max_accel * 1e9) + 1
    last_moving = None
    for k in range(0, 1000):
        t = step_stamp_ns(k, RATE)
        if core.reference(op.stamps.step(t)) is not None:
            last_moving = t
    assert op.deadman_stops == 1
    assert op.holding
    assert last_moving is not None and timeout_ns < last_moving < stop_by
    assert op.last_stop_ns is not None and abs(op.last_stop_ns - (stop_by - 1)) <= 1


def test_bad_operator_commands_are_counted_never_acted_on():
    op = Shaper()
    core = LosRateController(LosRateControllerParams(), operator=op.core)
    assert not op.set_rate(1, math.nan, 0.0)
    assert not op.set_rate(2, 0.0, math.inf)
    assert not op.set_rate(3, 0.0, math.radians(10.5))  # above the 10 °/s limit
    assert all(core.reference(op.stamps.step(step_stamp_ns(k, RATE))) is None for k in range(100))
    c = op.counters()
    assert (c["rejected_nonfinite"], c["rejected_over_limit"], c["commands_accepted"]) == (2, 1, 0)
