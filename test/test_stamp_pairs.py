"""StampPairs pairs two streams on equal stamps, whatever order the samples come in, and
refuses what a pair-taking core must not see: a repeated stamp, one at or before the last
pair taken, a sample whose partner never comes."""
from __future__ import annotations

import itertools
import math

import pytest

from gimbal_kinematics.timing.sync import StampPairs


class Core:
    """A pair-taking core: refuses a NaN value, takes pairs, starts over on :meth:`reset`."""

    def __init__(self) -> None:
        self.pairs: list[tuple[float, float, float]] = []
        self.paired_until = math.nan
        self.on_reset = None

    def check_sample(self, t, value):
        return None if math.isnan(value) else (float(t), float(value))

    def on_pair(self, t, a, b):
        self.pairs.append((t, a[0], b[0]))
        self.paired_until = t
        return t

    def reset(self) -> None:
        self.paired_until = math.nan
        self.on_reset()


@pytest.mark.parametrize("order", list(itertools.permutations(range(4))))
def test_pairs_form_on_equal_stamps_in_any_arrival_order_within_a_stamp(order):
    core = Core()
    pairs = StampPairs.feeding(core)
    samples = [(0, 0.1, 1.0), (1, 0.1, 2.0), (0, 0.2, 3.0), (1, 0.2, 4.0)]
    # within a stamp either unit may come first; stamps themselves in order
    for k in sorted(order, key=lambda i: samples[i][1]):
        pairs.add(*samples[k])
    assert core.pairs == [(0.1, 1.0, 2.0), (0.2, 3.0, 4.0)]
    assert pairs.counts == {"out_of_order": 0, "duplicates": 0, "unpaired": 0}


def test_repeated_late_and_unpaired_samples_are_refused_and_counted():
    core = Core()
    pairs = StampPairs.feeding(core)
    assert pairs.add(0, 0.1, 1.0) is None and pairs.add(0, 0.1, 1.0) is None  # waiting; then repeated
    assert pairs.add(1, 0.1, 2.0) == 0.1
    assert pairs.add(1, 0.1, 2.0) is None  # at the last pair taken: late
    assert pairs.add(0, 0.2, float("nan")) is None  # the core refused it: not counted here
    pairs.add(1, 0.2, 5.0)  # its partner was refused: waits in vain
    pairs.add(0, 0.3, 6.0)
    assert pairs.add(1, 0.3, 7.0) == 0.3  # the older lone sample can no longer pair
    assert pairs.counts == {"out_of_order": 1, "duplicates": 1, "unpaired": 1}
    assert core.pairs == [(0.1, 1.0, 2.0), (0.3, 6.0, 7.0)]


def test_a_core_starting_over_forgets_the_waiting_samples_and_the_bound_holds():
    core = Core()
    pairs = StampPairs.feeding(core, max_pending=2)
    for t in (0.1, 0.2, 0.3):
        pairs.add(0, t, 1.0)
    assert pairs.counts["unpaired"] == 1  # the oldest of three, beyond the bound of two
    core.reset()
    assert pairs.add(1, 0.3, 2.0) is None and core.pairs == []  # its partner was forgotten
    with pytest.raises(ValueError, match="max_pending"):
        StampPairs.feeding(Core(), max_pending=0)
