"""Campaign specifications: seeds, sweeps (grid and scrambled Sobol), run ids, validation,
and the CLI's refusals (exit 2, naming what is wrong, nothing written)."""
from __future__ import annotations

import hashlib
import json
import socket
import subprocess
import sys
import time

import numpy as np
import pytest
import yaml
from scipy.stats import qmc

from gimbal_sim.campaign_cli import main as campaign_main
from gimbal_sim.campaign.spec import (CampaignError, CampaignSpec, load_spec_file, parse_seeds, parse_sweep,
                                      plan, run_id, spec_from_mapping)
from gimbal_sim.graph.scenario import load, variant


def test_seed_ranges_and_lists():
    assert parse_seeds("1-20") == tuple(range(1, 21))
    assert parse_seeds("1,4,7-9") == (1, 4, 7, 8, 9)
    assert parse_seeds(3) == (3,)
    assert parse_seeds([0, 2]) == (0, 2)
    for bad in ("5-1", "a", "1-", "-3", "1,,2", "1-2,2", True, 1.5):
        with pytest.raises(CampaignError, match="seed"):
            parse_seeds(bad)


def test_grid_sweep_is_linspace_and_malformed_ranges_are_named():
    sweep = parse_sweep("sensor_models.gimbal_gyro_bias_deg_h", "50:200:4")
    assert sweep.values == tuple(np.linspace(50.0, 200.0, 4))
    assert parse_sweep("los_rate_controller.mode", "rate,los_hold").values == ("rate", "los_hold")
    assert parse_sweep("a.b", [1, 2]).values == (1, 2)
    for bad, why in (("50:200", "point count"), ("50:x:4", "not a number"), ("50:200:1", "n must be"),
                     ("50:200:2.5", "n must be"), ("1:2:3:4", "malformed range"), ("5:5:3", "equal"),
                     (":200:4", "malformed range")):
        with pytest.raises(CampaignError, match=why) as err:
            parse_sweep("sensor_models.gimbal_gyro_bias_deg_h", bad)
        assert "sensor_models.gimbal_gyro_bias_deg_h" in str(err.value)
    with pytest.raises(CampaignError, match="node.param"):
        parse_sweep("gimbal_gyro_bias_deg_h", "1:2:3")


def _spec(**kw) -> CampaignSpec:
    base = {"scenario": "sighting_land_vehicle", "seeds": "1-2", "duration_s": 2.0}
    base.update(kw)
    return spec_from_mapping(base)


def test_plan_expands_variants_seeds_and_grid_points_with_typed_values():
    p = plan(_spec(sweep={"sensor_models.gimbal_gyro_bias_deg_h": "50:200:4"}))
    assert len(p.runs) == 2 * 2 * 4  # variants x seeds x points
    run = next(r for r in p.runs if r.variant == "ekf_on" and r.seed == 2
               and r.values["sensor_models.gimbal_gyro_bias_deg_h"] == 100.0)
    # the scalar spreads over the [q, r] vector parameter; the variant and seed are applied
    assert run.scenario.nodes["sensor_models"]["params"]["gimbal_gyro_bias_deg_h"] == [100.0, 100.0]
    assert run.scenario.nodes["los_rate_controller"]["params"]["feedback"] is True
    assert run.scenario.seed == 2 and run.scenario.duration_s == 2.0
    one = plan(_spec(variants=["ekf_off"], sweep={"sensor_models.gimbal_gyro_bias_deg_h[1]": "10,20"}))
    params = [r.scenario.nodes["sensor_models"]["params"]["gimbal_gyro_bias_deg_h"] for r in one.runs]
    assert sorted(map(tuple, params)) == [(100.0, 10.0), (100.0, 10.0), (100.0, 20.0), (100.0, 20.0)]


def test_sobol_points_are_scipys_scrambled_sequence_scaled_to_the_bounds():
    p = plan(_spec(variants=["ekf_on"], seeds="1", sampling="sobol", samples=8, sample_seed=7,
                   sweep={"sensor_models.gimbal_gyro_bias_deg_h": "50:200",
                          "los_rate_controller.omega_n_hz": "10:30"}))
    expected = qmc.scale(qmc.Sobol(d=2, scramble=True, seed=7).random(8), [50.0, 10.0], [200.0, 30.0])
    got = [[r.values["sensor_models.gimbal_gyro_bias_deg_h"], r.values["los_rate_controller.omega_n_hz"]]
           for r in p.runs]
    np.testing.assert_array_equal(np.array(got), expected)
    with pytest.raises(CampaignError, match="power of 2"):
        plan(_spec(sampling="sobol", samples=6, sweep={"los_rate_controller.omega_n_hz": "10:30"}))
    with pytest.raises(CampaignError, match="bounds a:b"):
        _spec(sampling="sobol", samples=4, sweep={"los_rate_controller.omega_n_hz": "10:30:3"})


def test_run_id_is_the_hash_of_scenario_variant_seed_and_values():
    values = {"sensor_models.gimbal_gyro_bias_deg_h": 50.0}
    text = json.dumps({"scenario": "sighting_land_vehicle", "variant": "ekf_on", "seed": 3, "values": values},
                      sort_keys=True, separators=(",", ":"))
    assert run_id("sighting_land_vehicle", "ekf_on", 3, values) == hashlib.sha256(text.encode()).hexdigest()[:16]
    ids = {r.run_id for r in plan(_spec(sweep={"sensor_models.gimbal_gyro_bias_deg_h": "50:200:4"})).runs}
    assert len(ids) == 16
    # the same run in another campaign (other duration, more seeds) has the same id: what --resume finds
    again = {r.run_id for r in plan(_spec(seeds="1-3", duration_s=7.0,
                                          sweep={"sensor_models.gimbal_gyro_bias_deg_h": "50:200:4"})).runs}
    assert ids < again


def test_plan_refuses_unknown_scenario_variant_parameter_and_owned_parameters():
    cases = [({"scenario": "no_such_scenario"}, "unknown scenario 'no_such_scenario'"),
             ({"variants": ["nope"]}, "no variant 'nope'"),
             ({"sweep": {"sensor_models.no_such_param": "1:2:3"}}, "no parameter 'no_such_param'"),
             ({"sweep": {"no_node.x": "1:2:3"}}, "no node 'no_node'"),
             ({"sweep": {"los_rate_controller.feedback": "true"}}, "variant 'ekf_off' sets it too"),
             ({"sweep": {"vehicle_dynamics.duration_s": "1:2:3"}}, "set by the orchestrator"),
             ({"sweep": {"los_rate_controller.omega_n_hz": "abc,def"}}, "omega_n_hz"),
             ({"set": {"sensor_models.gimbal_gyro_bias_deg_h": "x"}}, "gimbal_gyro_bias_deg_h"),
             ({"scenario": "sim_open_loop", "variants": ["a"]}, "has no variants"),
             ({"scenario": "sighting_realtime", "engine": "core"}, "core loop cannot step")]
    for overrides, message in cases:
        with pytest.raises(CampaignError, match=message):
            plan(_spec(**overrides))


def test_variant_of_the_plan_equals_the_scenarios_own_variant():
    p = plan(_spec(variants=["ekf_on"], seeds="5"))
    (run,) = p.runs
    expected = variant(load("sighting_land_vehicle"), "ekf_on")
    assert run.scenario.nodes == expected.nodes and run.scenario.seed == 5


@pytest.mark.parametrize("args, message", [
    (["no_such_scenario"], "unknown scenario"),
    (["sighting_land_vehicle", "--variant", "nope"], "no variant 'nope'"),
    (["sighting_land_vehicle", "--sweep", "sensor_models.nope=1:2:3"], "no parameter 'nope'"),
    (["sighting_land_vehicle", "--sweep", "sensor_models.gimbal_gyro_bias_deg_h=50:200"], "malformed range"),
    (["sighting_land_vehicle", "--sweep", "sensor_models.gimbal_gyro_bias_deg_h"], "expected NODE.PARAM=VALUE"),
    (["sighting_land_vehicle", "--seeds", "3-1"], "malformed seed range"),
    (["sighting_land_vehicle", "--scheduler", "localhost:8786"], "expected tcp://host:port"),
    (["sighting_land_vehicle", "--workers", "0"], "--workers"),
])
def test_cli_refuses_bad_input_with_exit_2(args, message, tmp_path, capsys):
    out = tmp_path / "campaign"
    assert campaign_main([*args, "--out", str(out)]) == 2
    assert message in capsys.readouterr().err
    assert not out.exists()


def test_cli_refuses_an_existing_directory_without_resume(tmp_path, capsys):
    (tmp_path / "c").mkdir()
    assert campaign_main(["sighting_land_vehicle", "--out", str(tmp_path / "c")]) == 2
    assert "already exists; add --resume" in capsys.readouterr().err
    assert list((tmp_path / "c").iterdir()) == []


def test_cli_refuses_an_unreachable_scheduler_within_10_s(tmp_path):
    from gimbal_sim.campaign.engine import CONNECT_TIMEOUT_S, connect

    with socket.socket() as s:  # a port nobody listens on: bound, never listening
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
        # the refusal is a wall-clock timeout of the connection attempt, whatever the load
        t0 = time.monotonic()
        with pytest.raises(CampaignError, match=f"--scheduler tcp://127.0.0.1:{port}: unreachable"):
            connect(f"tcp://127.0.0.1:{port}", None)
        assert CONNECT_TIMEOUT_S < 10.0 and time.monotonic() - t0 < 10.0
        result = subprocess.run([sys.executable, "-m", "gimbal_sim.campaign_cli", "sighting_land_vehicle",
                                 "--scheduler", f"tcp://127.0.0.1:{port}", "--out", str(tmp_path / "c"),
                                 "--no-progress"], capture_output=True, text=True, timeout=300)
    assert result.returncode == 2, result.stderr
    assert f"--scheduler tcp://127.0.0.1:{port}: unreachable" in result.stderr
    assert not (tmp_path / "c").exists()


@pytest.mark.parametrize("spec", [
    CampaignSpec(scenario="sim_open_loop", seeds=(1, 2), variants=("a",), duration_s=2.0, engine="core"),
    CampaignSpec(scenario="", experiment="rotational_ins_navigation", seeds=(3, 4, 5), variants=("rotation_on",),
                 engine="core", options=(("duration_s", 60.0),)),
])
def test_a_campaign_directorys_record_is_the_campaign_it_asked_for(spec, tmp_path):
    """The campaign page's reproduce command hands gimbal-campaign the directory's own
    campaign.yaml (the engine's record around the spec): it reads back as the same campaign."""
    record = tmp_path / "campaign.yaml"
    record.write_text(yaml.safe_dump({"campaign": spec.to_dict(), "fingerprint": "f", "runs": 2}, sort_keys=False))
    assert load_spec_file(record) == spec
