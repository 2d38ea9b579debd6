"""The QoS, timing and QoS-event plumbing every node's inputs and outputs go through.

Two timings (the ``timing`` parameter, :data:`gimbal_kinematics.params.table.TIMING_PARAM`):

* ``lockstep``: the orchestrator's deterministic graph. Every input and output uses
  :data:`~gimbal_kinematics.ros.qos.GRAPH_QOS` (reliable, transient-local, keep-last 100),
  exactly as before this module existed, so scenario bags stay byte-identical.
  ``gimbal-run`` writes ``timing: lockstep`` into every node's params that has the parameter.
* ``free`` (the default for a node started alone, e.g. by ``ros2 run``): the node steps on
  the stamps of the messages it gets. Inputs use the REP 2003 consumer profile
  (``SensorDataQoS``: best effort, volatile), which matches a driver's sensor-data
  publisher, a default-QoS (reliable, volatile) publisher and ``ros2 bag play``; outputs
  use the ROS default (reliable, volatile, keep-last 10), which every default subscriber
  matches.

Every publisher and subscription made through :class:`NodeIo` accepts rclpy's standard QoS
overrides (``QoSOverridingOptions``): parameters
``qos_overrides.<topic>.subscription.{reliability,durability,history,depth}`` and
``qos_overrides.<topic>.publisher.{...}``, ``<topic>`` the fully qualified, remapped topic
name, e.g. ``--ros-args -p qos_overrides./gimbal/imu.subscription.reliability:=reliable``.
(rclpy's ``with_default_policies()`` covers history, depth and reliability; durability is
added because a durability mismatch is the other way a subscription and a publisher fail
to match.) An incompatible-QoS event is logged once per topic and direction, naming the
topic, the policy and the parameter that fixes it, and every event is counted
(:attr:`NodeIo.incompatible_qos`, for ``/diagnostics``).

A publisher of another type on an input topic (a ``std_msgs/String`` on ``/gimbal/imu``)
never matches the subscription, so its messages never arrive, and Fast DDS raises no
incompatible-type event (an RMW that does runs the check at once). Every
:data:`TYPE_CHECK_S` seconds (a steady timer: graph polling, not stepping) the node's input
topics are looked up on the graph (``get_publishers_info_by_topic``); each
publisher of another type is logged once per topic and type, naming both types and the
publishing node, and counted (:attr:`NodeIo.wrong_type`, for ``/diagnostics``).
:meth:`NodeIo.counters` gives both counters, as a node's /diagnostics carries them.
"""
from __future__ import annotations

from typing import Any, Callable

from rclpy.clock import Clock, ClockType
from rclpy.event_handler import PublisherEventCallbacks, SubscriptionEventCallbacks
from rclpy.node import Node
from rclpy.publisher import Publisher
from rclpy.qos import (
    DurabilityPolicy, HistoryPolicy, QoSPolicyKind, QoSProfile, ReliabilityPolicy, qos_policy_name_from_kind,
)
from rclpy.qos_overriding_options import QoSOverridingOptions
from rclpy.subscription import Subscription

from gimbal_kinematics.params.table import TIMING_CHOICES, TIMING_PARAM  # noqa: F401  (re-exported)
from gimbal_kinematics.params.table import ros2_control_topic

from .qos import GRAPH_QOS, ROS2_CONTROL_QOS

#: Input depth in free timing. ``qos_profile_sensor_data`` keeps 5 samples; 100 holds
#: 0.1 s of a 1 kHz sensor (0.5 s at 200 Hz) while the node is busy, e.g. on a loaded
#: 2-core machine or under ``ros2 bag play`` at a high rate. Reliability and durability
#: are those of ``qos_profile_sensor_data`` (best effort, volatile), so matching is unchanged.
FREE_INPUT_DEPTH = 100

#: Output depth in free timing: the ROS default profile's 10.
FREE_OUTPUT_DEPTH = 10

#: Period of the check of the input topics' publisher types [s].
TYPE_CHECK_S = 1.0

#: The policies a user can override per topic (rclpy's defaults plus durability).
OVERRIDABLE_POLICIES = (QoSPolicyKind.HISTORY, QoSPolicyKind.DEPTH, QoSPolicyKind.RELIABILITY,
                        QoSPolicyKind.DURABILITY)


def _check_timing(timing: str) -> None:
    if timing not in TIMING_CHOICES:
        raise ValueError(f"parameter 'timing' = {timing!r} is not one of {list(TIMING_CHOICES)}")


def input_qos(timing: str) -> QoSProfile:
    """QoS of an input subscription: lockstep -> GRAPH_QOS; free -> the REP 2003 consumer
    profile (best effort, volatile, keep-last :data:`FREE_INPUT_DEPTH`)."""
    return _qos(timing, FREE_INPUT_DEPTH, ReliabilityPolicy.BEST_EFFORT)


def output_qos(timing: str) -> QoSProfile:
    """QoS of an output publisher: lockstep -> GRAPH_QOS; free -> the ROS default (reliable,
    volatile, keep-last :data:`FREE_OUTPUT_DEPTH`)."""
    return _qos(timing, FREE_OUTPUT_DEPTH, ReliabilityPolicy.RELIABLE)


def _qos(timing: str, free_depth: int, free_reliability: ReliabilityPolicy) -> QoSProfile:
    """GRAPH_QOS in lockstep; in free timing keep-last ``free_depth``, volatile."""
    _check_timing(timing)
    if timing == "lockstep":
        return GRAPH_QOS
    return QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=free_depth, reliability=free_reliability,
                      durability=DurabilityPolicy.VOLATILE)


def type_name(msg_type: Any) -> str:
    """The ROS name of a message class, as the graph gives it: ``sensor_msgs/msg/Imu``."""
    return f"{msg_type.__module__.split('.')[0]}/msg/{msg_type.__name__}"


def _policy_name(kind: Any) -> str:
    try:
        return qos_policy_name_from_kind(kind)
    except ValueError:
        return str(kind)


class NodeIo:
    """Publishers and subscriptions of one node, with QoS overrides and incompatible-QoS
    accounting (module docstring). Make one per node."""

    def __init__(self, node: Node) -> None:
        self.node = node
        self._logged: set[tuple[str, str]] = set()
        self._totals: dict[int, int] = {}  # per entity: rmw's cumulative incompatible count
        self._inputs: dict[str, str] = {}  # input topic -> the type it takes
        self._wrong: set[tuple[str, str]] = set()  # (topic, type) of publishers of another type
        self._type_timer = None

    @property
    def incompatible_qos(self) -> int:
        """Incompatible-QoS peers seen so far, summed over this node's publishers and
        subscriptions (rmw's cumulative ``total_count`` of each), for ``/diagnostics``."""
        return sum(self._totals.values())

    @property
    def wrong_type(self) -> int:
        """(topic, type) pairs seen so far of publishers of another type on an input topic."""
        return len(self._wrong)

    def counters(self) -> dict[str, int]:
        """This plumbing's counters, for ``/diagnostics``."""
        return {"incompatible_qos": self.incompatible_qos, "wrong_type": self.wrong_type}

    def _watch_types(self, topic: str, msg_type: Any) -> None:
        """Remember the type ``topic`` takes; start the periodic check (module docstring)."""
        self._inputs[topic] = type_name(msg_type)
        if self._type_timer is None:
            self._type_timer = self.node.create_timer(TYPE_CHECK_S, self.check_types,
                                                      clock=Clock(clock_type=ClockType.STEADY_TIME))

    def check_types(self) -> None:
        """Log and count each publisher of another type on an input topic (once per topic and type)."""
        for topic, wanted in self._inputs.items():
            for info in self.node.get_publishers_info_by_topic(topic):
                if info.topic_type == wanted or (topic, info.topic_type) in self._wrong:
                    continue
                self._wrong.add((topic, info.topic_type))
                who = f"{info.node_namespace.rstrip('/')}/{info.node_name}" if info.node_name else "a publisher"
                self.node.get_logger().error(
                    f"wrong message type on {topic}: {who} publishes {info.topic_type}, this node takes {wanted}; "
                    "its messages never arrive. Counted on /diagnostics as wrong_type; logged once per topic and type.")

    def _on_incompatible(self, entity: int, topic: str, kind: str, profile: QoSProfile, event: Any) -> None:
        """Count the event; log it the first time for this topic and direction."""
        total = getattr(event, "total_count", None)
        self._totals[entity] = int(total) if total is not None else self._totals.get(entity, 0) + 1
        if (topic, kind) in self._logged:
            return
        self._logged.add((topic, kind))
        policy = _policy_name(getattr(event, "last_policy_kind", QoSPolicyKind.INVALID))
        peer = "publisher" if kind == "subscription" else "subscription"
        ours = {"RELIABILITY": profile.reliability.name.lower(), "DURABILITY": profile.durability.name.lower()}
        mine = f" (ours: {ours[policy]})" if policy in ours else ""
        self.node.get_logger().warning(
            f"incompatible QoS on {topic}: a {peer} does not match this {kind}'s {policy}{mine}; no messages "
            f"flow between them. Fix: set the parameter qos_overrides.{topic}.{kind}.{policy.lower()} "
            f"(e.g. --ros-args -p qos_overrides.{topic}.{kind}.{policy.lower()}:=...) or the peer's QoS. "
            "Counted on /diagnostics as incompatible_qos; logged once per topic.")

    def subscribe(self, msg_type: Any, topic: str, callback: Callable[[Any], None], timing: str,
                  raw: bool = False) -> Subscription:
        """A subscription with :func:`input_qos` of ``timing``, overridable by parameters."""
        profile = input_qos(timing)
        name = self.node.resolve_topic_name(topic)
        holder: dict[str, QoSProfile] = {}

        def on_event(event: Any) -> None:
            self._on_incompatible(id(holder), name, "subscription", holder.get("qos", profile), event)

        sub = self.node.create_subscription(
            msg_type, topic, self._watched(callback) if timing == "lockstep" else callback, profile, raw=raw,
            # an RMW that reports a type mismatch has it named at once (the check looks the type up)
            event_callbacks=SubscriptionEventCallbacks(incompatible_qos=on_event,
                                                       incompatible_type=lambda _event: self.check_types()),
            qos_overriding_options=QoSOverridingOptions(policy_kinds=OVERRIDABLE_POLICIES))
        holder["qos"] = sub.qos_profile
        self._watch_types(name, msg_type)
        return sub

    def _watched(self, callback: Callable[[Any], None]) -> Callable[[Any], None]:
        """``callback``, then the warning of the node's lockstep policy when inputs come but no
        step (:class:`gimbal_kinematics.timing.stream_stats.SilenceWatch`)."""
        def watched(msg: Any) -> None:
            callback(msg)
            watch = getattr(getattr(self.node, "policy", None), "silence", None)
            text = watch.take() if watch is not None else None
            if text:
                self.node.get_logger().warning(text)
        return watched

    def advertise(self, msg_type: Any, topic: str, timing: str, profile: QoSProfile | None = None) -> Publisher:
        """A publisher with :func:`output_qos` of ``timing`` (or ``profile``, a contract's own, e.g.
        ros2_control's), overridable by parameters."""
        profile = output_qos(timing) if profile is None else profile
        name = self.node.resolve_topic_name(topic)
        holder: dict[str, QoSProfile] = {}

        def on_event(event: Any) -> None:
            self._on_incompatible(id(holder), name, "publisher", holder.get("qos", profile), event)

        pub = self.node.create_publisher(
            msg_type, topic, profile,
            event_callbacks=PublisherEventCallbacks(incompatible_qos=on_event),
            qos_overriding_options=QoSOverridingOptions(policy_kinds=OVERRIDABLE_POLICIES))
        holder["qos"] = pub.qos_profile
        return pub

    def advertise_command(self, msg_type: Any, graph_topic: str, values: dict) -> Publisher:
        """A controller's effort-command publisher in the form its ``command_interface`` chooses
        (:data:`gimbal_kinematics.params.table.COMMAND_INTERFACE_PARAM`): ``graph_topic`` with the
        timing's QoS, or ``ros2_control_topic`` with :data:`.qos.ROS2_CONTROL_QOS`."""
        if values["command_interface"] == "ros2_control":
            return self.advertise(msg_type, ros2_control_topic(values), values["timing"], ROS2_CONTROL_QOS)
        return self.advertise(msg_type, graph_topic, values["timing"])

