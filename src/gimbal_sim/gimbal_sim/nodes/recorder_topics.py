"""What ``bag_recorder`` (:mod:`.bag_recorder_node`) knows of the topics it records: the
QoS to subscribe with, each message's stamp (read from the CDR payload, or the newest
``/clock``) and the order of a topic's stamps, which topics to take from the graph, and the
live view it feeds. The node holds the subscriptions, the writer and the progress.
"""
from __future__ import annotations

import struct
from pathlib import Path
from typing import Any, Callable

from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

from gimbal_kinematics.params.table import ParameterError
from gimbal_kinematics.ros.qos import GRAPH_QOS
from ..bag.live import SOURCE_TOPICS as LIVE_SOURCES, LiveGuard, LivePortError, LiveRelay, parse_topic_rates
from ..bag.record_rates import RecordRates
from ..bag.scene_config import SceneConfig
from ..bag.schemas import msg_text, split_type

_STAMP = struct.Struct("<iI")


def stamp_first(type_name: str) -> bool:
    """True when the type's first field is a std_msgs/Header or builtin_interfaces/Time, so
    its CDR payload starts (after the 4-byte encapsulation) with sec:int32, nanosec:uint32."""
    for line in msg_text(*split_type(type_name)).splitlines():
        line = line.split("#", 1)[0].strip()
        if line:
            return line.split()[0] in ("std_msgs/Header", "Header", "builtin_interfaces/Time")
    return False


def subscription_qos(offered: list[QoSProfile]) -> QoSProfile:
    """The strongest QoS every offering publisher is compatible with."""
    reliable = offered and all(q.reliability == ReliabilityPolicy.RELIABLE for q in offered)
    transient = offered and all(q.durability == DurabilityPolicy.TRANSIENT_LOCAL for q in offered)
    depth = max([GRAPH_QOS.depth] + [q.depth for q in offered if q.history == HistoryPolicy.KEEP_LAST])
    return QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=depth,
                      reliability=ReliabilityPolicy.RELIABLE if reliable else ReliabilityPolicy.BEST_EFFORT,
                      durability=DurabilityPolicy.TRANSIENT_LOCAL if transient else DurabilityPolicy.VOLATILE)


class TopicStamps:
    """Each recorded message's stamp: its header's, or for a type without one the newest
    ``/clock``; ``out_of_order`` counts stamps going backwards within a topic."""

    def __init__(self) -> None:
        self._stamped: dict[str, bool] = {}
        self._last: dict[str, int] = {}
        self.clock_ns = 0
        self.out_of_order = 0

    def add(self, topic: str, type_name: str) -> None:
        self._stamped[topic] = stamp_first(type_name)

    def stamp_of(self, topic: str, data: bytes) -> int:
        if self._stamped[topic] and len(data) >= 12 and data[1] == 1:  # CDR little-endian
            sec, nanosec = _STAMP.unpack_from(data, 4)
            return sec * 1_000_000_000 + nanosec
        return self.clock_ns

    def heard(self, topic: str, data: bytes) -> int:
        """A recorded message's stamp, its order judged (counted) and ``/clock`` followed."""
        stamp = self.stamp_of(topic, data)
        last = self._last.get(topic)
        if last is not None and stamp < last:
            self.out_of_order += 1
        self._last[topic] = stamp
        if topic == "/clock":
            self.clock_ns = stamp
        return stamp


class TopicChoice:
    """Which of the graph's topics to record (``topics``, or all but ``exclude`` that have a
    publisher) and whether the recording is matched, on ``node``'s graph API (rclpy's)."""

    def __init__(self, node: Any, wanted: list[str], exclude: set[str], wait_for_nodes: list[str]) -> None:
        self.node, self.wanted, self.exclude, self.wait_for_nodes = node, wanted, exclude, wait_for_nodes

    def candidates(self, live_on: bool) -> dict[str, str]:
        node = self.node
        types = {name: types[0] for name, types in node.get_topic_names_and_types() if types}
        if self.wanted:
            # and the live view's sources this run publishes: relayed, not recorded
            extra = [t for t in LIVE_SOURCES if live_on and t not in self.wanted and node.count_publishers(t) > 0]
            return {t: types[t] for t in [*self.wanted, *extra] if t in types}
        # a topic only subscribed to (e.g. an estimate nobody publishes in this run) has nothing to record
        return {t: ty for t, ty in types.items() if t not in self.exclude and node.count_publishers(t) > 0}

    def matched(self, subs: dict[str, Any]) -> bool:
        """Every wanted topic (or every topic of ``wait_for_nodes``) subscribed, each with a publisher."""
        if self.wanted and set(self.wanted) - set(subs):
            return False
        if not self.wanted:
            names = dict(self.node.get_node_names_and_namespaces())
            if set(self.wait_for_nodes) - set(names):
                return False
            for node in self.wait_for_nodes:
                published = {t for t, _ in self.node.get_publisher_names_and_types_by_node(node, names[node])}
                if (published - self.exclude) - set(subs):
                    return False
        return all(sub.get_publisher_count() > 0 for sub in subs.values())


def record_rates(values: dict) -> RecordRates:
    """The recording rates ``record_topic_rates`` asks for; :class:`ParameterError` names it."""
    try:
        return RecordRates(parse_topic_rates(values["record_topic_rates"]))
    except ValueError as exc:
        raise ParameterError(f"parameter 'record_topic_rates': {exc}") from exc


def start_live(values: dict, info: Callable[[str], None], error: Callable[[str], None]) -> LiveGuard | None:
    """The live view the parameters ask for (None: ``live_port`` 0); :class:`ParameterError`
    names the parameter refused (a port in use, bad rates)."""
    if not values["live_port"]:
        return None
    try:
        rates = parse_topic_rates(values["live_topic_rates"])
    except ValueError as exc:
        raise ParameterError(f"parameter 'live_topic_rates': {exc}") from exc
    # the run's scene description, written beside the bag before any node starts: its target, ...
    scene, missing = SceneConfig.beside(Path(values["output_dir"]))
    try:
        live = LiveRelay(values["live_host"], values["live_port"], values["live_rate_hz"], rates, scene)
    except LivePortError as exc:
        raise ParameterError(f"parameter 'live_port': {exc}") from exc
    info(f"live view on ws://{values['live_host']}:{live.port}")
    if missing:
        info(missing)
    # an error in the live view logs once and turns it off; the recording goes on
    return LiveGuard(live, error)
