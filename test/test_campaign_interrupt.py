"""An interrupted campaign, then ``--resume``: the results and the report count every run
on disk, including a run whose worker finished as the campaign was stopped."""
from __future__ import annotations

import json
from pathlib import Path

import pytest

from gimbal_sim.campaign.engine import Runners, execute_run
from gimbal_sim.campaign.results import read_results, results_digest
from gimbal_sim.campaign.spec import spec_from_mapping
from gimbal_sim.experiments.registry import run_campaign

SPEC = {"scenario": "sighting_land_vehicle", "seeds": "1-3", "sweep": {"los_rate_controller.omega_n_hz": "10"}}


def _mean_run(task, run_dir: Path) -> None:
    """A caller's own run: a seeded sample mean, written as the run's metrics."""
    import numpy as np

    value = float(np.random.default_rng(task.seed).normal(size=100).mean())
    (run_dir / "report").mkdir()
    (run_dir / "report" / "metrics.json").write_text(json.dumps({"experiment": {"mean": value}}))


def _finished_as_ctrl_c_came(task, run_dir: Path) -> None:
    """The last run: its worker writes the run's result to disk (as a worker on the same
    disk does), but the campaign is stopped before the row reaches it."""
    if task.seed == 3 and task.variant == "ekf_on":
        execute_run(task, Runners(run_fn=_mean_run))
        raise KeyboardInterrupt
    _mean_run(task, run_dir)


def _summary(out: Path) -> dict:
    return json.loads((out / "report" / "summary.json").read_text())


def test_interrupted_campaign_then_resume_counts_every_run_on_disk(tmp_path):
    spec, out = spec_from_mapping(SPEC), tmp_path / "c"
    with pytest.raises(KeyboardInterrupt, match="after 6 of 6 runs"):
        run_campaign(spec, out, serial=True, progress=False, run_fn=_finished_as_ctrl_c_came)
    on_disk = sorted(p.parent.name for p in (out / "runs").glob("*/result.json"))
    assert len(on_disk) == 6
    assert sorted(r["run_id"] for r in read_results(out)) == on_disk
    assert (_summary(out)["runs"], _summary(out)["ok"]) == (6, 6)

    # a report written before the last runs landed (the failure this guards: "2 of 2 runs ok")
    stale = dict(_summary(out), runs=2, ok=2, results_digest=results_digest(read_results(out)[:2]))
    (out / "report" / "summary.json").write_text(json.dumps(stale))
    result = run_campaign(spec, out, resume=True, serial=True, progress=False, run_fn=_mean_run)
    assert (result.ran, result.skipped) == (0, 6)
    assert (_summary(out)["runs"], _summary(out)["ok"]) == (6, 6)


def test_resume_rewrites_a_report_whose_results_changed_with_the_same_counts(tmp_path):
    """A run's figure changed on disk (same runs, same ok count): ``--resume`` runs nothing,
    but the report is rewritten from the new table, since it was written from another one."""
    spec, out = spec_from_mapping(SPEC), tmp_path / "c"
    run_campaign(spec, out, serial=True, progress=False, run_fn=_mean_run)
    before = _summary(out)
    assert before["results_digest"]
    run_id = sorted(p.name for p in (out / "runs").iterdir() if (p / "result.json").is_file())[0]
    row = json.loads((out / "runs" / run_id / "result.json").read_text())
    row["metrics"]["experiment.mean"] = 1000.0  # far from every seeded mean, so the group mean moves
    (out / "runs" / run_id / "result.json").write_text(json.dumps(row))

    result = run_campaign(spec, out, resume=True, serial=True, progress=False, run_fn=_mean_run)
    assert (result.ran, result.skipped) == (0, 6)
    after = _summary(out)
    assert (after["runs"], after["ok"]) == (before["runs"], before["ok"]) == (6, 6)
    assert after["results_digest"] != before["results_digest"]
    means = [r["experiment.mean"] for r in read_results(out) if r["variant"] == row["variant"]]
    assert 1000.0 in means
    group = next(g for g in after["groups"] if g["variant"] == row["variant"])
    assert group["metrics"]["experiment.mean"]["mean"] == pytest.approx(sum(means) / len(means), rel=1e-12)

    # nothing changed since: a further resume leaves the report alone (same file, same time)
    stamp = (out / "report" / "summary.json").stat().st_mtime_ns
    run_campaign(spec, out, resume=True, serial=True, progress=False, run_fn=_mean_run)
    assert (out / "report" / "summary.json").stat().st_mtime_ns == stamp
