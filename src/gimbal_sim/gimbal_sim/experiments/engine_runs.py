"""A scenario run on the one engine, as a campaign's ``engine: core`` run: the engine's run with
its bag (:func:`..core.engine_run.run_engine`), then the scenario's report from that bag, as for
a graph run. Scenario campaigns and the experiments that are declarations (their runs are a
scenario's, :class:`..campaign.experiment.ExperimentCampaign` with ``run`` None) run through it."""
from __future__ import annotations

from pathlib import Path
from typing import Any

from ..core.engine_run import run_engine
from ..graph.scenario import Scenario
from ..reports.dispatch import write_report


def run_on_engine(scenario: Scenario, run_dir: Path, compress: bool = True) -> dict[str, Any]:
    """Step ``scenario`` on the engine into ``run_dir`` (its bag, ``run.json``), then write its
    report from the bag; returns the report's metrics."""
    run_engine(scenario, run_dir, compress)
    return write_report(run_dir)[1]
