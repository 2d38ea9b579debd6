"""Readiness for pacing: a node reports "next step needed: 0" on its progress topic once
the graph around it is connected, so no sample and no output is lost to discovery."""
from __future__ import annotations

from typing import Iterable

from rclpy.clock import Clock, ClockType
from rclpy.node import Node
from rclpy.publisher import Publisher
from rclpy.qos import DurabilityPolicy
from rclpy.subscription import Subscription

from . import messages as m


def announce_when_connected(node: Node, progress: Publisher, inputs: Iterable[Subscription] = (),
                            outputs: Iterable[Publisher] = (), readers: int = 1, period_s: float = 0.02,
                            counts: dict[str, int] | None = None) -> None:
    """Every ``period_s`` [s] (a wall-clock timer: this waits for discovery, not for steps),
    check that each of ``inputs`` has a publisher and each of ``outputs`` ``readers``
    subscriptions (``counts``: per topic name, overriding ``readers``); then publish step 0
    ("ready") on ``progress``. The timer runs on the steady clock, so it fires with
    ``use_sim_time`` before any /clock.

    A transient-local ``progress`` (lockstep) says it once and stops checking: a reader that
    subscribes later still gets it. A volatile one (free timing) would lose a "ready" sent
    before the pacing reader's subscription matched, and a player that starts before the
    node's inputs have matched its publishers loses its first samples (a best-effort reader
    drops what comes from a writer it has not matched yet) and waits for a report that never
    comes. So in free timing "ready" waits until ``progress`` has a matched reader too (a
    reliable writer then delivers it, even to a reader that matches this writer a moment
    later), and is said again each time the number of matched progress readers rises: a
    second replay into the same node gets its own "ready".
    """
    inputs = tuple(inputs)
    outputs = tuple((p, (counts or {}).get(p.topic_name, readers)) for p in outputs)
    volatile = progress.qos_profile.durability == DurabilityPolicy.VOLATILE
    told = 0  # volatile: matched progress readers when "ready" was last said
    timer = None

    def connected() -> bool:
        return all(s.get_publisher_count() >= 1 for s in inputs) and \
            all(p.get_subscription_count() >= n for p, n in outputs)

    def check() -> None:
        nonlocal told
        if not volatile:
            if connected():
                timer.cancel()
                node.destroy_timer(timer)
                progress.publish(m.clock_msg(0))
            return
        pacers = progress.get_subscription_count()
        if pacers < told:
            told = pacers  # a reader left: the next one to match has not been told
        elif pacers > told and connected():
            told = pacers
            progress.publish(m.clock_msg(0))

    timer = node.create_timer(period_s, check, clock=Clock(clock_type=ClockType.STEADY_TIME))
