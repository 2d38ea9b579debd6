"""``gimbal-bench engine``: each figure printed against its target (ratios from the medians of
each side's runs, the 3-hour projection from steps/s, the RSS growth), and bad options
refused before anything runs."""
import pytest

from gimbal_sim.tools import bench, engine_speed


def _runs(steps_per_s, cpu_s=1.0):
    return [{"steps_per_s": v, "steps_per_cpu_s": v / cpu_s} for v in steps_per_s]


def test_report_gives_each_figure_against_its_target():
    result = {"load_before": 0.2, "load_after": 0.3, "cases": {
        "rotational_ins_navigation": {"this": _runs([70_000, 60_000, 65_000]), "baseline": _runs([3_000, 3_500, 3_250])},
        "sighting_land_vehicle": {"this": _runs([50_000]), "baseline": _runs([10_000])}},
        "memory": ({"peak_rss_mb": 200.0}, {"peak_rss_mb": 230.0})}
    text = engine_speed.report(result, 20.0, 10.0).splitlines()
    nav = next(line for line in text if line.startswith("rotational_ins_navigation"))
    assert "65,000" in nav and "3,250" in nav and "20.00x" in nav and "met" in nav
    three_hours = next(line for line in text if "3-hour" in line)
    assert "166" in three_hours and "met" in three_hours          # 10.8e6 / 65,000 = 166 s <= 180
    slv = next(line for line in text if line.startswith("sighting_land_vehicle"))
    assert "5.00x" in slv and "MISSED" in slv                     # 5x against >= 10x
    assert "+15.0 %" in text[-1] and "MISSED" in text[-1]          # 200 -> 230 MB is not flat


@pytest.mark.parametrize("args", [["engine", "--pairs", "0"], ["engine", "--baseline", "/nonexistent/python"],
                                  ["engine", "--duration", "-1"]])
def test_bad_options_are_refused_before_any_run(args, capsys):
    with pytest.raises(SystemExit) as exc:
        raise SystemExit(bench.main(args))
    assert exc.value.code == 2
    assert "gimbal-bench" in capsys.readouterr().err
