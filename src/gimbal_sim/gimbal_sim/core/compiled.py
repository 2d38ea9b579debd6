"""The engine's compiled runners: ``(matches(values), run(values, keep_commands, record))``
pairs; the first whose ``matches`` holds for a scenario's nodes (``core_loop.node_values``:
name -> (executable, parameter values)) runs it in place of the per-step Python loop
(:func:`.core_loop.run_core_loop`, when no observer watches each step); ``run`` returns
(steps, simulated s, wall s, CPU s, commands or None), handing ``record`` (None: unrecorded;
:class:`.recording.EngineBag`) what the nodes publish."""
from __future__ import annotations

from . import compiled_sighting

RUNNERS = [(compiled_sighting.matches, compiled_sighting.run)]


def compiled_runner(values):
    """The first runner whose ``matches(values)`` holds, or None."""
    return next((run for matches, run in RUNNERS if matches(values)), None)
