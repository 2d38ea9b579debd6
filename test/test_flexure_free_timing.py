"""flexure_estimator in free timing (its default when started alone): epoch stamps near
1.8e9 s, intervals from the stamps with ±30 % jitter, duplicates, a late sample and a lost
one, each counted on /diagnostics with the NIS window; checked against the core fed on a
grid from 0 (the lockstep run's time axis), against the core fed absolute float seconds,
and against a core fed only the clean samples with their true intervals."""
from __future__ import annotations

import math

import numpy as np
import pytest
import rclpy
from rclpy.context import Context

from lgu_pairs import Counted, Fed
from gimbal_estimators.flexure_estimator_node import FlexureEstimatorNode
from gimbal_estimators.flexure_kf import FlexureKf
from gimbal_kinematics.ros import messages as m
from test_flexure_node import KF_PARAMS, N_PAIRS, RATE, SEA_BAND, core_run, lgu_msg, lgu_samples, \
    stream  # noqa: F401  (lgu_samples: the fixture)

pytestmark = pytest.mark.ros
EPOCH_NS = 1_800_000_000_000_000_000
PERIOD_NS = int(1e9 / RATE)


def free_run(messages, **params) -> tuple[object, dict[str, dict[int, np.ndarray]], list[dict[str, str]]]:
    """The node in free timing, in this process, each message handed to its LGU callback;
    its publishers recorded. Returns (core, {topic: {stamp ns: (3,)}}, [/diagnostics values])."""
    context = Context()
    rclpy.init(context=context)
    args = ["--ros-args", "-r", "__node:=flex_free"] + [
        a for k, v in {"lgu_rate_hz": RATE, "sim_rate_hz": RATE, "diagnostics_period_s": 1.0,
                       **SEA_BAND, **params}.items() for a in ("-p", f"{k}:={v}")]
    node = FlexureEstimatorNode(context=context, cli_args=args, use_global_arguments=False)
    out: dict[str, dict[int, np.ndarray]] = {}
    diags: list[dict[str, str]] = []

    def recorder(topic):
        out[topic] = {}
        # the node publishes serialized messages (gimbal_estimators.wire)
        return lambda data: (msg := m.vector3_stamped_from_cdr(data)) and \
            out[topic].__setitem__(msg.stamp_ns, np.array(msg.vector))

    try:
        assert node.policy.timing == "free" and "/diagnostics" in node.edge.pubs
        for topic, pub in ((t[2:], p) for t, p in node.edge.pubs.items() if t.startswith("~/") and t != "~/progress"):
            pub.publish = recorder(topic)
        node.edge.pubs["/diagnostics"].publish = lambda msg: diags.extend({kv.key: kv.value for kv in s.values}
                                                                          for s in msg.status)
        for unit, msg in messages:
            node._on_lgu(unit, msg)
        return Counted(node), out, diags
    finally:
        node.destroy_node()
        rclpy.shutdown(context=context)


def shifted(messages, offset_ns: int):
    """The same messages with every stamp moved by ``offset_ns``."""
    for unit, msg in messages:
        t = m.stamp_ns(msg.header.stamp) + offset_ns
        msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(t, 10**9)
        yield unit, msg


def test_epoch_stamps_compute_what_the_grid_from_zero_computes(lgu_samples):
    grid = list(stream(lgu_samples))
    _, expected = core_run(KF_PARAMS, grid)          # t = stamp [s] from 0.1 s, as in lockstep
    core, out, diags = free_run(list(shifted(stream(lgu_samples), EPOCH_NS)))
    got = out["flexure"]
    assert len(got) == N_PAIRS and core.counters["resets"] == core.counters["gaps"] == 0
    # relative int-ns time: equal to the grid's up to rounding of the (shifted) time axis
    worst = max(float(np.max(np.abs(got[t + EPOCH_NS] - v))) for t, v in expected.items())
    # (the propagation intervals t - t_kf round differently on a shifted axis: ulp-level dt
    # differences, amplified to ~1e-10 rad = 2e-5 arcsec over 900 steps)
    assert worst < 1e-9, worst
    # the same core on absolute float seconds near 1.8e9 s (resolution 2.4e-7 s) does worse
    core_abs, absolute = core_run(KF_PARAMS, list(shifted(stream(lgu_samples), EPOCH_NS)))
    common = [t for t in expected if t + EPOCH_NS in absolute]
    worst_abs = max(float(np.max(np.abs(absolute[t + EPOCH_NS] - expected[t]))) for t in common) if common else math.inf
    print(f"epoch stamps: relative int ns -> {worst:.3g} rad, absolute float s -> {worst_abs:.3g} rad "
          f"({len(common)}/{len(expected)} estimates, core counters {core_abs.counters})")
    assert worst_abs > 10.0 * worst
    d = diags[-1]
    assert int(d["lgu1_received"]) == int(d["lgu2_received"]) >= N_PAIRS - 10
    for key in ("lgu1_duplicates", "lgu1_out_of_order", "lgu1_dropped", "lgu2_dropped", "nonfinite", "gated",
                "incompatible_qos"):
        assert int(d[key]) == 0, (key, d)
    assert int(d["nis_dof"]) == 3 and int(d["nis_window"]) > 0
    lo, hi, mean = float(d["nis_lower_95"]), float(d["nis_upper_95"]), float(d["nis_mean"])
    assert lo < 3.0 < hi and math.isfinite(mean)
    assert d["nis_verdict"] in ("consistent", "conservative", "overconfident")


def test_jitter_duplicates_late_and_lost_samples_are_counted_and_not_fused(lgu_samples):
    rng = np.random.default_rng(16)
    t_ns, stamps = EPOCH_NS, []
    for _ in lgu_samples:
        t_ns += int(PERIOD_NS * (1.0 + rng.uniform(-0.3, 0.3)))
        stamps.append(t_ns)
    msgs, clean = [], []  # clean: (unit, stamp, increment, true interval) the node may integrate
    for i, s in enumerate(lgu_samples):
        dt = (stamps[i] - stamps[i - 1]) * 1e-9 if i else 1.0 / RATE
        # an LGU publishes its increment over its real interval: rate = dalpha / dt
        for unit, d in ((0, s.dalpha1), (1, s.dalpha2)):
            if unit == 1 and i == 500:
                continue                                              # LGU2's sample lost
            msgs.append((unit, lgu_msg(unit, stamps[i], d, dt)))
            if not (unit == 1 and i == 501):  # the one after the loss: interval unknown to the node
                clean.append((unit, stamps[i], d, dt))
        if i == 300:
            msgs.append((0, lgu_msg(0, stamps[i], [1e-3, 1e-3, 1e-3], dt)))     # duplicate stamp
        if i == 400:
            msgs.append((0, lgu_msg(0, stamps[i - 2], [1e-3, 1e-3, 1e-3], dt)))  # late (backwards)
    core, out, diags = free_run(msgs)
    d = diags[-1]
    assert int(d["lgu1_duplicates"]) == 1 and int(d["lgu1_out_of_order"]) == 1, d
    assert int(d["lgu2_dropped"]) == 1 and int(d["lgu1_dropped"]) == 0, d
    assert int(d["lgu2_interval_unknown"]) == 1 and int(d["lgu1_interval_unknown"]) == 0, d
    assert 0.1 < float(d["lgu1_jitter_rms"]) < 0.25, d        # uniform ±30 %: RMS 0.17
    c = core.counters
    # the lost sample: LGU1's samples 500 and 501 dropped unpaired, attitudes re-anchored
    assert c["unpaired"] == 2 and c["gaps"] == 1 and c["reanchors"] == 1 and c["resets"] == 0, c
    assert c["bad_dt"] == 0 and c["duplicates"] == c["out_of_order"] == 0, c  # caught before the core
    got = out["flexure"]
    # one estimate per filter step: the filter steps once filter_period_s (0.1 s) has elapsed
    # since the last, so with jittered intervals not on every pair; never on a broken one
    assert len(got) == c["updates"] + c["gated"] and 0.7 * N_PAIRS < len(got) < N_PAIRS
    assert stamps[500] not in got and stamps[501] not in got
    # none fused: a core fed the clean samples with their true intervals, on the relative time
    ref = Fed(FlexureKf(KF_PARAMS))
    expected = {}
    for unit, t, dalpha, dt in clean:
        est = (ref.on_lgu1 if unit == 0 else ref.on_lgu2)((t - stamps[0]) * 1e-9, dalpha, dt)
        if est is not None:
            expected[t] = est.flexure
    assert sorted(expected) == sorted(got)
    worst = max(float(np.max(np.abs(got[t] - v))) for t, v in expected.items())
    assert worst < 1e-12, worst  # rate * dt round trip: a few ulps
    assert d["nis_verdict"] in ("consistent", "conservative", "overconfident")
