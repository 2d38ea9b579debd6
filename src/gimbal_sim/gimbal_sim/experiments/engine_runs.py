"""A scenario run on the one engine, as a campaign's ``engine: core`` run: the engine's run with
its bag (:func:`..core.engine_run.run_engine`), then the scenario's report from that bag, as for
a graph run. Scenario campaigns and the experiments that are declarations (their runs are a
scenario's, :class:`..campaign.experiment.ExperimentCampaign` with ``run`` None) run through it.

A scenario (or variant) with a ``prelude`` is two chained runs, on either engine
(:func:`run_chained`): the prelude scenario first (same seed, its own duration) into
``.<name>.prelude/prelude`` beside the run, whose hand-off turns its bag into a ROS 2 parameter
file applied to the scenario like ``--params-file``; then the scenario, with the hand-off's
figures in its ``hand_off.json``; the prelude's run then moves into the run's ``prelude/``.
"""
from __future__ import annotations

import dataclasses
import sys
from functools import partial
from pathlib import Path
from typing import Any, Callable

from gimbal_kinematics.cli.boundary import Interrupted, UsageError

from ..core.engine_run import run_engine
from ..graph.orchestrator import RunError
from ..graph.scenario import Scenario, ScenarioError, apply_params_file, prelude_base
from ..reports.dispatch import write_report
from ..reports.hand_off import HAND_OFFS, write_figures, write_hand_off

#: One run of a scenario without a prelude: (scenario, run dir, hand-off figures or None)
#: -> (its report's metrics, summary rows).
RunOne = Callable[[Scenario, Path, "dict | None"], "tuple[dict, list[tuple[str, str]]]"]


def prelude_scenario(scenario: Scenario) -> Scenario:
    """The single-run scenario of ``scenario``'s prelude: its scenario (and variant), the
    prelude's duration, ``scenario``'s seed; refuses (UsageError) an unknown hand-off or a
    prelude that has variants and names none, or a prelude of its own."""
    spec = scenario.prelude
    if spec["hand_off"] not in HAND_OFFS:
        raise UsageError(f"prelude of {scenario.name}: unknown hand_off {spec['hand_off']!r}; "
                         f"known: {', '.join(sorted(HAND_OFFS))}")
    try:
        first = prelude_base(spec)
    except ScenarioError as exc:
        raise UsageError(f"prelude of {scenario.name}: {exc}") from None
    if first.prelude:
        raise UsageError(f"prelude of {scenario.name}: {first.name!r} has a prelude itself; chain one at a time")
    return dataclasses.replace(first, seed=scenario.seed, duration_s=spec.get("duration_s", first.duration_s))


def run_chained(scenario: Scenario, out: Path, run_one: RunOne
                ) -> tuple[dict, dict, list[tuple[str, str]], list[tuple[str, str]]]:
    """Run ``scenario``'s prelude and then ``scenario`` from its hand-off, each with ``run_one``
    (module docstring). Returns the run's metrics, the hand-off figures, the prelude's summary
    rows (prefixed ``prelude:``, with their paths where the prelude ends up) and the run's."""
    first = prelude_scenario(scenario)
    staging = out.parent / f".{out.name}.prelude"
    if staging.exists():
        raise UsageError(f"{staging} exists (left by an earlier run?); not overwriting it")
    where = staging / "prelude"
    print(f"== prelude {first.name} ({first.duration_s:g} s) into {where}", file=sys.stderr)
    try:
        metrics, rows = run_one(first, where, None)
    except RunError as exc:
        raise RunError(f"prelude {first.name}: {exc} (its bag so far: {where})") from None
    if metrics.get("interrupted"):
        raise Interrupted(f"stopped in the prelude {first.name}; its bag, run.json and report are in {where}")
    if not metrics["closed_cleanly"]:
        raise RunError(f"prelude {first.name}: its bag was not closed cleanly ({where})")
    params_file, figures = write_hand_off(scenario.prelude["hand_off"], where)
    second = dataclasses.replace(apply_params_file(scenario, params_file), prelude=None)
    try:
        metrics, own_rows = run_one(second, out, figures)
    finally:
        if out.is_dir():  # the prelude's run goes with the run it started
            where.rename(out / "prelude")
            staging.rmdir()
    rows = [(f"prelude: {k}", v.replace(str(where), str(out / "prelude"))) for k, v in rows]
    return metrics, figures, rows, own_rows


def _engine_one(scenario: Scenario, run_dir: Path, hand_off: dict | None, compress: bool = True
                ) -> tuple[dict, list[tuple[str, str]]]:
    run_engine(scenario, run_dir, compress)
    if hand_off is not None:
        write_figures(run_dir, hand_off)
    return write_report(run_dir)[1], []


def run_on_engine(scenario: Scenario, run_dir: Path, compress: bool = True) -> dict[str, Any]:
    """Step ``scenario`` (after its prelude, if it has one) on the engine into ``run_dir`` (its
    bag, ``run.json``), then write its report from the bag; returns the report's metrics."""
    one = partial(_engine_one, compress=compress)
    if scenario.prelude:
        return run_chained(scenario, Path(run_dir), one)[0]
    return one(scenario, Path(run_dir), None)[0]
