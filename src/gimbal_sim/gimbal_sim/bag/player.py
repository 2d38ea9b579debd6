"""Play a bag back onto ROS topics, serialized bytes as recorded.

QoS, as ``ros2 bag play`` does it: each topic is offered with the reliability and
durability it was recorded with (``offered_qos_profiles``; when the recorded publishers
differ, reliable only if all were, transient-local only if all were; none recorded: the
ROS default, reliable volatile), so the subscriptions of the nodes that wrote or read it
match. ``--qos-profile-overrides-path`` replaces any of it per topic (rosbag2's YAML).

* Reliable volatile topics: KEEP_ALL, so the middleware applies back-pressure to a slow
  reliable reader, and a publish that times out under that pressure is retried, never
  dropped. A best-effort reader (a free-timing node's SensorDataQoS) gets no back-pressure:
  at ``--rate 0`` pace it (``--pace``) or it drops what its queue cannot hold.
* Transient-local topics: reliable KEEP_LAST with a deep history (``TRANSIENT_DEPTH``); a
  transient-local KEEP_ALL writer would keep the whole bag in memory for late joiners.
  Such a writer does not block, so a reader that falls more than that far behind loses
  samples: pace it.
* Best-effort topics: best effort KEEP_ALL (a best-effort writer never blocks).

Pacing: the player starts once each ``pace_topics`` reader has reported "ready" on its
progress topic (``rosgraph_msgs/Clock``), and never runs more than ``pace_window_s`` of bag
time ahead of the time each one reports (the time of the next sample it needs). Our nodes
all report one, so ``--pace`` makes replay into them lossless at any rate.

``/clock`` (``--clock RATE_HZ``): the bag time, on a grid of 1/RATE_HZ of bag time (at
``--rate`` r that is RATE_HZ/r per wall second; rosbag2 publishes RATE_HZ per wall
second), each grid time published before the first message at or after it.
"""
from __future__ import annotations

import sys
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Protocol

import yaml
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rosgraph_msgs.msg import Clock

from gimbal_kinematics.cli.boundary import RunFailed, read_text
from gimbal_kinematics.ros import messages as m
from gimbal_kinematics.ros.qos import GRAPH_QOS

from .qos_yaml import qos_from_dict
from .checks import damage_warnings
from .reader import BagContents, BagError, RawMessage, read_messages
from .schemas import message_class

PLAY_QOS = QoSProfile(history=HistoryPolicy.KEEP_ALL, reliability=ReliabilityPolicy.RELIABLE,
                      durability=DurabilityPolicy.VOLATILE)
TRANSIENT_DEPTH = 1000
TRANSIENT_PLAY_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=TRANSIENT_DEPTH,
                                reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)
BEST_EFFORT_PLAY_QOS = QoSProfile(history=HistoryPolicy.KEEP_ALL, reliability=ReliabilityPolicy.BEST_EFFORT,
                                  durability=DurabilityPolicy.VOLATILE)


def _all(offered: list[dict], key: str, value: str) -> bool:
    return bool(offered) and all(str(o.get(key, "")).lower() == value for o in offered)


def play_qos(offered: list[dict]) -> QoSProfile:
    """The profile to play a topic with, from its recorded ``offered_qos_profiles``."""
    if _all(offered, "durability", "transient_local") and not _all(offered, "reliability", "best_effort"):
        return TRANSIENT_PLAY_QOS
    if offered and not _all(offered, "reliability", "reliable"):
        return BEST_EFFORT_PLAY_QOS
    return PLAY_QOS


def load_qos_overrides(path: Path | None) -> dict[str, QoSProfile]:
    """rosbag2's ``--qos-profile-overrides-path`` YAML: ``/topic: {reliability: best_effort,
    durability: volatile, history: keep_last, depth: 10}``; fields not given keep the profile
    the player would have used. Raises :class:`BagError` naming the option on a bad file."""
    if path is None:
        return {}
    text = read_text(path, "--qos-profile-overrides-path")
    try:
        data = yaml.safe_load(text) or {}
    except yaml.YAMLError as exc:
        raise BagError(f"--qos-profile-overrides-path {path}: not YAML: {' '.join(str(exc).split())}") from None
    if not isinstance(data, dict) or not all(isinstance(k, str) and isinstance(v, dict) for k, v in data.items()):
        raise BagError(f"--qos-profile-overrides-path {path}: expected a mapping /topic -> {{reliability, "
                       f"durability, history, depth}}")
    allowed = {"reliability": ("reliable", "best_effort", "system_default"),
               "durability": ("volatile", "transient_local", "system_default"),
               "history": ("keep_last", "keep_all", "system_default")}
    out = {}
    known = (*allowed, "depth")
    for topic, entry in data.items():
        for key, value in entry.items():
            if key not in known:
                raise BagError(f"--qos-profile-overrides-path {path}: {topic}.{key}: unknown key; "
                               f"the known keys are {', '.join(known)}")
            if key in allowed and str(value).lower() not in allowed[key]:
                raise BagError(f"--qos-profile-overrides-path {path}: {topic}.{key} = {value!r}, "
                               f"expected one of {allowed[key]}")
            if key == "depth" and (not isinstance(value, int) or value < 0):
                raise BagError(f"--qos-profile-overrides-path {path}: {topic}.depth = {value!r}, expected an int >= 0")
        out[topic] = entry
    return out


PUBLISH_RETRY_LIMIT = 1000
#: Wall time [s] a paced wait goes on before the player says, and repeats, what it waits for.
PACE_STALL_WARN_S = 10.0
#: Spin this often (messages) besides the waits: the player's only subscriptions are the
#: progress topics (served while it waits on them), and a spin costs more than a publish.
SPIN_EVERY = 256


@dataclass
class PlayOptions:
    rate: float = 1.0                 # 0: as fast as delivery allows
    clock_hz: float = 0.0             # > 0: publish /clock on a grid of 1/clock_hz s of bag time
    topics: list[str] | None = None   # None: every topic
    exclude_topics: list[str] = field(default_factory=list)
    remap: dict[str, str] = field(default_factory=dict)
    start_offset_s: float = 0.0
    playback_duration_s: float = -1.0  # < 0: to the end
    start_paused: bool = False        # wait for a keypress (a newline when stdin is not a terminal)
    loop: bool = False
    wait_for_subscribers: int = 0     # matched subscriptions each topic needs before playing
    pace_topics: list[str] = field(default_factory=list)
    pace_window_s: float = 0.05
    wait_timeout_s: float = 30.0      # give up waiting for readers or their progress after this [s]
    qos_overrides: dict[str, dict] = field(default_factory=dict)
    merge: bool = False               # several .mcap files without metadata.yaml: read as one bag

    def __post_init__(self) -> None:
        if not self.rate >= 0.0:
            raise BagError(f"--rate must be >= 0 (0: maximum), got {self.rate}")
        if not self.start_offset_s >= 0.0:
            raise BagError(f"--start-offset must be >= 0 s, got {self.start_offset_s}")
        if self.wait_for_subscribers < 0:
            raise BagError("--wait-for-subscribers must be >= 0")
        if not self.clock_hz >= 0.0:
            raise BagError(f"--clock must be a rate > 0 Hz, got {self.clock_hz}")
        if self.playback_duration_s != self.playback_duration_s:
            raise BagError("--playback-duration must be a number of seconds (< 0: to the end)")
        if not 0.0 < self.wait_timeout_s < float("inf"):
            raise BagError(f"--wait-timeout must be a finite number of seconds > 0, got {self.wait_timeout_s}")
        for name in ("rate", "start_offset_s", "clock_hz", "playback_duration_s"):
            if abs(getattr(self, name)) == float("inf"):
                raise BagError(f"--{name.removesuffix('_s').removesuffix('_hz').replace('_', '-')} must be finite")


def parse_remaps(items: list[str]) -> dict[str, str]:
    remap = {}
    for item in items:
        old, sep, new = item.partition(":=")
        if not sep or not old.startswith("/") or not new.startswith("/"):
            raise BagError(f"--remap {item!r}: expected /old/topic:=/new/topic")
        remap[old] = new
    return remap


def wait_for_key(stream=None) -> None:
    """Block until a key is pressed on a terminal, or a line (or end of input) arrives otherwise."""
    stream = stream or sys.stdin
    if stream.isatty():
        import termios
        import tty

        fd = stream.fileno()
        saved = termios.tcgetattr(fd)
        try:
            tty.setcbreak(fd)
            stream.read(1)
        finally:
            termios.tcsetattr(fd, termios.TCSADRAIN, saved)
    else:
        stream.readline()


class PlaySink(Protocol):
    """Where the player also hands each message it publishes (the live view, ``--live``): told
    each topic it will get, under its played name, then each message's CDR bytes and log
    time; closed with the player. The player never builds one: its caller does."""

    def add_topic(self, topic: str, type_name: str) -> None: ...

    def publish(self, topic: str, data: bytes, stamp_ns: int) -> None: ...

    def close(self) -> None: ...


class BagPlayer(Node):
    """Publishes a bag's messages; :meth:`play` blocks until done (or forever with loop).
    ``sink``: also handed every published message (:class:`PlaySink`); the player closes it."""

    def __init__(self, bag_dir: Path, options: PlayOptions, sink: PlaySink | None = None, **node_kwargs) -> None:
        super().__init__("bag_player", **node_kwargs)
        self.options = options
        self.sink = sink
        wanted = set(options.topics) if options.topics else None
        if wanted is not None:
            wanted -= set(options.exclude_topics)
        messages, contents = read_messages(Path(bag_dir), wanted, merge=options.merge)
        if contents.message_count == 0:
            raise BagError(f"{bag_dir}: nothing to play: " + (f"no message can be read ({contents.error})"
                                                             if contents.error else "the bag holds no messages"))
        for option, names in (("--topics", set(options.topics or ())),
                              ("--exclude-topics", set(options.exclude_topics)),
                              ("--remap", set(options.remap)),
                              ("--qos-profile-overrides-path", set(options.qos_overrides))):
            missing = names - set(contents.topics)
            if missing:
                raise BagError(f"{option}: topics not in the bag: {sorted(missing)}; it has {sorted(contents.topics)}")
        self.contents: BagContents = contents
        for line in damage_warnings(contents):
            self.get_logger().warning(line.removeprefix("warning: "))
        if contents.error:
            self.get_logger().warning(f"bag not closed cleanly ({contents.error}); playing every part that checks")
        start = (contents.start_ns or 0) + int(round(options.start_offset_s * 1e9))
        stop = None if options.playback_duration_s < 0 else start + int(round(options.playback_duration_s * 1e9))
        excluded = set(options.exclude_topics)
        self.messages: list[RawMessage] = sorted(
            (x for x in messages if x.log_time_ns >= start and (stop is None or x.log_time_ns <= stop)
             and x.topic not in excluded), key=lambda x: x.log_time_ns)
        if not self.messages:
            span = (contents.end_ns - contents.start_ns) * 1e-9
            raise BagError(f"nothing to play: --topics / --exclude-topics, --start-offset {options.start_offset_s:g} s "
                           f"and --playback-duration {options.playback_duration_s:g} s select no message of a bag "
                           f"of {span:.3f} s")
        self.pubs = {}
        self.qos = {}
        for topic in sorted({x.topic for x in self.messages}):
            record = contents.topics[topic]
            qos = play_qos(record.qos_profiles)
            if topic in options.qos_overrides:
                qos = qos_from_dict(options.qos_overrides[topic], qos)
            self.qos[topic] = qos
            self.pubs[topic] = self.create_publisher(message_class(record.type_name),
                                                     options.remap.get(topic, topic), qos)
        self.pub_clock = self.create_publisher(Clock, "/clock", PLAY_QOS) if options.clock_hz > 0 else None
        if sink is not None:
            for topic in self.pubs:
                sink.add_topic(options.remap.get(topic, topic), contents.topics[topic].type_name)
        self._paced: dict[str, int | None] = {t: None for t in options.pace_topics}
        self._pace_subs: dict[str, object] = {}
        self.t_bag0 = self.messages[0].log_time_ns if self.messages else 0
        self._warned_best_effort = False
        self._best_effort_check = 0.0
        self.published = 0
        self.retries = 0
        self.clocks = 0

    def _on_progress(self, topic: str, msg: Clock) -> None:
        # Any report means "connected, send me the bag": "ready" is step 0, which is epoch 0 for a
        # free-timing node fed epoch stamps, and no report can ask for a message before the first.
        # Unclamped, a "ready" arriving as the wait ends left the reader 1.8e9 s behind: the
        # player waited for a report from a node that had been sent nothing, forever.
        self._paced[topic] = max(m.stamp_ns(msg.clock), self._paced[topic] or 0, self.t_bag0)

    def _subscribe_progress(self) -> None:
        """Subscribe to each progress topic once its publisher is known, with its durability.

        A reader counts as ready once it reports (``announce_when_connected``: "ready" once
        its inputs have publishers), not once its progress topic matches: discovery matches
        each direction on its own, so this player's publishers may have matched a reader that
        has not yet matched them, and a best-effort reader drops what such a writer sends; the
        first window would be lost and the reader would never report. A lockstep node offers
        progress transient-local and says "ready" once: this subscription gets it even if made
        later. A free-timing node offers it volatile (a transient-local subscription would not
        match) and says "ready" to each new progress reader once its inputs are connected.
        """
        for topic in self._paced:
            if topic in self._pace_subs:
                continue
            offered = self.get_publishers_info_by_topic(topic)
            if not offered:
                continue
            durable = all(i.qos_profile.durability == DurabilityPolicy.TRANSIENT_LOCAL for i in offered)
            qos = GRAPH_QOS if durable else QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=100,
                                                       reliability=ReliabilityPolicy.RELIABLE,
                                                       durability=DurabilityPolicy.VOLATILE)
            self._pace_subs[topic] = self.create_subscription(
                Clock, topic, lambda msg, t=topic: self._on_progress(t, msg), qos)

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

    def _awaited(self) -> list[str]:
        """What the player still waits for before it plays: subscribers and progress reports."""
        need = self.options.wait_for_subscribers
        out = [f"{need} subscriber(s) on {topic} (has {pub.get_subscription_count()})"
               for topic, pub in self.pubs.items() if pub.get_subscription_count() < need]
        return out + [f"progress on {topic}" for topic, v in self._paced.items() if v is None]

    def wait_for_readers(self, executor) -> None:
        """``--wait-for-subscribers`` / ``--pace``: say at once what is awaited; give up after
        ``wait_timeout_s`` (a :class:`RunFailed`: nobody came)."""
        timeout_s = self.options.wait_timeout_s
        deadline = time.monotonic() + timeout_s
        said = False
        while awaited := self._awaited():
            self._subscribe_progress()
            if not said:
                print(f"gimbal-bag play: waiting up to {timeout_s:g} s (--wait-timeout) for {'; '.join(awaited)}",
                      file=sys.stderr, flush=True)
                said = True
            if time.monotonic() > deadline:
                raise RunFailed(f"no reader came within {timeout_s:g} s (--wait-timeout): still waiting for "
                                f"{'; '.join(awaited)}; nothing was played")
            self._spin(executor, 0.05)
        self.warn_best_effort()

    def warn_best_effort(self) -> None:
        """A best-effort reader of an unpaced replay drops what it cannot keep up with, as ROS does."""
        if self._paced or self._warned_best_effort:
            return
        for topic in self.pubs:
            remapped = self.options.remap.get(topic, topic)
            lossy = sorted(i.node_name for i in self.get_subscriptions_info_by_topic(remapped)
                           if i.qos_profile.reliability == ReliabilityPolicy.BEST_EFFORT)
            if lossy:
                self._warned_best_effort = True
                print(f"gimbal-bag play: warning: {', '.join(lossy)} read(s) {remapped} best effort: messages it "
                      f"cannot keep up with are dropped; --pace <its progress topic> plays no faster than it "
                      f"reads", file=sys.stderr, flush=True)
                return

    def wait_for_resume(self, executor, key_source=None) -> None:
        """``--start-paused``: keep the graph alive until a key (or a newline) arrives."""
        if not self.options.start_paused:
            return
        print("paused: press a key (or send a newline) to start playing", file=sys.stderr, flush=True)
        pressed = threading.Event()
        threading.Thread(target=lambda: (wait_for_key(key_source), pressed.set()), daemon=True).start()
        while not pressed.is_set():
            self._spin(executor, 0.05)

    def _clock_until(self, t_ns: int, next_clock: int, period: int) -> int:
        """Publish every /clock grid time up to ``t_ns``; returns the next grid time."""
        while next_clock <= t_ns:
            self._publish(self.pub_clock, m.clock_msg(next_clock))
            self.clocks += 1
            next_clock += period
        return next_clock

    def _wait_for_pace(self, executor, t_ns: int, window_ns: int) -> None:
        """Spin until every paced reader is within ``window_ns`` of bag time ``t_ns``; say what
        is awaited every :data:`PACE_STALL_WARN_S` (a reader that stops reporting otherwise
        stalls the replay without a word)."""
        started = time.monotonic()
        warn_at = started + PACE_STALL_WARN_S
        while min(self._paced.values()) + window_ns < t_ns:
            self._spin(executor, 0.01)
            if time.monotonic() > started + self.options.wait_timeout_s:
                raise RunFailed(f"paced: no progress for {self.options.wait_timeout_s:g} s (--wait-timeout) from "
                                f"{sorted(self._paced)}; stopped after {self.published} of {len(self.messages)} "
                                f"messages")
            if time.monotonic() > warn_at:
                warn_at += PACE_STALL_WARN_S
                behind = {topic: f"{(v - self.t_bag0) * 1e-9:.3f} s" for topic, v in self._paced.items()
                          if v + window_ns < t_ns}
                self.get_logger().warning(
                    f"paced: waiting {time.monotonic() - started:.0f} s for progress; readers at {behind} of bag time, "
                    f"next message at {(t_ns - self.t_bag0) * 1e-9:.3f} s ({self.published} published)")

    def play(self, executor) -> int:
        """Publish every message once (or repeatedly with loop); returns messages published."""
        self.wait_for_readers(executor)
        self.wait_for_resume(executor)
        window = int(self.options.pace_window_s * 1e9)
        rate = self.options.rate
        paced = bool(self._paced)
        period = int(round(1e9 / self.options.clock_hz)) if self.pub_clock is not None else 0
        pubs = {topic: self.pubs[topic] for topic in self.pubs}
        while True:
            t_bag0 = self.t_bag0
            next_clock = t_bag0
            t_wall0 = time.monotonic()
            for i, msg in enumerate(self.messages):
                t = msg.log_time_ns
                if rate > 0:
                    target = t_wall0 + (t - t_bag0) * 1e-9 / rate
                    while (delay := target - time.monotonic()) > 0:
                        self._spin(executor, min(delay, 0.01))
                        if period:  # /clock keeps ticking through a gap in the bag
                            now = t_bag0 + int((time.monotonic() - t_wall0) * rate * 1e9)
                            next_clock = self._clock_until(min(now, t), next_clock, period)
                if paced and min(self._paced.values()) + window < t:
                    self._wait_for_pace(executor, t, window)
                if period:
                    next_clock = self._clock_until(t, next_clock, period)
                self._publish(pubs[msg.topic], msg.data)
                if self.sink is not None:
                    self.sink.publish(self.options.remap.get(msg.topic, msg.topic), msg.data, t)
                self.published += 1
                if i % SPIN_EVERY == 0:
                    self._spin(executor)
                    if not paced and time.monotonic() > self._best_effort_check:
                        self._best_effort_check = time.monotonic() + 1.0
                        self.warn_best_effort()
            if not self.options.loop:
                self.drain()
                return self.published

    def destroy_node(self) -> None:
        sink, self.sink = self.sink, None
        if sink is not None:
            sink.close()
        super().destroy_node()

    def drain(self, timeout_s: float = 30.0) -> None:
        """Wait until every reliable reader has acknowledged what was published: the last
        messages of a fast replay are still in flight when the loop ends, and a publisher
        destroyed then takes them with it."""
        from rclpy.duration import Duration

        deadline = time.monotonic() + timeout_s
        for topic, pub in self.pubs.items():
            if self.qos[topic].reliability == ReliabilityPolicy.RELIABLE:
                left = max(deadline - time.monotonic(), 0.0)
                if not pub.wait_for_all_acked(Duration(nanoseconds=int(left * 1e9))):
                    self.get_logger().warning(f"{topic}: not every reader acknowledged the last messages")
