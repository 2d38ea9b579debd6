"""The experiment runners' Monte Carlo as campaigns: their CLIs go through
the campaign engine (serial, a Dask LocalCluster on 127.0.0.1, or the real nodes with
``--engine graph``) and print the figures their own loops give, computed here without the
engine; ``--resume`` runs nothing; what has no graph equivalent is refused, naming it."""
from __future__ import annotations

import json

import numpy as np
import pytest

from gimbal_sim.experiments import flexure, free_gyro, sighting_loop
from gimbal_sim.campaign.spec import CampaignError, CampaignSpec, Sweep, spec_from_mapping
from gimbal_sim.experiments.registry import plan


def _drift_line(drift: np.ndarray, mode: str, duration_s: float) -> str:
    return (f"{mode:9s} {len(drift)} runs: drift at {duration_s:g} s [deg] az {np.mean(drift[:, 0]):+.4f} ± "
            f"{np.std(drift[:, 0]):.4f}, el {np.mean(drift[:, 1]):+.4f} ± {np.std(drift[:, 1]):.4f}")


def _run_dirs(out) -> list:
    return sorted(p for p in (out / "runs").iterdir() if not p.name.startswith("."))


def test_sighting_loop_prints_figures_recomputed_from_its_runs_bags_and_resume_runs_nothing(tmp_path, capsys):
    from gimbal_sim.reports.sighting import analyse

    out = tmp_path / "mc"
    args = ["--monte-carlo", "2", "--duration", "31", "--modes", "feedback", "--out", str(out)]
    assert sighting_loop.main(args) == 0
    printed = capsys.readouterr().out
    # each run is scenario sighting_land_vehicle:ekf_on on the engine, with its bag; the table's
    # figures come back from the bags by the report's reader
    runs = _run_dirs(out)
    assert len(runs) == 2 and all(any(r.glob("*.mcap")) for r in runs)
    assert {json.loads((r / "run.json").read_text())["scenario"] for r in runs} == {"sighting_land_vehicle:ekf_on"}
    a = [analyse(r) for r in runs]
    assert _drift_line(np.array([x["final_drift_deg"] for x in a]), "feedback", 31.0) in printed
    nees = np.mean([x["mean_nees_bias"] for x in a])
    assert f"nees_bias (2 dof) time- and run-averaged {nees:.3f}" in printed
    # a campaign directory like any other: one row per run, each with its metrics
    import pyarrow.parquet as pq

    rows = pq.read_table(out / "results.parquet").to_pylist()
    assert sorted((r["variant"], r["seed"]) for r in rows) == [("feedback", 1), ("feedback", 2)]
    assert all(r["status"] == "ok" and r["engine"] == "core" for r in rows)
    assert all(np.isfinite(r["sighting.final_drift_deg.azimuth"]) for r in rows)
    assert sighting_loop.main([*args, "--resume"]) == 0
    assert capsys.readouterr().out == printed
    last = json.loads((out / "invocations.jsonl").read_text().splitlines()[-1])
    assert last["ran"] == 0 and last["skipped"] == 2


def test_sighting_loop_los_hold_and_the_ins_case_are_scenario_values(tmp_path, capsys):
    out = tmp_path / "hold"
    assert sighting_loop.main(["--duration", "1", "--modes", "los_hold", "--ins", "gauss_markov",
                               "--ins-error-states", "--out", str(out)]) == 0
    (run,) = _run_dirs(out / "los_hold")
    params = (run / "scenario.yaml").read_text()
    assert "los_hold" in json.loads((run / "run.json").read_text())["scenario"]
    assert "ins_attitude_tau_s: 300.0" in params and "ins_error_states: true" in params
    assert "ins_attitude_model: gauss_markov" in params
    assert "los_hold  1 runs: drift at 1 s" in capsys.readouterr().out


def test_free_gyro_campaign_runs_the_scenario_on_the_engine_and_keeps_its_bags(tmp_path, capsys):
    """The FDOP Monte Carlo is scenario free_gyro_positioning on the one engine (on a Dask
    LocalCluster): every run leaves its bag, which rosbags reads, and the printed empirical
    covariance is recomputed here from the bags' fixes (pymap3d's NED against the site); the
    claimed covariance and FDOP are the cores' (the scenario is set up as they are)."""
    import pymap3d
    from rosbags.highlevel import AnyReader

    free_gyro.main(["--runs", "3", "--fixes-per-run", "2", "--jobs", "2", "--out", str(tmp_path / "fg")])
    printed = capsys.readouterr().out
    core = free_gyro.run_fdop_monte_carlo(3, fixes_per_run=2)
    assert printed.startswith(f"3 runs, 6 fixes, FDOP {core.fdop:.4f}")
    assert f"FDOP²σ² cov  (N, E) [m²]: {np.round(core.predicted_cov_ne_m, 2).tolist()}" in printed
    runs = sorted((tmp_path / "fg" / "runs").glob("*/result.json"))
    assert len(runs) == 3 and len({json.loads(p.read_text())["host"] for p in runs}) == 1  # recorded where each ran
    errors = []
    for result in runs:
        assert json.loads(result.read_text())["bag_kept"] and len(list(result.parent.glob("*.mcap"))) == 1
        with AnyReader([result.parent]) as reader:
            fixes = [c for c in reader.connections if c.topic == "/free_gyro_positioning/fix"]
            for connection, _, raw in reader.messages(connections=fixes):
                fix = reader.deserialize(raw, connection.msgtype)
                n, e, _ = pymap3d.geodetic2ned(fix.latitude, fix.longitude, fix.altitude, 35.0, 129.0, fix.altitude)
                errors.append((n, e))
    e = np.array(errors)
    assert len(e) == 6
    line = next(x for x in printed.splitlines() if "empirical cov" in x)
    printed_cov = np.array(json.loads(line.split(":", 1)[1]))
    np.testing.assert_allclose(e.T @ e / len(e), printed_cov, rtol=1e-3, atol=0.01)


def test_flexure_single_seed_prints_each_models_figures(tmp_path, capsys):
    # The printed figures have to be the run's, whatever its length: a short run is enough.
    flexure.main(["--seeds", "3", "--duration", "120", "--convergence", "60", "--models", "random_walk_rate"])
    printed = capsys.readouterr().out
    want = flexure.run_flexure_comparison(120.0, 3, models=("random_walk_rate",), sim_rate_hz=10.0,
                                          convergence_s=60.0)["random_walk_rate"].metrics
    f = lambda v: "(" + ", ".join(f"{x:.1f}" for x in v) + ")"  # noqa: E731
    assert f"total flexure error RMS {f(want['total_rms_arcsec'])}″" in printed
    assert f"[random_walk_rate] epochs={want['n_epochs']} wall=" in printed


@pytest.mark.parametrize("main, args, named", [
    (sighting_loop.main, ["--monte-carlo", "0"], "--monte-carlo"),
    (flexure.main, ["--engine", "graph", "--sim-rate", "50"], "sim_rate_hz"),
    (flexure.main, ["--engine", "graph", "--turn"], "turn"),
    (free_gyro.main, ["--runs", "2", "--jobs", "0"], "--jobs"),
])
def test_what_a_runner_cannot_do_exits_2_naming_it(main, args, named, capsys):
    with pytest.raises(SystemExit) as exc:
        main(args)
    assert exc.value.code == 2
    assert named in capsys.readouterr().err


def test_experiment_specs_are_validated_before_anything_runs():
    for spec, named in ((CampaignSpec("", (1,), experiment="nope"), "unknown experiment"),
                        (CampaignSpec("", (1,), experiment="free_gyro", options=(("runs", 3),)), "unknown option"),
                        # the scenario's rate is no node parameter: refused on either engine
                        (CampaignSpec("", (1,), experiment="free_gyro", options=(("rate_hz", 20.0),)), "rate_hz"),
                        (CampaignSpec("", (1,), experiment="alignment", variants=("spin",)), "no variant"),
                        (CampaignSpec("", (1,), experiment="flexure", sweeps=(Sweep("a.b", (1,)),)), "sweeps")):
        with pytest.raises(CampaignError, match=named):
            plan(spec)
    # the id of a run does not depend on the campaign it is in
    one = plan(CampaignSpec("", (1, 2), experiment="alignment", options=(("duration_s", 60.0),)))
    two = plan(CampaignSpec("", (2,), experiment="alignment", variants=("rotate",), options=(("duration_s", 60.0),)))
    assert {r.run_id for r in two.runs} < {r.run_id for r in one.runs}
    assert len(one.runs) == 4


def test_a_runner_whose_runs_are_a_scenarios_takes_set_and_its_own_loop_refuses_it():
    target, value = "sensor_models.free_gyro_triad_scale_factor_sigma_ppm", 5.0
    spec = CampaignSpec("", (1,), experiment="free_gyro", overrides=((target, value),))
    planned = plan(spec)
    assert planned.base.nodes["sensor_models"]["params"]["free_gyro_triad_scale_factor_sigma_ppm"] == value
    # the fingerprint carries it (a resume with another --set is another campaign), and so
    # does the campaign's YAML record
    assert planned.fingerprint != plan(CampaignSpec("", (1,), experiment="free_gyro")).fingerprint
    assert spec_from_mapping(spec.to_dict()).overrides == ((target, value),)
    # a parameter one of the experiment's options sets is refused, naming it
    clash = CampaignSpec("", (1,), experiment="sighting_loop", overrides=(("sensor_models.ins_attitude_model", "white"),))
    with pytest.raises(CampaignError, match="ins_attitude_model: an option of the experiment sets it"):
        plan(clash)
    # a runner's own loop has no scenario parameters
    with pytest.raises(CampaignError, match="its own loop"):
        plan(CampaignSpec("", (1,), experiment="flexure", engine="core",
                          overrides=(("sensor_models.lgu_arw_deg_rt_h", 0.01),)))
    with pytest.raises(CampaignError, match="no parameter 'nope'"):
        plan(CampaignSpec("", (1,), experiment="free_gyro", overrides=(("sensor_models.nope", 1.0),)))


@pytest.mark.ros
def test_sighting_loop_on_the_graph_engine_runs_the_real_nodes(tmp_path, capsys):
    out = tmp_path / "graph"
    # 2 s: the drift is already hundredths of a degree, so the printed figures carry as many digits as longer runs
    assert sighting_loop.main(["--duration", "2", "--modes", "feedback", "--engine", "graph", "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    (run_dir,) = _run_dirs(out)
    assert any(run_dir.glob("*.mcap"))          # a bag of the real graph
    metrics = json.loads((run_dir / "report" / "metrics.json").read_text())["sighting"]["final_drift_deg"]
    assert f"az {metrics['azimuth']:+.4f} ± 0.0000" in printed
    assert "nees (6 dof): not in the runs' bags" in printed
    # the real nodes and the engine: the same LOS drift (the same bag data, test_engine_bags)
    assert sighting_loop.main(["--duration", "2", "--modes", "feedback", "--out", str(tmp_path / "core")]) == 0
    assert capsys.readouterr().out == printed


def test_graph_reports_pool_to_the_statistics_of_all_their_fixes():
    """free_gyro's graph table pools each run's report (n fixes already pooled by the
    report's own function) into what the pooled fixes give directly."""
    from gimbal_sim.reports.free_gyro import covariance_consistency

    rng = np.random.default_rng(7)
    arcsec = np.pi / (180 * 3600)
    runs, reports = [], []
    for n in (3, 5):
        err = rng.normal(scale=12.0, size=(n, 2))
        a = rng.normal(size=(n, 2, 2))
        cov = a @ a.transpose(0, 2, 1) + 100.0 * np.eye(2)
        nees = [float(e @ np.linalg.solve(c, e)) for e, c in zip(err, cov)]
        hd, hs = rng.normal(scale=20 * arcsec, size=n), rng.uniform(15, 25, size=n) * arcsec
        runs.append({"errors_ne_m": err, "cov_ne_m": cov, "nees": nees, "fdop": [2 ** 0.5] * n,
                     "heading_error_rad": hd, "heading_sigma_rad": hs})
        reports.append({"free_gyro": {"fdop_mean": 2 ** 0.5, "position": covariance_consistency(err, cov),
                                      "heading": {"n": n, "rms_error_arcsec": float(np.sqrt(np.mean(hd ** 2)) / arcsec),
                                                  "mean_error_arcsec": float(np.mean(hd) / arcsec),
                                                  "mean_sigma_arcsec": float(np.mean(hs) / arcsec)}}})
    want, got = free_gyro.pooled(runs), free_gyro.pooled_reports(reports)
    assert got.n_fixes == want.n_fixes == 8
    for field in ("empirical_cov_ne_m", "predicted_cov_ne_m", "trace_ratio", "variance_ratios", "mean_nees", "fdop",
                  "heading_error_std", "heading_sigma_mean"):
        assert np.allclose(getattr(got, field), getattr(want, field), rtol=1e-12, atol=0), field


@pytest.mark.ros
def test_free_gyro_on_the_graph_engine_pools_the_scenarios_reports(tmp_path, capsys):
    free_gyro.main(["--runs", "2", "--fixes-per-run", "2", "--engine", "graph"])
    printed = capsys.readouterr().out
    core = free_gyro.run_fdop_monte_carlo(2, fixes_per_run=2)
    # the scenario set up as the cores: the same fixes, the same claimed covariance
    assert printed.startswith(f"2 runs, 4 fixes, FDOP {core.fdop:.4f}")
    assert f"FDOP²σ² cov  (N, E) [m²]: {np.round(core.predicted_cov_ne_m, 2).tolist()}" in printed
