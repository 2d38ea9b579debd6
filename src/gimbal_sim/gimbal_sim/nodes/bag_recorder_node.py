"""``bag_recorder`` node: record a run's topics, raw, into a rosbag2-style MCAP bag.

Messages are taken serialized (``raw=True``) and written as they came: no re-encoding.
Log and publish times are the message's own header stamp (sim time) or, for a type without
one, the latest ``/clock``; a run therefore records identically however fast it ran.

Completeness: the recorder subscribes with the publishers' offered QoS (our graph's is
reliable, transient-local, depth 100), reports ready on ``~/progress`` only when every
wanted topic has a matched publisher, and then reports the next step it needs after each
``/clock``, so ``vehicle_dynamics`` never outruns it. Loss it can detect is counted: the
middleware's message-lost events and per-topic stamps that go backwards.

A full or failing disk stops the recording in order (:class:`..bag.writer.DiskStopped`): the
bag is closed at its last chunk on disk, with ``custom_data.stopped`` in its metadata, the
node logs one line naming the device and its free space and ends (exit 1 alone;
``gimbal-run`` then stops the run, keeps what was recorded and writes its report).
"""
from __future__ import annotations

import struct
import sys
from pathlib import Path

from rclpy.event_handler import SubscriptionEventCallbacks
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.task import Future
from rosgraph_msgs.msg import Clock

from gimbal_kinematics.ros import messages as m
from gimbal_kinematics.ros.node_main import run_node
from gimbal_kinematics.ros.qos import GRAPH_QOS
from gimbal_kinematics.params import ParameterError
from gimbal_kinematics.ros.params import declare_and_read
from ..bag.qos_yaml import qos_to_dict
from .bag_recorder_params import DESCRIPTION, PARAMS
from ..bag.schemas import message_class, msg_text, split_type
from ..bag.record_rates import RecordRates
from ..bag.writer import BagWriter, DiskStopped
from ..bag.live import SOURCE_TOPICS as LIVE_SOURCES, LiveGuard, LivePortError, LiveRelay, parse_topic_rates
from ..bag.scene_config import SceneConfig

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


class BagRecorderNode(Node):
    def __init__(self, **node_kwargs) -> None:
        super().__init__("bag_recorder", **node_kwargs)
        values = declare_and_read(self, PARAMS)
        if not values["output_dir"]:
            raise ParameterError("parameter 'output_dir' is required")
        try:
            self.rates = RecordRates(parse_topic_rates(values["record_topic_rates"]))
        except ValueError as exc:
            raise ParameterError(f"parameter 'record_topic_rates': {exc}") from exc
        self.live = self._start_live(values)  # before the bag: a port in use leaves nothing behind
        try:
            self.writer = BagWriter(values["output_dir"], chunk_duration_ns=int(values["chunk_duration_s"] * 1e9),
                                    compress=values["compress"])
        except FileExistsError as exc:
            if self.live is not None:
                self.live.close()
            raise ParameterError(f"parameter 'output_dir': {exc}") from exc
        self.wanted = list(values["topics"])
        self.exclude = set(values["exclude_topics"]) | {self.resolve_topic_name("~/progress")}
        self.wait_for_nodes = list(values["wait_for_nodes"])
        self.rate = values["sim_rate_hz"]
        self.progress_every = values["progress_every_steps"]
        self.end_ns = int(round(values["end_time_s"] * 1e9))
        self.subs: dict[str, object] = {}
        self.live_subs: dict[str, object] = {}  # live view sources not recorded (no readiness, no pacing)
        self._stamped: dict[str, bool] = {}
        self._last_stamp: dict[str, int] = {}
        self.clock_ns = 0
        self.lost = 0           # middleware message-lost events
        self.out_of_order = 0   # stamps going backwards within a topic
        self.ready = False
        #: why the recording stopped before its end (a full disk), for node_main's exit code
        self.failure: str | None = None
        self.done = Future()
        self.pub_progress = self.create_publisher(Clock, "~/progress", GRAPH_QOS)
        self._discovery = self.create_timer(0.05, self._discover)

    def _start_live(self, values: dict) -> LiveGuard | None:
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
        self.get_logger().info(f"live view on ws://{values['live_host']}:{live.port}")
        if missing:
            self.get_logger().info(missing)
        # an error in the live view logs once and turns it off; the recording goes on
        return LiveGuard(live, self.get_logger().error)

    # --- discovery (wall timer: graph polling, not stepping) -----------------------------
    def _candidate_topics(self) -> dict[str, str]:
        types = {name: types[0] for name, types in self.get_topic_names_and_types() if types}
        if self.wanted:
            # and the live view's sources this run publishes: relayed, not recorded (_subscribe)
            extra = [t for t in LIVE_SOURCES if self.live is not None and self.live.on and t not in self.wanted
                     and self.count_publishers(t) > 0]
            return {t: types[t] for t in [*self.wanted, *extra] if t in types}
        # a topic only subscribed to (e.g. an estimate nobody publishes in this run) has nothing to record
        return {t: ty for t, ty in types.items() if t not in self.exclude and self.count_publishers(t) > 0}

    def _discover(self) -> None:
        for topic, type_name in self._candidate_topics().items():
            if topic not in self.subs and topic not in self.live_subs:
                self._subscribe(topic, type_name)
        if not self.ready and self._all_matched():
            self.ready = True
            self.get_logger().info(f"recording {len(self.subs)} topics to {self.writer.directory}")
            self.pub_progress.publish(m.clock_msg(0))

    def _all_matched(self) -> bool:
        if self.wanted and set(self.wanted) - set(self.subs):
            return False
        if not self.wanted:
            names = {n for n, _ in self.get_node_names_and_namespaces()}
            if set(self.wait_for_nodes) - names:
                return False
            for node in self.wait_for_nodes:
                ns = dict(self.get_node_names_and_namespaces())[node]
                published = {t for t, _ in self.get_publisher_names_and_types_by_node(node, ns)}
                if (published - self.exclude) - set(self.subs):
                    return False
        return all(sub.get_publisher_count() > 0 for sub in self.subs.values())

    def _subscribe(self, topic: str, type_name: str) -> None:
        offered = [info.qos_profile for info in self.get_publishers_info_by_topic(topic)]
        self._stamped[topic] = stamp_first(type_name)
        if self.wanted and topic not in self.wanted:
            if self.live is None:
                return
            self.live.add_topic(topic, type_name)
            self.live_subs[topic] = self.create_subscription(
                message_class(type_name), topic, lambda data, t=topic: self._relay_only(t, data),
                subscription_qos(offered), raw=True)
            return
        if self.failure is not None:
            return
        try:
            self.writer.add_topic(topic, type_name, [qos_to_dict(q) for q in offered] or [qos_to_dict(GRAPH_QOS)])
        except DiskStopped as exc:
            self._stop(exc)
            return
        if self.live is not None:
            self.live.add_topic(topic, type_name)
        events = SubscriptionEventCallbacks(message_lost=lambda status, t=topic: self._on_lost(t, status))
        self.subs[topic] = self.create_subscription(
            message_class(type_name), topic, lambda data, t=topic: self._on_message(t, data),
            subscription_qos(offered), raw=True, event_callbacks=events)

    # --- recording -----------------------------------------------------------------------
    def _on_lost(self, topic: str, status) -> None:
        self.lost += status.total_count_change
        self.get_logger().error(f"{topic}: {status.total_count_change} messages lost by the middleware")

    def _on_message(self, topic: str, data: bytes) -> None:
        stamp = self._stamp_of(topic, data)
        last = self._last_stamp.get(topic)
        if last is not None and stamp < last:
            self.out_of_order += 1
        self._last_stamp[topic] = stamp
        if self.failure is not None:
            return
        if not self.rates or self.rates.keep(topic, stamp):
            try:
                self.writer.write(topic, data, stamp)
            except DiskStopped as exc:
                self._stop(exc)
                return
        if self.live is not None:
            self.live.publish(topic, data, stamp)
        if topic == "/clock":
            self.clock_ns = stamp
            step = m.step_of_stamp(stamp, self.rate)
            if self.ready and ((step + 1) % self.progress_every == 0 or (self.end_ns and stamp >= self.end_ns)):
                self.pub_progress.publish(m.clock_cdr(m.step_stamp_ns(step + 1, self.rate)))

    def _stop(self, exc: DiskStopped) -> None:
        """The disk stopped the recording: the bag is closed; say so once and end the node."""
        self.failure = (f"recording stopped: {exc}; kept {self.writer.message_count} messages up to "
                        f"{self.writer.end_ns * 1e-9:.3f} s in {self.writer.directory}")
        self.get_logger().error(self.failure)
        if not self.done.done():
            self.done.set_result(True)

    def _relay_only(self, topic: str, data: bytes) -> None:
        if self.live is not None:
            self.live.publish(topic, data, self._stamp_of(topic, data))

    def _stamp_of(self, topic: str, data: bytes) -> int:
        if self._stamped[topic] and len(data) >= 12 and data[1] == 1:  # CDR little-endian
            sec, nanosec = _STAMP.unpack_from(data, 4)
            return sec * 1_000_000_000 + nanosec
        return self.clock_ns

    def close(self) -> None:
        """Finish the bag (idempotent); records the loss counters in the log."""
        if self.live is not None:
            self.live.close()
            self.live = None
        if not self.writer.closed:
            self.writer.close()
            text = (f"bag closed: {self.writer.message_count} messages on {len(self.writer.topics)} topics, "
                    f"{self.lost} lost, {self.out_of_order} out of order")
            if self.context.ok():
                self.get_logger().info(text)
            else:  # after Ctrl-C the context is gone and /rosout with it
                print(f"[bag_recorder] {text}", file=sys.stderr)

    def destroy_node(self) -> None:
        self.close()
        super().destroy_node()


def main(argv: list[str] | None = None) -> int:
    return run_node(BagRecorderNode, "bag_recorder", DESCRIPTION, argv)


if __name__ == "__main__":
    sys.exit(main())
