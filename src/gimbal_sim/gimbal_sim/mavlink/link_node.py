"""The MAVLink side both gimbal nodes (device and manager) run on the wall clock: the UDP
link of their parameters (:func:`.link.open_link`) drained every 10 ms and a ``HEARTBEAT``
sent at 1 Hz, on steady timers, and the link closed with the node.
"""
from __future__ import annotations

from collections.abc import Callable

from rclpy.clock import Clock, ClockType
from rclpy.node import Node

from .link import UdpLink

POLL_PERIOD_S = 0.01
HEARTBEAT_PERIOD_S = 1.0


class LinkNode(Node):
    """A node whose core (``self.core``) makes the ``HEARTBEAT`` it sends on ``self.link``
    (the node opens it with :func:`.link.open_link`)."""

    link: UdpLink

    def start_link(self, poll: Callable[[], None]) -> Clock:
        """The link's steady timers: ``poll`` drains it, the heartbeat goes out; returns the
        steady clock for the node's other wall-clock timers."""
        steady = Clock(clock_type=ClockType.STEADY_TIME)
        self.create_timer(POLL_PERIOD_S, poll, clock=steady)
        self.create_timer(HEARTBEAT_PERIOD_S, lambda: self.link.send(self.core.heartbeat()), clock=steady)
        return steady

    def destroy_node(self) -> None:
        self.link.close()
        super().destroy_node()
