"""The rotational_ins_navigation experiment campaign: gimbal-campaign routes the name to the
core engine, the CEP table's median interval is the order-statistics one."""
import json

import numpy as np
import pytest
from scipy import stats

from gimbal_sim.campaign_cli import main as campaign_main
from gimbal_sim.experiments.navigation import _campaign_table, cep_summary, change_table, main as navigation_main, \
    median_interval


def test_median_interval_is_the_distribution_free_order_statistics_interval():
    """n = 20: [x_(6), x_(15)] (binomial coverage 95.9 %, the textbook table), and Monte
    Carlo coverage of the true median of a skewed law is at least 95 %."""
    med, lo, hi = median_interval(np.arange(1.0, 21.0))
    assert (med, lo, hi) == (10.5, 6.0, 15.0)
    assert stats.binom.cdf(14, 20, 0.5) - stats.binom.cdf(5, 20, 0.5) >= 0.95
    rng = np.random.default_rng(3)
    true_median = np.log(2.0)  # exponential(1)
    hits = sum(lo <= true_median <= hi for _, lo, hi in (median_interval(rng.exponential(size=20))
                                                         for _ in range(2000)))
    assert hits / 2000 >= 0.945


def test_gimbal_campaign_runs_the_scenario_variants_on_the_engine_and_its_table_reads_the_bags(tmp_path, capsys):
    """The CEP campaign is a declaration: its runs are the 5 Hz scenario variants on the one
    engine, each with its bag; each run's radial rate recomputed from its bag with rosbags (a
    reader we did not write) is the one the table's per-seed rows print."""
    out = tmp_path / "c"
    assert campaign_main(["rotational_ins_navigation", "--variant", "rotation_on", "--variant", "rotation_off",
                          "--seeds", "1", "--duration", "20", "--serial", "--no-progress", "--out", str(out)]) == 0
    runs = sorted(out.glob("runs/*/report/metrics.json"))
    assert len(runs) == 2
    metrics = [json.loads(p.read_text())["navigation"] for p in runs]
    assert all(abs(m["duration_s"] - 20.0) < 0.5 for m in metrics)
    printed = capsys.readouterr().out  # gimbal-campaign prints the CEP50 table itself, as its report carries it
    assert "CEP50" in printed and "ratio rotation_off / rotation_on" in printed
    assert "CEP50" in json.loads((out / "report" / "summary.json").read_text())["experiment_table"]
    assert cep_summary({"rotation_on": [{"final_radial_rate_nmi_h": 0.2}]})["rotation_on"]["cep50_nmi_h"] == 0.2
    from_bags = sorted(_radial_rate_from_bag(p.parent.parent) for p in runs)
    assert navigation_main(["cep", str(out)]) == 0
    assert "rotation_off" in capsys.readouterr().out
    assert navigation_main(["cep", str(out), "--per-seed"]) == 0
    row = capsys.readouterr().out.splitlines()[-1].split()
    assert row[0] == "1" and sorted(float(v) for v in row[1:]) == pytest.approx(from_bags, abs=1e-3)
    assert navigation_main(["cep", str(out), "--against", str(out)]) == 0  # each run against itself: no change
    changes = capsys.readouterr().out.split("per-seed change")[1].splitlines()[2:]
    assert [line.split()[:5] for line in changes] == [[v, "1", "+0.000", "0.000", "0/1"]
                                                      for v in ("rotation_on", "rotation_off")]
    assert navigation_main(["cep", str(out), "--seeds", "2-3"]) == 1  # seed 1 ran, only
    assert "no finished run" in capsys.readouterr().err
    assert navigation_main(["cep", str(out), "--seeds", "1-"]) == 2
    assert navigation_main(["cep", str(tmp_path / "none")]) == 2
    assert campaign_main(["rotational_ins_navigation", "--sweep", "a.b=1:2:2", "--out", str(tmp_path / "x")]) == 2


def _radial_rate_from_bag(run_dir) -> float:
    """The last fix's horizontal distance from the true site [n mile] per hour of the run, by rosbags."""
    from rosbags.highlevel import AnyReader
    from pathlib import Path

    bag = next(p.parent for p in Path(run_dir).rglob("metadata.yaml"))
    with AnyReader([bag]) as reader:
        fixes = {}
        for topic in ("/platform_navigator/fix", "/truth/host/fix"):
            conns = [c for c in reader.connections if c.topic == topic]
            msgs = [(t, reader.deserialize(raw, c.msgtype)) for c, t, raw in reader.messages(connections=conns)]
            fixes[topic] = msgs
    nav, truth = fixes["/platform_navigator/fix"], fixes["/truth/host/fix"]
    (t_end, last), (_, site) = nav[-1], truth[0]
    lat = np.radians(site.latitude)
    a, f = 6378137.0, 1.0 / 298.257223563
    e2 = f * (2.0 - f)
    w = np.sqrt(1.0 - e2 * np.sin(lat) ** 2)
    north = np.radians(last.latitude - site.latitude) * a * (1.0 - e2) / w ** 3
    east = np.radians(last.longitude - site.longitude) * a / w * np.cos(lat)
    hours = (t_end - nav[0][0]) * 1e-9 / 3600.0
    return float(np.hypot(north, east) / 1852.0 / hours)


def test_one_run_takes_the_noise_from_the_command_line_and_refuses_a_negative_one(capsys):
    """``navigation run --gyro-arw G --accel-noise A`` runs with that white noise: with both 0
    the run is the seed's biases alone and repeats exactly; with the scenarios' noise the same
    seed (the same biases) ends elsewhere. A negative figure is refused with exit 2, naming the
    option."""
    def radial(*extra):
        assert navigation_main(["run", "--duration", "20", "--rate", "50", "--seed", "3", *extra]) == 0
        lines = dict(line.split(None, 1) for line in capsys.readouterr().out.splitlines() if line.strip())
        return float(lines["radial_error_m"])

    quiet = radial("--gyro-arw", "0", "--accel-noise", "0")
    assert quiet == radial("--gyro-arw", "0", "--accel-noise", "0")
    assert radial() != quiet
    with pytest.raises(SystemExit) as exit_info:
        navigation_main(["run", "--duration", "1", "--gyro-arw", "-1"])
    assert exit_info.value.code == 2
    assert "--gyro-arw" in capsys.readouterr().err


def test_cep_table_lists_the_scenarios_own_variants_and_their_ratio():
    """A campaign run from the scenario's file records the scenario's variant names
    (rotation_on_1khz, ...): the table lists them after the experiment's and gives their ratio."""
    summary = cep_summary({"rotation_off_1khz": [{"final_radial_rate_nmi_h": r} for r in (1.0, 2.0, 3.0)],
                           "rotation_on_1khz": [{"final_radial_rate_nmi_h": r} for r in (0.2, 0.4, 0.6)],
                           "perfectly_aligned": [{"final_radial_rate_nmi_h": 0.3}]})
    assert summary["ratio_off_on_1khz"] == pytest.approx(2.0 / 0.4)
    lines = _campaign_table(summary).splitlines()
    assert [line.split()[0] for line in lines[2:5]] == ["perfectly_aligned", "rotation_off_1khz", "rotation_on_1khz"]
    assert "ratio rotation_off_1khz / rotation_on_1khz: 5.00" in lines[-1]


def test_cep_on_a_campaign_without_a_finished_run_says_so(tmp_path, capsys):
    import pyarrow as pa
    import pyarrow.parquet as pq

    out = tmp_path / "c"
    (out / "runs").mkdir(parents=True)
    pq.write_table(pa.Table.from_pylist([{"run_id": "abc", "scenario": "rotational_ins_navigation",
                                          "variant": "rotation_on_1khz", "seed": 1, "status": "failed"}]),
                   out / "results.parquet")  # written by pyarrow, as a campaign writes it
    (out / "campaign.yaml").write_text("campaign: {scenario: rotational_ins_navigation}\n")
    assert navigation_main(["cep", str(out)]) == 1
    assert "no finished run with a navigation report" in capsys.readouterr().err


def test_change_table_pairs_runs_by_scenario_variant_and_seed():
    """An experiment campaign's perfectly_aligned is the scenario's rotation_on_1khz: a study run
    from the scenario's file pairs with it seed by seed; a seed without a baseline is left out."""
    def run(variant, seed, rate):
        return {"scenario_variant": variant, "seed": seed, "final_radial_rate_nmi_h": rate}

    base = {"perfectly_aligned": [run("rotation_on_1khz", s, r) for s, r in ((1, 0.3), (2, 0.5), (3, 0.2))]}
    study = {"rotation_on_1khz": [run("rotation_on_1khz", s, r) for s, r in ((1, 0.4), (2, 0.3), (3, 0.6), (4, 9.0))],
             "rotation_off_1khz": [run("rotation_off_1khz", 1, 2.0)]}
    rows = {line.split()[0]: line.split()[1:] for line in change_table(study, base).splitlines()[2:]}
    # changes +0.1, -0.2, +0.4: median +0.1, sizes 0.1, 0.2, 0.4: median 0.2, two of three worse
    assert rows["rotation_on_1khz"] == ["3", "+0.100", "0.200", "2/3"]
    assert rows["rotation_off_1khz"][:3] == ["0", "no", "baseline"]


def test_experiment3_figures_count_the_runs_inside_the_papers_bounds():
    """Exp. 3: largest radial error < 2,200 m, azimuth at hand-off < 1′, level < 5″; counted
    per run against hand-made metrics."""
    def run(radial_m, v_north, v_east, residual):
        return {"final_radial_rate_nmi_h": 0.3, "max_radial_error_m": radial_m,
                "max_velocity_error_m_s": {"north": v_north, "east": v_east},
                "hand_off": {"residual_misalignment_arcsec": residual}}

    runs = [run(1000.0, 0.5, 0.7, [1.0, -2.0, 59.0]), run(2500.0, 0.9, 0.2, [6.0, 0.0, -30.0]),
            run(2199.0, 0.1, 0.3, [0.0, 4.9, 61.0])]
    s = cep_summary({"upgraded": runs})["upgraded"]
    assert s["max_radial_error_m"] == [2199.0, 1000.0, 2500.0] and s["max_radial_under_2200_m"] == 2
    assert s["max_velocity_error_m_s_median"] == pytest.approx(0.7)  # the larger axis of each: 0.7, 0.9, 0.3
    assert s["azimuth_under_1_arcmin"] == 2 and s["level_under_5_arcsec"] == 2
    table = _campaign_table({"upgraded": {**s, "runs": 3}})
    assert "azimuth under 1′ in 2 of 3 runs" in table and "under 2,200 m in 2 of 3 runs" in table
