"""Readiness for pacing: a node reports "next step needed: 0" on its progress topic once
the graph around it is connected, so no sample and no output is lost to discovery."""
from __future__ import annotations

from typing import Iterable

from rclpy.clock import Clock, ClockType
from rclpy.node import Node
from rclpy.publisher import Publisher
from rclpy.subscription import Subscription

from . import messages as m


def announce_when_connected(node: Node, progress: Publisher, inputs: Iterable[Subscription] = (),
                            outputs: Iterable[Publisher] = (), readers: int = 1, period_s: float = 0.02,
                            counts: dict[str, int] | None = None) -> None:
    """Every ``period_s`` [s] (a wall-clock timer: this waits for discovery, not for steps),
    check that each of ``inputs`` has a publisher and each of ``outputs`` ``readers``
    subscriptions (``counts``: per topic name, overriding ``readers``); then publish step 0 on
    ``progress`` once and stop checking. The timer
    runs on the steady clock, so it fires with ``use_sim_time`` before any /clock."""
    inputs = tuple(inputs)
    outputs = tuple((p, (counts or {}).get(p.topic_name, readers)) for p in outputs)
    timer = None

    def check() -> None:
        if any(s.get_publisher_count() < 1 for s in inputs):
            return
        if any(p.get_subscription_count() < n for p, n in outputs):
            return
        timer.cancel()
        node.destroy_timer(timer)
        progress.publish(m.clock_msg(0))

    timer = node.create_timer(period_s, check, clock=Clock(clock_type=ClockType.STEADY_TIME))
