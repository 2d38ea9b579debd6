"""The QoS, timing and event plumbing every node's inputs and outputs share.

Two timings (parameter ``timing``, :data:`TIMING_CHOICES`):

* ``lockstep``: the orchestrator's deterministic graph; every topic uses ``GRAPH_QOS``
  (reliable, transient-local, keep-last 100), exactly as before.
* ``free`` (the default outside the orchestrator): a driver, a bag or ``ros2 bag play``
  feeds the node. Inputs use the REP 2003 consumer profile, rclpy's
  ``qos_profile_sensor_data``: best effort, volatile, keep-last 5. It matches sensor-data
  publishers, default-QoS publishers and ``ros2 bag play``. Outputs use the ROS default:
  reliable, volatile, keep-last 10.

Every publisher and subscription made here takes rclpy's standard QoS overrides
(``QoSOverridingOptions.with_default_policies()``: parameters such as
``qos_overrides./gimbal/imu.subscription.reliability``). An incompatible-QoS event is logged
once per topic, naming the topic, the policy and the parameter that fixes it, and counted
(:attr:`NodeIo.incompatible_qos`, for /diagnostics).
"""
from __future__ import annotations

from typing import Any, Callable

from rclpy.event_handler import PublisherEventCallbacks, SubscriptionEventCallbacks
from rclpy.qos import (DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy, qos_policy_name_from_kind,
                       qos_profile_sensor_data)
from rclpy.qos_overriding_options import QoSOverridingOptions

from ..params import TIMING_CHOICES  # noqa: F401  (re-exported: the contract names it here)
from .qos import GRAPH_QOS

#: Outputs in free timing: the ROS default profile.
FREE_OUTPUT_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=10, reliability=ReliabilityPolicy.RELIABLE,
                             durability=DurabilityPolicy.VOLATILE)


def _check(timing: str) -> None:
    if timing not in TIMING_CHOICES:
        raise ValueError(f"timing must be one of {TIMING_CHOICES}, got {timing!r}")


def input_qos(timing: str) -> QoSProfile:
    """Subscription profile: ``GRAPH_QOS`` in lockstep, ``qos_profile_sensor_data`` (best
    effort, volatile, keep-last 5) in free timing."""
    _check(timing)
    return GRAPH_QOS if timing == "lockstep" else qos_profile_sensor_data


def output_qos(timing: str) -> QoSProfile:
    """Publisher profile: ``GRAPH_QOS`` in lockstep, reliable volatile keep-last 10 in free."""
    _check(timing)
    return GRAPH_QOS if timing == "lockstep" else FREE_OUTPUT_QOS


class NodeIo:
    """Made once per node: creates its publishers and subscriptions with the timing's QoS,
    the standard QoS overrides and incompatible-QoS reporting (module docstring)."""

    def __init__(self, node: Any) -> None:
        self.node = node
        self._counts: dict[str, int] = {}

    @property
    def incompatible_qos(self) -> int:
        """Incompatible-QoS events so far, over every topic."""
        return sum(self._counts.values())

    def _on_incompatible(self, topic: str, side: str) -> Callable[[Any], None]:
        def callback(info: Any) -> None:
            first = topic not in self._counts
            self._counts[topic] = self._counts.get(topic, 0) + 1
            if first:
                policy = qos_policy_name_from_kind(info.last_policy_kind)
                name = self.node.resolve_topic_name(topic) if hasattr(self.node, "resolve_topic_name") else topic
                self.node.get_logger().error(
                    f"incompatible QoS on {name} ({side}): policy {policy}; set the parameter "
                    f"qos_overrides.{name}.{side}.{policy.lower()} to match the other side "
                    f"(counted in diagnostics: incompatible_qos)")
        return callback

    def subscribe(self, msg_type: Any, topic: str, callback: Callable[[Any], None], timing: str,
                  raw: bool = False) -> Any:
        """A subscription with the timing's input QoS (:func:`input_qos`)."""
        events = SubscriptionEventCallbacks(incompatible_qos=self._on_incompatible(topic, "subscription"))
        return self.node.create_subscription(
            msg_type, topic, callback, input_qos(timing), raw=raw, event_callbacks=events,
            qos_overriding_options=QoSOverridingOptions.with_default_policies())

    def advertise(self, msg_type: Any, topic: str, timing: str) -> Any:
        """A publisher with the timing's output QoS (:func:`output_qos`)."""
        events = PublisherEventCallbacks(incompatible_qos=self._on_incompatible(topic, "publisher"))
        return self.node.create_publisher(
            msg_type, topic, output_qos(timing), event_callbacks=events,
            qos_overriding_options=QoSOverridingOptions.with_default_policies())
