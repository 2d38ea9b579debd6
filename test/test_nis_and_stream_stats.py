"""NisWindow against Monte Carlo innovations of known covariance, and StreamStats on a
synthetic epoch-stamped stream with jitter, drops, duplicates and out-of-order samples."""
from __future__ import annotations

import math

import numpy as np
import pytest

from gimbal_estimators.nis import NisWindow
from gimbal_kinematics.timing.stamps import JUMP_SAMPLES, Stamp as Verdict
from gimbal_kinematics.timing.stream_stats import StreamStats


def _window_verdicts(scale: float, windows: int, n: int, rng) -> list[str]:
    """Verdicts of ``windows`` independent windows of ``n`` 3-dof innovations drawn with
    covariance scale·S while the filter states S (S random SPD)."""
    out = []
    for _ in range(windows):
        w = NisWindow(dof=3, window=n)
        A = rng.normal(size=(3, 3))
        S = A @ A.T + 3 * np.eye(3)
        L = np.linalg.cholesky(scale * S)
        Sinv = np.linalg.inv(S)
        for y in (L @ rng.normal(size=(3, n))).T:
            w.add(float(y @ Sinv @ y))
        out.append(w.verdict().verdict)
    return out


def test_a_consistent_filter_is_within_the_95_percent_bounds_95_percent_of_the_time():
    rng = np.random.default_rng(20240516)
    verdicts = _window_verdicts(1.0, 1000, 50, rng)
    inside = verdicts.count("consistent") / len(verdicts)
    # binomial(1000, 0.95): sigma = 0.0069; 4 sigma
    assert abs(inside - 0.95) < 4 * math.sqrt(0.95 * 0.05 / 1000), inside
    # two-sided: about as many windows above as below
    assert abs(verdicts.count("overconfident") - verdicts.count("conservative")) < 25


@pytest.mark.parametrize("scale, word", [(2.0, "overconfident"), (0.5, "conservative")])
def test_a_wrong_covariance_is_flagged(scale, word):
    rng = np.random.default_rng(7)
    verdicts = _window_verdicts(scale, 200, 100, rng)
    assert verdicts.count(word) / len(verdicts) > 0.99


def test_window_slides_and_bounds_follow_the_sample_count():
    w = NisWindow(dof=2, window=20, min_samples=5)
    assert w.verdict().verdict == "insufficient"
    for _ in range(4):
        w.add(2.0)
    assert w.verdict().verdict == "insufficient" and w.verdict().samples == 4
    for _ in range(30):
        w.add(100.0)
    v = w.verdict()
    assert v.samples == 20 and v.mean == 100.0 and v.verdict == "overconfident"
    w.add(math.nan)
    assert w.rejected_nonfinite == 1 and w.verdict().samples == 20
    # the bounds narrow around dof as the window grows
    lo5, hi5 = w.bounds(5)
    lo20, hi20 = w.bounds(20)
    assert lo5 < lo20 < 2.0 < hi20 < hi5


def test_stream_stats_counts_an_epoch_stream_with_jitter_drops_duplicates_and_late_samples():
    rng = np.random.default_rng(3)
    t0 = 1_800_000_000_000_000_000  # 1.8e9 s in ns
    period = 5_000_000  # 200 Hz
    intervals = period * rng.uniform(0.7, 1.3, 2000)  # each interval +-30 % of the period
    stamps = (t0 + np.cumsum(intervals)).astype(np.int64)
    keep = np.ones(stamps.size, bool)
    drop_idx = rng.choice(np.arange(10, stamps.size - 1), 40, replace=False)
    keep[drop_idx] = False
    seq = [int(s) for s in stamps[keep]]
    # duplicates and swapped pairs at chosen places (away from the drops)
    dup_at, swap_at = [100, 700, 1500], [300, 1100]
    events = []
    for i, s in enumerate(seq):
        events.append(s)
        if i in dup_at:
            events.append(s)
    for j in swap_at:
        events[j], events[j + 1] = events[j + 1], events[j]
    st = StreamStats(jump_ns=500_000_000)
    verdicts = [st.offer(s) for s in events]
    assert st.duplicates == 3 and verdicts.count(Verdict.DUPLICATE) == 3
    assert st.out_of_order == 2 and verdicts.count(Verdict.OUT_OF_ORDER) == 2
    # ±30 % jitter alone never reads as a drop (1.3 < 1.5 periods). A dropped sample leaves
    # a gap of two intervals, in [1.4, 2.6] periods: below 1.5 with probability 0.1²/0.72
    # = 1.4 %, so about 0.6 of the 40 are missed. Each swapped pair's late sample is
    # rejected, leaving a gap too (+2).
    assert 40 + 2 - 3 <= st.dropped <= 40 + 2, st.dropped
    assert st.period_ns == pytest.approx(period, rel=0.05)
    # uniform(0.7, 1.3) intervals: RMS deviation 0.3/sqrt(3)
    assert st.jitter_rms == pytest.approx(0.3 / math.sqrt(3), rel=0.1)
    assert st.received == len(events)
    # a bag loop: far back is a jump, accepted once JUMP_SAMPLES stamps in a row agree on it
    loop = [t0 + i * period for i in range(JUMP_SAMPLES)]
    assert [st.offer(s) for s in loop] == [Verdict.HELD] * (JUMP_SAMPLES - 1) + [Verdict.JUMPED_BACK]
    assert st.jumps == 1 and st.released == tuple(loop[:-1]) and st.outliers == 0
