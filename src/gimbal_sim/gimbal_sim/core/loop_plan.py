"""What every engine runner shares: the scenario's nodes with their parameter values, and
the result of a run (:class:`CoreLoopResult`). :mod:`.core_loop` (the Python loop over the
stages) and the compiled runners (:mod:`.compiled`) both take them from here.
"""
from __future__ import annotations

from array import array
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..graph.plan import plan_nodes
from ..graph.registry import NODE_TYPES
from ..graph.scenario import Scenario, ScenarioError

#: Nodes with no core to step (they only observe the run).
PASSIVE = {"bag_recorder"}


class NoCoreError(ScenarioError):
    """The scenario has a node whose core this loop cannot step."""


def node_values(scenario: Scenario) -> dict[str, tuple[str, dict[str, Any]]]:
    """node name -> (executable, every parameter value the node would read: its declared
    defaults, then the scenario's values, then what the orchestrator sets)."""
    out = {}
    for planned in plan_nodes(scenario, Path("/nonexistent")):
        if planned.executable in PASSIVE:
            continue
        values = {p.name: p.default for p in NODE_TYPES[planned.executable].params}
        values.update(planned.params)
        out[planned.name] = (planned.executable, values)
    return out


@dataclass
class CoreLoopResult:
    steps: int                 # lockstep steps taken (truth k -> k+1)
    sim_s: float
    wall_s: float
    cpu_s: float
    step_latency_s: array      # wall time of each step [s], when kept (else empty)
    commands: list | None      # torque commands per step, when recorded

    @property
    def steps_per_s(self) -> float:
        return self.steps / self.wall_s if self.wall_s > 0 else float("inf")
