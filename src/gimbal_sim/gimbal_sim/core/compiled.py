"""The engine's compiled runners: node sets whose whole lockstep step is compiled.

Each entry of :data:`RUNNERS` is (``matches(values, keep_commands)``,
``run(scenario, values, keep_commands, record)``): ``matches`` says whether the runner steps
exactly this node set (``loop_plan.node_values``: name -> (executable, parameter values)) as
the Python loop does; ``run`` steps it and returns a :class:`.loop_plan.CoreLoopResult`,
handing ``record`` (None: unrecorded; :class:`.recording.EngineBag`) what each node
publishes. :func:`.core_loop.run_core_loop` takes the first that matches.
"""
from __future__ import annotations

from array import array
from typing import Any, Callable

from . import compiled_platform, compiled_sighting
from .compiled_platform_setup import chain_values
from .loop_plan import CoreLoopResult


def _platform_matches(values: dict[str, Any], keep_commands: bool) -> bool:
    return not keep_commands and chain_values(values) is not None   # it keeps no command series


def _platform_run(scenario, values, keep_commands: bool, record) -> CoreLoopResult:
    return compiled_platform.run(scenario, record)


def _sighting_matches(values: dict[str, Any], keep_commands: bool) -> bool:
    return compiled_sighting.matches(values)


def _sighting_run(scenario, values, keep_commands: bool, record) -> CoreLoopResult:
    steps, sim_s, wall, cpu, commands = compiled_sighting.run(values, keep_commands, record)
    return CoreLoopResult(steps, sim_s, wall, cpu, array("d"), commands)


RUNNERS: list[tuple[Callable, Callable]] = [(_platform_matches, _platform_run), (_sighting_matches, _sighting_run)]


def compiled_runner(values: dict[str, Any], keep_commands: bool = False) -> Callable | None:
    """The ``run`` of the first runner matching the node set ``values``, or None."""
    return next((run for matches, run in RUNNERS if matches(values, keep_commands)), None)
