"""A flexure core fed as its node and the engine feed it: each unit's samples through
:class:`gimbal_kinematics.timing.sync.StampPairs`, the pairs to the core."""
from __future__ import annotations

from collections import ChainMap
from typing import Any

from gimbal_kinematics.timing.sync import StampPairs


class Fed:
    """``core`` with per-unit inputs (``on_lgu1``, ``on_lgu2``), its counters and the
    pairing's in one live view (:attr:`counters`); anything else is the core's."""

    def __init__(self, core: Any) -> None:
        self.core = core
        self.pairs = StampPairs.feeding(core)

    def on_lgu1(self, t: float, dalpha: Any, dt: float) -> Any:
        return self.pairs.add(0, t, dalpha, dt)

    def on_lgu2(self, t: float, dalpha: Any, dt: float) -> Any:
        return self.pairs.add(1, t, dalpha, dt)

    @property
    def counters(self) -> ChainMap:
        return ChainMap(self.core.counters, self.pairs.counts)

    def __getattr__(self, name: str) -> Any:
        return getattr(self.core, name)


class Counted:
    """A flexure node's core with the node's pairing counters beside its own (:attr:`counters`);
    anything else is the core's."""

    def __init__(self, node: Any) -> None:
        self.node = node

    @property
    def counters(self) -> ChainMap:
        return ChainMap(self.node.core.counters, self.node.pairs.counts)

    def __getattr__(self, name: str) -> Any:
        return getattr(self.node.core, name)
