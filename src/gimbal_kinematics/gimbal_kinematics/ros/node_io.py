"""The QoS, timing and QoS-event plumbing every node's inputs and outputs go through.

Two timings (the ``timing`` parameter, :data:`gimbal_kinematics.params.TIMING_PARAM`):

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
"""
from __future__ import annotations

from typing import Any, Callable

from rclpy.event_handler import PublisherEventCallbacks, SubscriptionEventCallbacks
from rclpy.node import Node
from rclpy.publisher import Publisher
from rclpy.qos import (
    DurabilityPolicy, HistoryPolicy, QoSPolicyKind, QoSProfile, ReliabilityPolicy, qos_policy_name_from_kind,
)
from rclpy.qos_overriding_options import QoSOverridingOptions
from rclpy.subscription import Subscription

from gimbal_kinematics.params import TIMING_CHOICES, TIMING_PARAM  # noqa: F401  (re-exported)
from gimbal_kinematics.params import ros2_control_topic

from .qos import GRAPH_QOS, ROS2_CONTROL_QOS

#: Input depth in free timing. ``qos_profile_sensor_data`` keeps 5 samples; 100 holds
#: 0.1 s of a 1 kHz sensor (0.5 s at 200 Hz) while the node is busy, e.g. on a loaded
#: 2-core machine or under ``ros2 bag play`` at a high rate. Reliability and durability
#: are those of ``qos_profile_sensor_data`` (best effort, volatile), so matching is unchanged.
FREE_INPUT_DEPTH = 100

#: Output depth in free timing: the ROS default profile's 10.
FREE_OUTPUT_DEPTH = 10

#: The policies a user can override per topic (rclpy's defaults plus durability).
OVERRIDABLE_POLICIES = (QoSPolicyKind.HISTORY, QoSPolicyKind.DEPTH, QoSPolicyKind.RELIABILITY,
                        QoSPolicyKind.DURABILITY)


def _check_timing(timing: str) -> None:
    if timing not in TIMING_CHOICES:
        raise ValueError(f"parameter 'timing' = {timing!r} is not one of {list(TIMING_CHOICES)}")


def input_qos(timing: str) -> QoSProfile:
    """QoS of an input subscription: lockstep -> GRAPH_QOS; free -> the REP 2003 consumer
    profile (best effort, volatile, keep-last :data:`FREE_INPUT_DEPTH`)."""
    _check_timing(timing)
    if timing == "lockstep":
        return GRAPH_QOS
    return QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=FREE_INPUT_DEPTH,
                      reliability=ReliabilityPolicy.BEST_EFFORT, durability=DurabilityPolicy.VOLATILE)


def output_qos(timing: str) -> QoSProfile:
    """QoS of an output publisher: lockstep -> GRAPH_QOS; free -> the ROS default (reliable,
    volatile, keep-last :data:`FREE_OUTPUT_DEPTH`)."""
    _check_timing(timing)
    if timing == "lockstep":
        return GRAPH_QOS
    return QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=FREE_OUTPUT_DEPTH,
                      reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.VOLATILE)


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

    @property
    def incompatible_qos(self) -> int:
        """Incompatible-QoS peers seen so far, summed over this node's publishers and
        subscriptions (rmw's cumulative ``total_count`` of each), for ``/diagnostics``."""
        return sum(self._totals.values())

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
            event_callbacks=SubscriptionEventCallbacks(incompatible_qos=on_event),
            qos_overriding_options=QoSOverridingOptions(policy_kinds=OVERRIDABLE_POLICIES))
        holder["qos"] = sub.qos_profile
        return sub

    def _watched(self, callback: Callable[[Any], None]) -> Callable[[Any], None]:
        """``callback``, then the warning of the node's lockstep policy when inputs come but no
        step (:class:`gimbal_kinematics.input_policy.SilenceWatch`)."""
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
        (:data:`gimbal_kinematics.params.COMMAND_INTERFACE_PARAM`): ``graph_topic`` with the
        timing's QoS, or ``ros2_control_topic`` with :data:`.qos.ROS2_CONTROL_QOS`."""
        if values["command_interface"] == "ros2_control":
            return self.advertise(msg_type, ros2_control_topic(values), values["timing"], ROS2_CONTROL_QOS)
        return self.advertise(msg_type, graph_topic, values["timing"])

