"""The no-regression table's tool (``python -m gimbal_sim.tools.no_regression``): which
scenarios it compares, and its verdicts on bags written by the engine and re-read by the
bag comparison, with a third party's reader (``mcap``) confirming what differs."""
import dataclasses

import pytest

from mcap.reader import make_reader

from gimbal_sim.core.engine_run import run_engine
from gimbal_sim.graph.scenario import builtin_scenarios, load
from gimbal_sim.tools.no_regression import cases, main, verdict


def _engine_bag(tmp_path, name: str, seed: int):
    scenario = dataclasses.replace(load("sim_open_loop"), duration_s=0.05, seed=seed)
    run_engine(scenario, tmp_path / name)
    return tmp_path / name


def _payloads(bag):
    with open(next(bag.glob("*.mcap")), "rb") as f:
        return [m.data for _, _, m in make_reader(f).iter_messages()]


def test_every_lockstep_scenario_is_compared_and_the_clocked_ones_are_named():
    todo, skipped = cases()
    compared = {c.scenario for c in todo}
    left_out = {line.split(":")[0].split(" ")[0] for line in skipped}
    assert compared | left_out == set(builtin_scenarios())
    assert {"sighting_realtime", "mavlink_gimbal_sitl"} <= left_out
    assert all(load(c.scenario).variants.get(c.variant, {}).get("prelude") is None for c in todo)


def test_same_seed_is_same_data_and_another_seed_is_different(tmp_path):
    a, b, c = _engine_bag(tmp_path, "a", 3), _engine_bag(tmp_path, "b", 3), _engine_bag(tmp_path, "c", 4)
    assert _payloads(a) == _payloads(b) and _payloads(a) != _payloads(c)
    ok, words, topics = verdict(a, b, 0.0)
    assert ok and words == "same data" and topics > 0
    ok, words, _ = verdict(a, c, 0.0)
    assert not ok and words.startswith("DIFFERENT")
    ok, words, _ = verdict(a, tmp_path / "missing", 0.0)
    assert not ok and words == "NO BAG written"


def test_bad_arguments_exit_2_naming_them(tmp_path, capsys):
    with pytest.raises(SystemExit) as exc:
        main(["--baseline", str(tmp_path), "--out", str(tmp_path / "o")])
    assert exc.value.code == 2 and "no .venv/bin/gimbal-run" in capsys.readouterr().err
