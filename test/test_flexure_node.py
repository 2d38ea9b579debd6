"""flexure_estimator node (paper 5): bad input (NaN, a dropped LGU sample, an out-of-order
stamp, a backward clock jump, bad parameters) checked against the filter core fed directly,
and a short ship_flexure_band graph run read back with rosbags and replayed through the core."""
from __future__ import annotations

import math
import subprocess

import numpy as np
import pytest
import rclpy
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from geometry_msgs.msg import Vector3Stamped
from rosbags.highlevel import AnyReader

from conftest import VENV_BIN
from ros_harness import spin_until
from lgu_pairs import Counted, Fed
from gimbal_estimators.flexure_estimator_node import OUTPUTS, FlexureEstimatorNode
from gimbal_estimators.flexure_attitude_matching import AttitudeMatchingKf, AttitudeMatchingParams
from gimbal_estimators.flexure_kf import FlexureKf, FlexureKfParams
from gimbal_kinematics.ros import messages as m
from gimbal_kinematics.ros.qos import GRAPH_QOS
from gimbal_sim.world.sensor_suite import LguSample, SensorSuite, SensorSuiteConfig
from gimbal_sim.world.sensors import FlexureParams
from gimbal_sim.world.vehicle import VehicleConfig, VehicleCore

pytestmark = pytest.mark.ros
RATE = 10.0  # LGU = simulation rate, as in the ship_flexure scenario
DT = 1.0 / RATE
AS = math.pi / 180.0 / 3600.0
N_PAIRS = 900
#: The sea-wave band (peaked at 0.5 rad/s) in the truth and in the node alike: its flexure
#: moves several arcseconds per sample, so a sample lost and fused across would show.
SEA_BAND = {"dynamic_beta_per_s": [0.1, 0.1, 0.1], "dynamic_freq_rad_s": [0.5, 0.5, 0.5]}
KF_PARAMS = FlexureKfParams(**SEA_BAND)


@pytest.fixture(scope="module")
def lgu_samples() -> list[LguSample]:
    """90 s of the paper 5 ship with its two LGUs (gimbal_sim cores, seeded)."""
    vc = VehicleCore(VehicleConfig(profile="paper5_ship", plant="host_only", sim_rate_hz=RATE, duration_s=N_PAIRS * DT))
    flexure = FlexureParams(**{k: tuple(v) for k, v in SEA_BAND.items()})
    suite = SensorSuite(SensorSuiteConfig(sensors=("lgu",), sim_rate_hz=RATE, lgu_rate_hz=RATE, seed=3,
                                          flexure=flexure))
    out = []
    while True:
        out += [s for s in suite.update(vc.truth()) if isinstance(s, LguSample)]
        if vc.finished:
            return out
        vc.step()


def lgu_msg(unit: int, t_ns: int, dalpha, dt: float = DT):
    return m.imu_msg(t_ns, f"lgu{unit + 1}_frd", angular_velocity=[d / dt for d in dalpha])


def stream(samples, drop=(), nan=(), replay_old=(), jump_at=None):
    """(unit, message) in arrival order: LGU1 then LGU2 per sample. ``drop``: indices whose
    LGU2 message is lost; ``nan``: indices whose LGU1 rate has a NaN; ``replay_old``: after
    these indices, LGU1's message of 5 samples earlier arrives again (out of order);
    ``jump_at``: from this index on, stamps restart at the first sample's (a bag loop)."""
    for i, s in enumerate(samples):
        t_ns = m.step_stamp_ns(i + 1 if jump_at is None or i < jump_at else i + 1 - jump_at, RATE)
        d1 = list(s.dalpha1)
        if i in nan:
            d1[0] = math.nan
        yield 0, lgu_msg(0, t_ns, d1)
        if i not in drop:
            yield 1, lgu_msg(1, t_ns, s.dalpha2)
        if i in replay_old:
            yield 0, lgu_msg(0, m.step_stamp_ns(i + 1 - 5, RATE), samples[i - 5].dalpha1)


def core_run(params: FlexureKfParams, messages) -> tuple[FlexureKf, dict[int, np.ndarray]]:
    """The core fed the same messages directly: (core, {stamp ns: total flexure}); the
    original eq. 1 filter for :class:`AttitudeMatchingParams`."""
    kf = Fed(AttitudeMatchingKf(params) if isinstance(params, AttitudeMatchingParams) else FlexureKf(params))
    out = {}
    for unit, msg in messages:
        w = msg.angular_velocity
        feed = kf.on_lgu1 if unit == 0 else kf.on_lgu2
        est = feed(m.stamp_ns(msg.header.stamp) * 1e-9, (w.x * DT, w.y * DT, w.z * DT), DT)
        if est is not None:
            out[m.stamp_ns(msg.header.stamp)] = est.flexure
    return kf, out


def node_run(messages, name: str = "flex_test", **params):
    """The node (named ``name``) in this process; each message handed to its LGU callback,
    its outputs received over the graph. Returns (node's core, {topic: {stamp ns: (3,)}})."""
    context = Context()
    rclpy.init(context=context)
    overrides = {"timing": "lockstep", "lgu_rate_hz": RATE, "sim_rate_hz": RATE, **SEA_BAND, **params}
    args = ["--ros-args", "-r", f"__node:={name}"] + [a for k, v in overrides.items() for a in ("-p", f"{k}:={v}")]
    node = FlexureEstimatorNode(context=context, cli_args=args, use_global_arguments=False)
    harness = Node("harness", context=context)
    received: dict[str, dict[int, np.ndarray]] = {}
    counts: dict[str, int] = {}

    def on_msg(topic, msg):
        received[topic][m.stamp_ns(msg.header.stamp)] = np.array(m.vec_of(msg.vector))
        counts[topic] += 1

    def sub(topic):
        received[topic], counts[topic] = {}, 0
        harness.create_subscription(Vector3Stamped, topic, lambda msg: on_msg(topic, msg), GRAPH_QOS)

    for o in OUTPUTS:
        sub(f"/{name}/{o}")
        sub(f"/{name}/{o}_sigma")
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    executor.add_node(harness)
    try:
        # let the subscriptions match before anything is published
        assert spin_until(executor, lambda: all(p.get_subscription_count() >= 1 for t, p in node.edge.pubs.items()
                                                    if t not in ("~/progress", "/diagnostics")), 30.0)
        published = 0
        for unit, msg in messages:
            before = node.core.counters["updates"] + node.core.counters["gated"]
            node._on_lgu(unit, msg)
            published += node.core.counters["updates"] + node.core.counters["gated"] > before
            # take each estimate off the wire before the next (the readers keep the last 100)
            assert spin_until(executor, lambda: min(counts.values()) >= published, 10.0), "outputs not received"
        return Counted(node), received
    finally:
        executor.shutdown()
        node.destroy_node()
        harness.destroy_node()
        rclpy.shutdown(context=context)


@pytest.fixture(scope="module")
def clean(lgu_samples):
    msgs = list(stream(lgu_samples))
    core, received = node_run(msgs)
    return msgs, core, received


def truth_at(lgu_samples, t_ns):
    return np.array(lgu_samples[m.step_of_stamp(t_ns, RATE) - 1].flexure)


def lost_change(lgu_samples, i):
    """Flexure change over sample ``i``'s interval [rad] (3,): what fusing across its loss
    would leave in the relative attitude θ_d (the test run's is 1-4″, not negligible)."""
    change = np.array(lgu_samples[i].flexure) - np.array(lgu_samples[i - 1].flexure)
    assert np.max(np.abs(change)) > 2.0 * AS
    return change


def test_node_publishes_what_the_core_computes_on_its_private_topics(clean, lgu_samples):
    msgs, core, received = clean
    _, expected = core_run(KF_PARAMS, msgs)
    got = received["/flex_test/flexure"]
    assert sorted(got) == sorted(expected) and len(got) == N_PAIRS
    assert max(float(np.max(np.abs(got[k] - expected[k]))) for k in got) == 0.0
    assert all(len(v) == N_PAIRS for v in received.values())
    sig = received["/flex_test/flexure_sigma"]
    # The filter converges: the final error is inside its own 3σ and far below the 0.1° prior offset.
    last = max(got)
    err = got[last] - truth_at(lgu_samples, last)
    assert np.all(np.abs(err) < 3.0 * sig[last]) and np.all(np.abs(err) < 120 * AS)
    bias = received["/flex_test/bias_diff"][last]
    assert np.all(np.isfinite(bias)) and core.counters["resets"] == 0


def test_nan_sample_is_rejected_counted_and_bridged_by_a_reanchor(clean, lgu_samples):
    msgs = list(stream(lgu_samples, nan={400}))
    core, received = node_run(msgs)
    c = core.counters
    assert c["nonfinite"] == 1 and c["unpaired"] == 1 and c["gaps"] == 1 and c["reanchors"] == 1
    assert c["resets"] == 0
    got = received["/flex_test/flexure"]
    assert all(np.all(np.isfinite(v)) for topic in received.values() for v in topic.values())
    assert m.step_stamp_ns(401, RATE) not in got  # the broken pair produced no estimate
    _, expected = core_run(KF_PARAMS, msgs)
    assert max(float(np.max(np.abs(got[k] - expected[k]))) for k in got) == 0.0
    # What was learnt survives, and the flexure change over the hole does not stay in the
    # estimate (fused across, it would shift it by about that change, up to 4″ here).
    last = max(got)
    shift = np.abs(got[last] - clean[2]["/flex_test/flexure"][last])
    assert np.max(shift) < 0.25 * np.max(np.abs(lost_change(lgu_samples, 400))), shift / AS


def test_dropped_lgu_sample_is_detected_and_not_fused_across(clean, lgu_samples):
    msgs = list(stream(lgu_samples, drop={300}))
    core, received = node_run(msgs)
    c = core.counters
    # LGU1's lone sample is dropped with its partner; the interval's rotation is lost in
    # both units, so the attitudes restart (re-anchor) instead of matching across the hole.
    assert c["unpaired"] == 1 and c["gaps"] == 1 and c["reanchors"] == 1 and c["resets"] == 0
    assert c["nonfinite"] == c["out_of_order"] == 0
    got = received["/flex_test/flexure"]
    assert len(got) == N_PAIRS - 1
    last = max(got)
    shift = np.abs(got[last] - clean[2]["/flex_test/flexure"][last])
    assert np.max(shift) < 0.25 * np.max(np.abs(lost_change(lgu_samples, 300))), shift / AS


def test_out_of_order_stamp_is_rejected_without_any_effect(clean, lgu_samples):
    msgs = list(stream(lgu_samples, replay_old={200, 600}))
    core, received = node_run(msgs)
    assert core.counters["out_of_order"] == 2
    assert core.counters["reanchors"] == core.counters["resets"] == core.counters["gaps"] == 0
    got, ref = received["/flex_test/flexure"], clean[2]["/flex_test/flexure"]
    assert sorted(got) == sorted(ref)
    assert max(float(np.max(np.abs(got[k] - ref[k]))) for k in got) == 0.0


def test_rates_marked_not_provided_are_rejected_as_malformed(lgu_samples):
    msgs = list(stream(lgu_samples[:100]))
    msgs[81] = (0, m.imu_msg(m.stamp_ns(msgs[81][1].header.stamp), "lgu1_frd"))  # REP 145: [0] = -1
    core, received = node_run(msgs)
    c = core.counters
    assert c["malformed"] == 1 and c["unpaired"] == 1 and c["reanchors"] == 1 and c["resets"] == 0
    assert len(received["/flex_test/flexure"]) == 99


def test_backward_clock_jump_resets_and_starts_over(lgu_samples):
    msgs = list(stream(lgu_samples, jump_at=450))
    core, received = node_run(msgs)
    assert core.counters["resets"] == 1
    assert "backward clock jump" in core.last_reset_reason
    # after the reset the node is a fresh filter on the second half
    _, fresh = core_run(KF_PARAMS, list(stream(lgu_samples[450:])))
    got = received["/flex_test/flexure"]
    last = max(fresh)
    assert np.array_equal(got[last], fresh[last])


def test_model_original_runs_the_eq1_filter_on_the_same_messages(clean, lgu_samples):
    """``model: original`` publishes what the eq. 1 core fed the same messages directly
    publishes (per-unit bias models from σ_diff/√2), and not the simplified filter's."""
    msgs = list(stream(lgu_samples[:300]))
    core, received = node_run(msgs, name="flex_original", model="original")
    assert isinstance(core.node.core, AttitudeMatchingKf) and core.state.shape == (27,)
    _, ref = core_run(AttitudeMatchingParams.from_simplified(KF_PARAMS), msgs)
    got = received["/flex_original/flexure"]
    assert len(got) == 300 and sorted(got) == sorted(ref)
    assert all(np.array_equal(got[t], ref[t]) for t in ref)
    simplified = clean[2]["/flex_test/flexure"]
    assert max(float(np.max(np.abs(got[t] - simplified[t]))) for t in got) > 0.0


@pytest.mark.parametrize("args,named", [
    (["-p", "quasi_static_model:=random_constants"], "quasi_static_model"),
    (["-p", "sim_rate_hz:=10.0", "-p", "lgu_rate_hz:=4.0"], "lgu_rate_hz"),
    (["-p", "dynamic_rms_arcsec:=[20.0, 60.0]"], "dynamic_rms_arcsec"),
    (["-p", "model:=eq1"], "model"),
    (["-p", "model:=original", "-p", "lgu_bias_rw_deg_h_rt_h:=-0.001"], "lgu_bias_rw_deg_h_rt_h"),
])
def test_bad_parameters_are_refused_naming_them(args, named, ros_domain_env):
    result = subprocess.run([str(VENV_BIN / "flexure_estimator"), "--ros-args", *args], env=ros_domain_env,
                            capture_output=True, text=True, timeout=120)
    assert result.returncode == 2 and named in result.stderr, result.stderr


@pytest.mark.slow
def test_ship_flexure_graph_runs_both_models_side_by_side(ros_domain_env, tmp_path):
    """30 s of the ship_flexure_band scenario (the two estimators on the filter's own band) in container mode: both estimators (same
    executable, two node names) record their own topics, and replaying the recorded LGU
    messages through the core reproduces every recorded estimate: each node saw every
    sample with its own parameters."""
    out = tmp_path / "run"
    result = subprocess.run([str(VENV_BIN / "gimbal-run"), "ship_flexure_band", "--duration", "30", "--mode", "container",
                             "--out", str(out), "--no-progress"], env=ros_domain_env, capture_output=True, text=True,
                            timeout=900)
    assert result.returncode == 0, result.stderr[-3000:]
    nodes = {"flexure_random_constant": FlexureKfParams(quasi_static_model="random_constant", gate_probability=None),
             "flexure_random_walk_rate": FlexureKfParams(quasi_static_model="random_walk_rate")}
    lgu: list[tuple[int, int, tuple]] = []
    recorded: dict[str, dict[int, np.ndarray]] = {n: {} for n in nodes}
    with AnyReader([out]) as reader:
        counts = {c.topic: c.msgcount for c in reader.connections}
        wanted = {"/ship/lgu1/imu", "/ship/lgu2/imu"} | {f"/{n}/flexure" for n in nodes}
        for conn, _, raw in reader.messages(connections=[c for c in reader.connections if c.topic in wanted]):
            msg = reader.deserialize(raw, conn.msgtype)
            t_ns = msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec
            if conn.topic in ("/ship/lgu1/imu", "/ship/lgu2/imu"):
                w = msg.angular_velocity
                lgu.append((t_ns, int(conn.topic[9]) - 1, (w.x * DT, w.y * DT, w.z * DT)))
            for n in nodes:
                if conn.topic == f"/{n}/flexure":
                    recorded[n][t_ns] = np.array([msg.vector.x, msg.vector.y, msg.vector.z])
    assert counts["/ship/lgu1/imu"] == counts["/ship/lgu2/imu"] == 300
    for n in nodes:
        # one estimate per second of stamps (publish_period_s: 1), first at the first pair
        assert all(counts[f"/{n}/{o}{s}"] == 31 for o in OUTPUTS for s in ("", "_sigma"))
        assert counts[f"/{n}/progress"] >= 300 // 10
    lgu.sort(key=lambda r: (r[0], r[1]))
    for n, params in nodes.items():
        kf = Fed(FlexureKf(params))
        replay = {}
        for t_ns, unit, d in lgu:
            est = (kf.on_lgu1 if unit == 0 else kf.on_lgu2)(t_ns * 1e-9, d, DT)
            if est is not None:
                replay[t_ns] = est.flexure
        assert all(np.array_equal(v, replay[t]) for t, v in recorded[n].items()), n
    assert not np.allclose(recorded["flexure_random_constant"][30 * 10**9],
                           recorded["flexure_random_walk_rate"][30 * 10**9])
    import json
    metrics = json.loads((out / "report" / "metrics.json").read_text())
    assert set(metrics["estimators"]) == set(nodes)
    assert metrics["estimators"]["flexure_random_walk_rate"]["model"] == "random_walk_rate"
