"""Play a bag back onto ROS topics, serialized bytes as recorded.

Each topic is offered with the durability it was recorded with (``offered_qos_profiles``,
as ``ros2 bag play`` does), so the subscriptions of the nodes that wrote or read it match:
a transient-local subscription (our graph's QoS) refuses a volatile publisher.

* Volatile topics: reliable KEEP_ALL, so the middleware applies back-pressure to a slow
  reader, and a publish that times out under that pressure is retried, never dropped.
* Transient-local topics: reliable KEEP_LAST with a deep history (``TRANSIENT_DEPTH``); a
  transient-local KEEP_ALL writer would keep the whole bag in memory for late joiners.
  Such a writer does not block, so a reader that falls more than that far behind loses
  samples: pace it.

Pacing: the player never runs more than ``pace_window_s`` of bag time ahead of the time
each ``pace_topics`` reader reports on its progress topic (``rosgraph_msgs/Clock``, the
time of the next step it needs). Our nodes all report one, so ``--pace`` makes replay into
them lossless at any rate.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path

from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rosgraph_msgs.msg import Clock

from gimbal_kinematics.ros import messages as m
from gimbal_kinematics.ros.qos import GRAPH_QOS
from .reader import BagContents, BagError, RawMessage, read_messages
from .schemas import message_class

PLAY_QOS = QoSProfile(history=HistoryPolicy.KEEP_ALL, reliability=ReliabilityPolicy.RELIABLE,
                      durability=DurabilityPolicy.VOLATILE)
TRANSIENT_DEPTH = 1000
TRANSIENT_PLAY_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=TRANSIENT_DEPTH,
                                reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)


def play_qos(offered: list[dict]) -> QoSProfile:
    """The profile to play a topic with, from its recorded ``offered_qos_profiles``."""
    durable = any(str(o.get("durability", "")).lower() == "transient_local" for o in offered or [])
    return TRANSIENT_PLAY_QOS if durable else PLAY_QOS
PUBLISH_RETRY_LIMIT = 1000


@dataclass
class PlayOptions:
    rate: float = 1.0                 # 0: as fast as delivery allows
    clock: bool = False               # publish /clock from bag time
    topics: list[str] | None = None   # None: every topic
    remap: dict[str, str] = field(default_factory=dict)
    start_offset_s: float = 0.0
    loop: bool = False
    wait_for_subscribers: int = 0     # matched subscriptions each topic needs before playing
    pace_topics: list[str] = field(default_factory=list)
    pace_window_s: float = 0.05

    def __post_init__(self) -> None:
        if not self.rate >= 0.0:
            raise BagError(f"--rate must be >= 0 (0: maximum), got {self.rate}")
        if not self.start_offset_s >= 0.0:
            raise BagError(f"--start-offset must be >= 0 s, got {self.start_offset_s}")
        if self.wait_for_subscribers < 0:
            raise BagError("--wait-for-subscribers must be >= 0")


def parse_remaps(items: list[str]) -> dict[str, str]:
    remap = {}
    for item in items:
        old, sep, new = item.partition(":=")
        if not sep or not old.startswith("/") or not new.startswith("/"):
            raise BagError(f"--remap {item!r}: expected /old/topic:=/new/topic")
        remap[old] = new
    return remap


class BagPlayer(Node):
    """Publishes a bag's messages; :meth:`play` blocks until done (or forever with loop)."""

    def __init__(self, bag_dir: Path, options: PlayOptions, **node_kwargs) -> None:
        super().__init__("bag_player", **node_kwargs)
        self.options = options
        wanted = set(options.topics) if options.topics else None
        messages, contents = read_messages(Path(bag_dir), wanted)
        if wanted:
            missing = wanted - set(contents.topics)
            if missing:
                raise BagError(f"topics not in the bag: {sorted(missing)}")
        self.contents: BagContents = contents
        if contents.error:
            self.get_logger().warning(f"bag not closed cleanly ({contents.error}); playing its complete part")
        start = (contents.start_ns or 0) + int(options.start_offset_s * 1e9)
        self.messages: list[RawMessage] = sorted((x for x in messages if x.log_time_ns >= start),
                                                 key=lambda x: x.log_time_ns)
        self.pubs = {}
        for topic in sorted({x.topic for x in self.messages}):
            record = contents.topics[topic]
            self.pubs[topic] = self.create_publisher(message_class(record.type_name),
                                                     options.remap.get(topic, topic), play_qos(record.qos_profiles))
        self.pub_clock = self.create_publisher(Clock, "/clock", PLAY_QOS) if options.clock else None
        self._paced = {t: None for t in options.pace_topics}
        for topic in options.pace_topics:
            # transient-local, as the nodes offer it: a reader's "ready" (step 0) may have
            # been published before the player started
            self.create_subscription(Clock, topic, lambda msg, t=topic: self._on_progress(t, msg), GRAPH_QOS)
        self.published = 0
        self.retries = 0

    def _on_progress(self, topic: str, msg: Clock) -> None:
        self._paced[topic] = max(m.stamp_ns(msg.clock), self._paced[topic] or 0)

    def _spin(self, executor, timeout: float = 0.0) -> None:
        executor.spin_once(timeout_sec=timeout)

    def _publish(self, pub, data) -> None:
        for _ in range(PUBLISH_RETRY_LIMIT):
            try:
                pub.publish(data)
                return
            except Exception:  # noqa: BLE001 - rclpy raises RCLError when back-pressure times out
                self.retries += 1
        raise BagError(f"could not deliver a message on {pub.topic_name} after {PUBLISH_RETRY_LIMIT} attempts")

    def wait_for_readers(self, executor, timeout_s: float = 30.0) -> None:
        deadline = time.monotonic() + timeout_s
        need = self.options.wait_for_subscribers
        while any(p.get_subscription_count() < need for p in self.pubs.values()) or \
                any(v is None for v in self._paced.values()):
            if time.monotonic() > deadline:
                raise BagError(f"readers did not appear within {timeout_s:g} s (need {need} per topic and "
                               f"progress on {sorted(self._paced)})")
            self._spin(executor, 0.05)

    def play(self, executor) -> int:
        """Publish every message once (or repeatedly with loop); returns messages published."""
        self.wait_for_readers(executor)
        window = int(self.options.pace_window_s * 1e9)
        while True:
            t_bag0 = self.messages[0].log_time_ns if self.messages else 0
            t_wall0 = time.monotonic()
            last_clock = None
            for msg in self.messages:
                if self.options.rate > 0:
                    target = t_wall0 + (msg.log_time_ns - t_bag0) * 1e-9 / self.options.rate
                    while (delay := target - time.monotonic()) > 0:
                        self._spin(executor, min(delay, 0.01))
                while self._paced and min(self._paced.values()) + window < msg.log_time_ns:
                    self._spin(executor, 0.01)
                if self.pub_clock is not None and msg.log_time_ns != last_clock:
                    self._publish(self.pub_clock, m.clock_msg(msg.log_time_ns))
                    last_clock = msg.log_time_ns
                self._publish(self.pubs[msg.topic], msg.data)
                self.published += 1
                self._spin(executor)
            if not self.options.loop:
                return self.published
