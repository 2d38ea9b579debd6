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

import sys

from rclpy.event_handler import SubscriptionEventCallbacks
from rclpy.node import Node
from rclpy.task import Future
from rosgraph_msgs.msg import Clock

from gimbal_kinematics.ros import messages as m
from gimbal_kinematics.ros.node_main import run_node
from gimbal_kinematics.ros.qos import GRAPH_QOS
from gimbal_kinematics.params.table import ParameterError
from gimbal_kinematics.ros.params import declare_and_read
from ..bag.qos_yaml import qos_to_dict
from .bag_recorder_params import DESCRIPTION, PARAMS
from ..bag.schemas import message_class
from ..bag.writer import BagWriter, DiskStopped
from .recorder_topics import TopicChoice, TopicStamps, record_rates, start_live, subscription_qos


class BagRecorderNode(Node):
    def __init__(self, **node_kwargs) -> None:
        super().__init__("bag_recorder", **node_kwargs)
        values = declare_and_read(self, PARAMS)
        if not values["output_dir"]:
            raise ParameterError("parameter 'output_dir' is required")
        self.rates = record_rates(values)
        # before the bag: a port in use leaves nothing behind
        self.live = start_live(values, self.get_logger().info, self.get_logger().error)
        try:
            self.writer = BagWriter(values["output_dir"], chunk_duration_ns=int(values["chunk_duration_s"] * 1e9),
                                    compress=values["compress"])
        except FileExistsError as exc:
            if self.live is not None:
                self.live.close()
            raise ParameterError(f"parameter 'output_dir': {exc}") from exc
        self.choice = TopicChoice(self, list(values["topics"]), set(values["exclude_topics"])
                                  | {self.resolve_topic_name("~/progress")}, list(values["wait_for_nodes"]))
        self.rate = values["sim_rate_hz"]
        self.progress_every = values["progress_every_steps"]
        self.end_ns = int(round(values["end_time_s"] * 1e9))
        self.subs: dict[str, object] = {}
        self.live_subs: dict[str, object] = {}  # live view sources not recorded (no readiness, no pacing)
        self.stamps = TopicStamps()
        self.lost = 0           # middleware message-lost events
        self.messages_heard = 0  # node_main spins on after a stop while this grows
        self.ready = False
        #: why the recording stopped before its end (a full disk), for node_main's exit code
        self.failure: str | None = None
        self.done = Future()
        self.pub_progress = self.create_publisher(Clock, "~/progress", GRAPH_QOS)
        self._discovery = self.create_timer(0.05, self._discover)

    # --- discovery (wall timer: graph polling, not stepping) -----------------------------
    def _discover(self) -> None:
        for topic, type_name in self.choice.candidates(self.live is not None and self.live.on).items():
            if topic not in self.subs and topic not in self.live_subs:
                self._subscribe(topic, type_name)
        if not self.ready and self.choice.matched(self.subs):
            self.ready = True
            self.get_logger().info(f"recording {len(self.subs)} topics to {self.writer.directory}")
            self.pub_progress.publish(m.clock_msg(0))

    def _subscribe(self, topic: str, type_name: str) -> None:
        offered = [info.qos_profile for info in self.get_publishers_info_by_topic(topic)]
        self.stamps.add(topic, type_name)
        if self.choice.wanted and topic not in self.choice.wanted:
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
        self.messages_heard += 1
        stamp = self.stamps.heard(topic, data)
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
            self.live.publish(topic, data, self.stamps.stamp_of(topic, data))

    def close(self) -> None:
        """Finish the bag (idempotent); records the loss counters in the log."""
        if self.live is not None:
            self.live.close()
            self.live = None
        if not self.writer.closed:
            self.writer.close()
            text = (f"bag closed: {self.writer.message_count} messages on {len(self.writer.topics)} topics, "
                    f"{self.lost} lost, {self.stamps.out_of_order} out of order")
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
