"""A campaign that would take days by its own estimate is refused unless confirmed with
``--large``. The bound is made tiny here (monkeypatched) so that tiny synthetic
runs cross it; the estimate itself is the engine's: the mean wall time of the runs a resumed
campaign already finished, else the engine's measured wall per simulated second."""
from __future__ import annotations

import json
from pathlib import Path

import pytest

from gimbal_sim.campaign import engine
from gimbal_sim.campaign.spec import CampaignError, spec_from_mapping
from gimbal_sim.experiments.registry import plan, run_campaign

SPEC = {"scenario": "sighting_land_vehicle", "seeds": "1-3", "sweep": {"los_rate_controller.omega_n_hz": "10"}}


def _run(task, run_dir: Path) -> None:
    if task.seed == 3:
        raise RuntimeError("seed 3 fails this time")
    (run_dir / "report").mkdir()
    (run_dir / "report" / "metrics.json").write_text(json.dumps({"experiment": {"seed": task.seed}}))


def _ok(task, run_dir: Path) -> None:
    (run_dir / "report").mkdir()
    (run_dir / "report" / "metrics.json").write_text(json.dumps({"experiment": {"seed": task.seed}}))


def test_a_fresh_campaign_over_the_bound_is_refused_before_anything_is_written(tmp_path, monkeypatch):
    spec, out = spec_from_mapping(SPEC), tmp_path / "c"
    # 6 runs x 120 s x 0.867 s/s on 1 worker = 624 s: over a 600 s bound, under a 700 s one
    monkeypatch.setattr(engine, "MAX_ESTIMATE_S", 600.0)
    with pytest.raises(CampaignError, match=r"about 0\.2 h by its own estimate \(6 runs x 104 s .*--large"):
        run_campaign(spec, out, serial=True, progress=False, run_fn=_ok)
    assert not out.exists()
    monkeypatch.setattr(engine, "MAX_ESTIMATE_S", 700.0)
    assert run_campaign(spec, out, serial=True, progress=False, run_fn=_ok).ran == 6


def test_a_resume_is_estimated_from_the_runs_it_finished(tmp_path, monkeypatch):
    spec, out = spec_from_mapping(SPEC), tmp_path / "c"
    first = run_campaign(spec, out, serial=True, progress=False, run_fn=_run)
    assert (first.ran, len(first.failed)) == (6, 2)
    walls = [json.loads(p.read_text())["wall_s"] for p in (out / "runs").glob("*/result.json")
             if json.loads(p.read_text())["status"] == "ok"]
    expected = 2 * sum(walls) / len(walls)  # the 2 failed runs to redo x the mean of the 4 that finished
    estimate, how = engine.estimate_wall_s(plan(spec), out, True, 1)
    assert estimate == pytest.approx(expected) and "the mean of the 4 runs it finished" in how
    monkeypatch.setattr(engine, "MAX_ESTIMATE_S", expected / 2.0)
    with pytest.raises(CampaignError, match="mean of the 4 runs it finished"):
        run_campaign(spec, out, resume=True, serial=True, progress=False, run_fn=_ok)
    result = run_campaign(spec, out, resume=True, serial=True, progress=False, run_fn=_ok, large=True)
    assert (result.ran, result.skipped) == (2, 4)
