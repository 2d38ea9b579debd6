"""The engine's bag: what the graph's recorder would write, from the nodes' own serialisation.

Each stage hands its node's messages to :class:`EngineBag` as the node's serialisation
function makes them (``nodes.wire``, ``gimbal_estimators.wire``, ``gimbal_control.wire``:
``[(topic, type, bytes)]``), and the bag writes them as the graph's ``bag_recorder`` does:
the topic resolved as ROS resolves the node's (``~/x`` → ``/<node>/x``, then the node's
remaps), the scenario's ``record`` list and ``record_rates_hz`` honoured
(:class:`..bag.record_rates.RecordRates`), the log and publish time the message's header
stamp, the offered QoS the graph's publishers offer. The same seed therefore gives the same
topics, types, stamps and CDR bytes as a graph run (``gimbal-bench compare``).

What only the graph carries is not written (:data:`GRAPH_ONLY`, docs/architecture.md).
"""
from __future__ import annotations

import struct
from pathlib import Path

from ..bag.record_rates import RecordRates
from ..bag.writer import BagWriter
from ..graph.scenario import Scenario

#: Topics only the graph carries: each node's health with its process's figures (wall-clock
#: timing, middleware QoS events) and the lockstep handshake of the nodes and the recorder.
GRAPH_ONLY = ("/diagnostics", "/<node>/progress")

#: The offered QoS of the graph's publishers as its recorder reads them from the middleware
#: (GRAPH_QOS: reliable, transient-local; the middleware reports no history or depth).
_INFINITE = {"sec": 9223372036, "nsec": 854775807}
GRAPH_OFFERED_QOS = [{"history": "unknown", "depth": 0, "reliability": "reliable", "durability": "transient_local",
                      "deadline": dict(_INFINITE), "lifespan": dict(_INFINITE), "liveliness": "automatic",
                      "liveliness_lease_duration": dict(_INFINITE), "avoid_ros_namespace_conventions": False}]

_STAMP = struct.Struct("<iI")
_SKIP = object()


def resolve(node: str, topic: str, remap: dict[str, str]) -> str:
    """The topic name a node's publisher of ``topic`` gets (``~/x`` private, ``x`` relative
    to the root namespace), after the node's remaps (``from: to``, matched on the name as
    declared or as resolved)."""
    if topic in remap:
        topic = remap[topic]
    if topic.startswith("~/"):
        name = f"/{node}/{topic[2:]}"
    elif not topic.startswith("/"):
        name = f"/{topic}"
    else:
        name = topic
    return remap.get(name, name)


class EngineBag:
    """``bag(node, messages)``: record one node's messages (module docstring); :meth:`close`
    finishes the bag and writes its ``metadata.yaml``."""

    def __init__(self, out_dir: Path, scenario: Scenario, compress: bool = True) -> None:
        # fsync'd once a wall second, not each half second of sim time: the engine runs
        # hundreds of times faster than real time (BagWriter's crash safety)
        self.writer = BagWriter(out_dir, compress=compress, sync_wall_s=1.0)
        self.wanted = None if scenario.record == "all" else set(scenario.record)
        self.rates = RecordRates(scenario.record_rates_hz)
        self.remaps = {name: spec.get("remap") or {} for name, spec in scenario.nodes.items()}
        self._names: dict[tuple[str, str], object] = {}

    def _register(self, node: str, topic: str, type_name: str) -> object:
        name = self.topic_name(node, topic)
        if name is None:
            name = _SKIP
        else:
            self.add_topic(name, type_name)
        self._names[(node, topic)] = name
        return name

    def topic_name(self, node: str, topic: str) -> str | None:
        """The bag's name of ``node``'s ``topic``, or None when the scenario does not record
        it; :meth:`add_topic` registers it before its first message."""
        name = resolve(node, topic, self.remaps.get(node, {}))
        return None if self.wanted is not None and name not in self.wanted else name

    def add_topic(self, name: str, type_name: str) -> None:
        self.writer.add_topic(name, type_name, GRAPH_OFFERED_QOS)

    def __call__(self, node: str, messages: list[tuple[str, str, bytes]]) -> None:
        names, rates, write = self._names, self.rates, self.writer.write
        for topic, type_name, data in messages:
            name = names.get((node, topic))
            if name is None:
                name = self._register(node, topic, type_name)
            if name is _SKIP:
                continue
            sec, nanosec = _STAMP.unpack_from(data, 4)
            stamp = sec * 1_000_000_000 + nanosec
            if rates and not rates.keep(name, stamp):
                continue
            write(name, data, stamp)

    @property
    def message_count(self) -> int:
        return self.writer.message_count

    def close(self) -> None:
        self.writer.close()
