"""Scenario variants: validation of the overrides and the single-run scenarios they give."""
from __future__ import annotations

import pytest
import yaml

from gimbal_sim.graph.scenario import ScenarioError, builtin_scenarios, load, validate, variant


def _base() -> dict:
    return yaml.safe_load(builtin_scenarios()["sighting_land_vehicle"].read_text())


def test_builtin_variants_differ_only_in_their_overrides():
    s = load("sighting_land_vehicle")
    assert list(s.variants) == ["ekf_off", "ekf_on"] and s.comparison == "sighting"
    off, on = variant(s, "ekf_off"), variant(s, "ekf_on")
    assert off.nodes["los_rate_controller"]["params"]["feedback"] is False
    assert on.nodes["los_rate_controller"]["params"]["feedback"] is True
    assert off.seed == on.seed == s.seed and not off.variants and on.name == "sighting_land_vehicle:ekf_on"
    for name in s.nodes:
        if name != "los_rate_controller":
            assert off.nodes[name] == on.nodes[name] == s.nodes[name]


def test_a_variant_may_change_the_seed_and_nothing_else_leaks():
    data = _base()
    data["variants"] = {"a": {"seed": 7}, "b": {"los_rate_controller.zeta": 1}}
    s = validate(data)
    assert variant(s, "a").seed == 7 and variant(s, "b").seed == data["seed"]
    assert variant(s, "b").nodes["los_rate_controller"]["params"]["zeta"] == 1.0  # int accepted for a float


@pytest.mark.parametrize("variants, comparison, message", [
    ({"x": {"los_rate_controller.no_such": 1}}, "sighting", "no_such"),
    ({"x": {"ghost.feedback": True}}, "sighting", "ghost.feedback"),
    ({"x": {"seed": -1}}, "sighting", "seed"),
    ({"x": {"los_rate_controller.feedback": "yes"}}, "sighting", "feedback"),
    ({"x y": {}}, "sighting", "variant name"),
    ({"x": {"seed": 1}}, "", "comparison"),
])
def test_bad_variants_are_refused_naming_the_culprit(variants, comparison, message):
    data = _base()
    data["variants"], data["comparison"] = variants, comparison
    with pytest.raises(ScenarioError, match=message):
        validate(data)


def test_unknown_variant_is_refused():
    with pytest.raises(ScenarioError, match="no variant 'nope'"):
        variant(load("sighting_land_vehicle"), "nope")


@pytest.mark.ros
def test_concurrent_variants_record_what_sequential_ones_do(ros_domain_env, tmp_path):
    """--jobs 2 runs each variant as a child process in a domain of its own; the bags, read
    back with the mcap library, hold the same messages as a one-at-a-time run."""
    import subprocess

    from mcap_ros2.reader import read_ros2_messages

    from conftest import VENV_BIN
    from gimbal_sim.bag.reader import find_mcap

    def run(out, jobs):
        proc = subprocess.run([str(VENV_BIN / "gimbal-run"), "sighting_land_vehicle", "--duration", "0.3",
                               "--mode", "container", "--jobs", str(jobs), "--out", str(out), "--no-progress"],
                              env=ros_domain_env, capture_output=True, text=True, timeout=300)
        assert proc.returncode == 0, proc.stderr[-3000:]
        return proc

    together = run(tmp_path / "together", 2)
    run(tmp_path / "apart", 1)
    assert "ekf_off: recorded" in together.stdout and "ekf_on: recorded" in together.stdout
    assert (tmp_path / "together" / "report" / "metrics.json").is_file()
    for name in ("ekf_off", "ekf_on"):
        bags = {}
        for how in ("together", "apart"):
            path, _ = find_mcap(tmp_path / how / name)
            bags[how] = sorted((m.channel.topic, m.log_time_ns, repr(m.ros_msg)) for m in read_ros2_messages(str(path)))
        assert len(bags["together"]) > 1000 and bags["together"] == bags["apart"], name


@pytest.mark.parametrize("name", sorted(builtin_scenarios()))
def test_builtin_scenarios_set_only_parameters_their_nodes_declare(name):
    # A misspelt parameter would be refused only when the node starts; catch it here.
    from gimbal_sim.graph.registry import NODE_TYPES

    s = load(name)
    runs = [variant(s, v) for v in s.variants] or [s]
    for single in runs:
        for node, spec in single.nodes.items():
            declared = {p.name for p in NODE_TYPES[spec["executable"]].params}
            unknown = set(spec["params"]) - declared
            assert not unknown, f"{name}: node {node!r} sets undeclared parameters {sorted(unknown)}"
