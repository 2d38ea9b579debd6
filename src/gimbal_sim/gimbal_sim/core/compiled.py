"""The engine's compiled runners: node sets whose whole lockstep step is compiled.

Each entry is (``matches(scenario)``, ``run(scenario, record)``): ``matches`` says whether
the runner steps exactly this scenario's node set (and parameters) as the Python loop does;
``run`` steps it and returns a :class:`.loop_plan.CoreLoopResult`, handing ``record`` what
each node publishes. :func:`.core_loop.run_core_loop` takes the first that matches.
"""
from __future__ import annotations

from typing import Callable

from . import compiled_platform

RUNNERS: list[tuple[Callable, Callable]] = [
    (compiled_platform.matches, compiled_platform.run),
]


def compiled_runner(scenario) -> Callable | None:
    """The ``run`` of the first runner matching ``scenario``, or None."""
    return next((run for matches, run in RUNNERS if matches(scenario)), None)
