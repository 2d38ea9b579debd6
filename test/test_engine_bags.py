"""The engine writes the graph's bag: every deterministic built-in scenario (every variant
that is not another case run again) run briefly in the graph (container mode, in this
process) and on the engine gives the same data on every topic both carry (``gimbal-bench
compare``'s :func:`compare_bags`, which reads the bags with the ``mcap`` library and decodes
differing payloads with rclpy), the graph alone carrying only what docs/architecture.md
lists; per-topic record rates keep the same messages in both; a campaign of three seeds on
the engine leaves three bags that ``rosbags`` reads, and its figure recomputed from them
equals the reported one.
"""
from __future__ import annotations

import dataclasses
import math
import subprocess

import numpy as np
import pytest
from rosbags.highlevel import AnyReader

from conftest import VENV_BIN

from gimbal_sim.bag.compare import compare_bags
from gimbal_sim.core.core_loop import NoCoreError
from gimbal_sim.core.engine_run import check_engine, run_engine
from gimbal_sim.graph.orchestrator import run
from gimbal_sim.graph.scenario import apply_set, builtin_scenarios, load, variant

#: Steps per scenario: enough for every node to publish (the 100 Hz INS and the EKF's
#: outputs, the operator's commands, free-gyro fixes, flexure estimates) and cheap in the graph.
STEPS = 500
#: Overrides that make a node publish within STEPS (the alignment's averaging block, the
#: scripted stick's step).
SETS = {"rotational_ins_alignment": ["platform_alignment.block_s=0.05"],
        "sighting_slew": ["operator.step_start_s=0.2", "operator.step_duration_s=0.2"]}


#: Variants that are another case run again, left out: {(scenario, variant): the scenario it
#: equals}. ship_flexure_sea_states' sea_state_4 is ship_flexure (the same nodes, parameters,
#: rate and seed).
SAME_AS_ANOTHER_CASE = {("ship_flexure_sea_states", "sea_state_4"): "ship_flexure"}


def _deterministic_cases() -> list[tuple[str, str]]:
    """(scenario, variant) of every built-in scenario the engine steps, lockstep timing only
    (a realtime or free-timing node depends on the wall clock: no two runs are equal)."""
    cases = []
    for name in builtin_scenarios():
        base = load(name)
        for v in list(base.variants) or [""]:
            if (name, v) in SAME_AS_ANOTHER_CASE:
                continue
            single = variant(base, v) if v else base
            if single.prelude:
                continue
            try:
                check_engine(single)
            except NoCoreError:
                continue
            cases.append((name, v))
    return cases


CASES = _deterministic_cases()


def _short(name: str, v: str, **changes):
    single = variant(load(name), v) if v else load(name)
    for assignment in SETS.get(name, []):
        single = apply_set(single, assignment)
    return dataclasses.replace(single, duration_s=STEPS / single.sim_rate_hz, **changes)


def _graph_only(topic: str) -> bool:
    return topic == "/diagnostics" or topic.endswith("/progress")


def _same_data(graph_dir, engine_dir) -> None:
    diff = compare_bags(graph_dir, engine_dir)
    only_graph = {t for t, d in diff.topics.items() if d.count_b == 0}
    only_engine = {t for t, d in diff.topics.items() if d.count_a == 0}
    assert not only_engine, f"topics the graph does not carry: {only_engine}"
    assert all(_graph_only(t) for t in only_graph), f"graph topics the engine skips: {only_graph}"
    both = {t: d for t, d in diff.topics.items() if t not in only_graph}
    assert both and all(d.comparable and d.values_equal for d in both.values()), \
        "\n".join(line for line in diff.lines() if "identical" not in line)


def test_the_cases_cover_the_sighting_family_and_the_open_loop_sensors():
    names = {n for n, _ in CASES}
    assert {"sighting_land_vehicle", "sighting_operator", "sighting_geo_pointing", "sim_open_loop",
            "gyro_at_rest", "ship_lgu_open_loop"} <= names
    assert {"rotational_ins_navigation", "rotational_ins_alignment", "rotational_platform_servo", "ship_flexure_turn",
            "free_gyro_sailing", "gimbal_encoder_fusion"} <= names
    assert ("sighting_realtime", "") not in CASES
    for (name, v), other in SAME_AS_ANOTHER_CASE.items():  # left out only while it is that case run again
        assert (other, "") in CASES
        left_out, kept = variant(load(name), v), load(other)
        assert all(getattr(left_out, f.name) == getattr(kept, f.name) for f in dataclasses.fields(kept)
                   if f.name not in ("name", "description")), (name, v, other)


@pytest.mark.parametrize("name,v", CASES, ids=[f"{n}:{v}" if v else n for n, v in CASES])
def test_graph_and_engine_record_the_same_data(name, v, tmp_path):
    scenario = _short(name, v)
    run(scenario, tmp_path / "graph", "container", progress=False)
    run_engine(scenario, tmp_path / "engine")
    _same_data(tmp_path / "graph", tmp_path / "engine")


def test_the_platform_on_a_moving_base_records_the_same_data_in_the_graph_and_on_the_engine(tmp_path):
    """``platform_base_motion`` on paper 5's ship at the 50 Hz rate, the navigator on the
    resolver (the built-in ship variants, at 1 kHz on the servo's φz, are cases above) gives
    the graph's bag."""
    scenario = _short("rotational_ins_navigation", "rotation_on")
    for assignment in ("vehicle_dynamics.profile=paper5_ship", "vehicle_dynamics.platform_base_motion=true"):
        scenario = apply_set(scenario, assignment)
    scenario = dataclasses.replace(scenario, duration_s=4.0)
    run(scenario, tmp_path / "graph", "container", progress=False)
    run_engine(scenario, tmp_path / "engine")
    _same_data(tmp_path / "graph", tmp_path / "engine")


def test_record_rates_keep_the_same_messages_in_the_recorder_and_the_engine(tmp_path):
    rates = {"/truth/gimbal/imu": 50.0, "/gimbal/imu": 0.0, "/truth/host/delta_angle": 7.0}
    scenario = _short("sighting_land_vehicle", "ekf_on", record_rates_hz=rates)
    run(scenario, tmp_path / "graph", "container", progress=False)
    run_engine(scenario, tmp_path / "engine")
    _same_data(tmp_path / "graph", tmp_path / "engine")
    with AnyReader([tmp_path / "engine"]) as reader:
        counts = {c.topic: c.msgcount for c in reader.connections}
        stamps = [m.header.stamp.sec * 10**9 + m.header.stamp.nanosec for c, _, raw in reader.messages(
            [c for c in reader.connections if c.topic == "/truth/host/delta_angle"])
            for m in [reader.deserialize(raw, c.msgtype)]]
    # steps 0..500 at 1 kHz: 50 Hz keeps every 20th, 7 Hz the first at or after each 1/7 s
    assert counts["/truth/gimbal/imu"] == 26 and counts["/gimbal/imu"] == 501
    period = round(1e9 / 7.0)
    expected, due = [], 0
    for k in range(STEPS + 1):
        if k * 1_000_000 >= due:
            expected.append(k * 1_000_000)
            due = k * 1_000_000 + period
    assert stamps == expected


def _final_bias_error_deg_h(bag_dir) -> tuple[float, float]:
    """(q, r) of the last EKF bias estimate minus the true gyro bias at its stamp [deg/h],
    from the bag as rosbags reads it."""
    wanted = {"/gyro_bias_ekf/bias": {}, "/truth/gimbal/gyro_bias": {}}
    with AnyReader([bag_dir]) as reader:
        for conn, _, raw in reader.messages([c for c in reader.connections if c.topic in wanted]):
            msg = reader.deserialize(raw, conn.msgtype)
            wanted[conn.topic][msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec] = (msg.vector.y, msg.vector.z)
    est = wanted["/gyro_bias_ekf/bias"]
    last = max(est)
    true = wanted["/truth/gimbal/gyro_bias"][last]
    deg_h = math.degrees(1.0) * 3600.0
    return (est[last][0] - true[0]) * deg_h, (est[last][1] - true[1]) * deg_h


def test_an_engine_campaign_of_three_seeds_keeps_three_bags_whose_figure_is_the_reported_one(tmp_path):
    from gimbal_sim.campaign.spec import spec_from_mapping
    from gimbal_sim.experiments.registry import run_campaign

    spec = spec_from_mapping({"scenario": "sighting_land_vehicle", "variants": ["ekf_on"], "seeds": [1, 2, 3],
                              "duration_s": 0.5, "engine": "core"}, "campaign")
    result = run_campaign(spec, tmp_path / "campaign", serial=True, progress=False)
    assert len(result.rows) == 3 and all(row["status"] == "ok" and row["bag_kept"] for row in result.rows)
    bags = sorted((tmp_path / "campaign" / "runs").glob("*/metadata.yaml"))
    assert len(bags) == 3
    finals = []
    for row in result.rows:
        q, r = _final_bias_error_deg_h(tmp_path / "campaign" / "runs" / row["run_id"])
        assert q == pytest.approx(row["metrics"]["sighting.final_bias_error_deg_h.q"], rel=1e-12, abs=1e-9)
        assert r == pytest.approx(row["metrics"]["sighting.final_bias_error_deg_h.r"], rel=1e-12, abs=1e-9)
        finals.append(q)
    assert len(set(np.round(finals, 9))) == 3  # three seeds, three different runs


def test_gimbal_bag_play_replays_an_engine_bag(tmp_path, ros_domain_env):
    run_engine(_short("sighting_operator", "ekf_on"), tmp_path / "engine")
    with AnyReader([tmp_path / "engine"]) as reader:
        count = reader.message_count
    result = subprocess.run([str(VENV_BIN / "gimbal-bag"), "play", str(tmp_path / "engine"), "--rate", "0"],
                            env=ros_domain_env, capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stderr[-2000:]
    assert f"played {count} messages" in result.stdout + result.stderr
