"""Group a node's inputs by lockstep step and release each step, in order, once every input
due at that step has arrived (no rclpy).

Nodes that must act on exactly the inputs of step k (a controller whose command k the
vehicle waits for, an estimator that must fuse every sample in order) feed each message's
step here. Different inputs may sample at different steps, so ``needs(k)`` says which are
due at step k. Arrival order across topics never changes what is released, which keeps a
run deterministic.
"""
from __future__ import annotations

from typing import Any, Callable


class StepGroups:
    """Pending inputs by step (module docstring).

    A message for a step at or before the last released one is rejected and counted in
    ``rejected``, unless it lies more than ``backjump_steps`` back: that is a clock jump (a
    replayed bag looping), so everything pending is dropped, ``restarts`` counts it and the
    message starts the new run.
    """

    def __init__(self, needs: Callable[[int], tuple[str, ...]], backjump_steps: float) -> None:
        self.needs = needs
        self.backjump_steps = float(backjump_steps)
        self._pending: dict[int, dict[str, Any]] = {}
        self.last_step: int | None = None
        self.rejected = 0
        self.restarts = 0

    def add(self, kind: str, k: int, msg: Any, logger: Any = None) -> list[tuple[int, dict[str, Any]]]:
        """Add input ``kind`` of step ``k``; returns the steps it completes, in order, as
        (step, {kind: msg}) (empty when it completes none or is rejected). A node's
        ``logger`` (rclpy's, or anything with ``info``/``warning``) hears of restarts and,
        at most once a second, of rejections."""
        last = self.last_step
        if last is not None and k <= last:
            if last - k <= self.backjump_steps:
                self.rejected += 1
                if logger is not None:
                    logger.warning(f"{kind} stamped for step {k}, already past step {last}: ignored "
                                   f"({self.rejected} rejected)", throttle_duration_sec=1.0)
                return []
            self._pending.clear()
            self.last_step = None
            self.restarts += 1
            if logger is not None:
                logger.info(f"inputs jumped back from step {last} to {k} (a replay looping?): restarting")
        self._pending.setdefault(k, {})[kind] = msg
        done = []
        for step in sorted(self._pending):
            group = self._pending[step]
            if not all(need in group for need in self.needs(step)):
                break
            del self._pending[step]
            self.last_step = step
            done.append((step, group))
        return done
