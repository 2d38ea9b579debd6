"""One scenario run on the engine into a run directory, as a graph run leaves it.

:func:`run_engine` writes what ``gimbal-run`` writes for the graph: ``scenario.yaml``,
``params/<node>.yaml`` (the nodes' final parameters), the bag (``metadata.yaml`` +
``<name>_0.mcap``, :class:`.recording.EngineBag`) and ``run.json`` (with ``engine: core``).
The report and its page come from the bag, by the same report function as a graph run's
(``gimbal_sim.reports.dispatch.write_report``, called by ``gimbal-run --engine core`` and by
the campaign's core runs).

The engine steps in lockstep: a scenario with a node in ``realtime`` or ``free`` timing (whose
data depend on the wall clock) is refused, as are one whose plant takes ros2_control's command
contract and one with a node it has no stage for (:func:`check_engine`).
"""
from __future__ import annotations

import json
import time
from dataclasses import dataclass
from pathlib import Path

from ..graph.plan import plan_nodes, write_run_files
from ..graph.scenario import Scenario
from .core_loop import CoreLoopResult, NoCoreError, check_stages, core_plan, node_values, run_core_loop
from .recording import EngineBag


@dataclass
class EngineRun:
    result: CoreLoopResult
    wall_s: float          # the whole run, bag closed included [s]
    message_count: int     # messages written to the bag


def check_engine(scenario: Scenario) -> None:
    """Raise :class:`.core_loop.NoCoreError` naming why the engine cannot run ``scenario``'s
    node set (its parameters are the nodes' own checks, ``graph.plan.check_nodes``)."""
    clocked = sorted(n for n, spec in scenario.nodes.items() if spec["params"].get("timing", "lockstep") != "lockstep")
    if clocked:
        raise NoCoreError(f"{', '.join(clocked)} in realtime or free timing: their data depend on the wall clock, "
                          f"which the engine does not have")
    contract = sorted(n for n, spec in scenario.nodes.items()
                      if spec["params"].get("command_interface", "graph") != "graph")
    if contract:
        raise NoCoreError(f"{', '.join(contract)} with command_interface ros2_control: that contract (a command "
                          f"applied from the plant's next step, on another topic) is the graph's only")
    check_stages(node_values(scenario))


def run_engine(scenario: Scenario, out_dir: Path, compress: bool = True) -> EngineRun:
    """Step ``scenario`` on the engine into ``out_dir`` (which must not exist), recording its
    bag; raises :class:`.core_loop.NoCoreError` (nothing written) for a node set the engine
    cannot step, FileExistsError when ``out_dir`` exists."""
    out_dir = Path(out_dir)
    if out_dir.exists():
        raise FileExistsError(f"output directory {out_dir} already exists; not overwriting it")
    check_engine(scenario)  # a node set the engine cannot step, or a value a core refuses, before anything is written
    core_plan(scenario)
    t0 = time.perf_counter()
    write_run_files(scenario, plan_nodes(scenario, out_dir, compress), out_dir)
    bag = EngineBag(out_dir, scenario, compress)
    try:
        result = run_core_loop(scenario, record=bag)
    finally:
        bag.close()
    wall = time.perf_counter() - t0
    (out_dir / "run.json").write_text(json.dumps({
        "scenario": scenario.name, "engine": "core", "mode": "core", "seed": scenario.seed, "compressed": compress,
        "sim_s": result.sim_s, "interrupted": False, "wall_s": wall,
        "real_time_factor": result.sim_s / wall if wall > 0 else None,
        "steps_per_s": result.steps / wall if wall > 0 else None, "loop_wall_s": result.wall_s,
        "cpu_s": result.cpu_s, "messages": bag.message_count}, indent=2) + "\n")
    return EngineRun(result, wall, bag.message_count)
