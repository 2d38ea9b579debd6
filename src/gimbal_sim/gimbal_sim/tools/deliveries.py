"""Messages delivered to subscribers per lockstep step, measured on a short processes-mode run
(``gimbal-bench``'s deliveries row): what the graph's DDS traffic costs per step, beside the
messages the bag records."""
from __future__ import annotations

import dataclasses
import os
import threading
from pathlib import Path

from gimbal_kinematics.ros.ros_domain import claim_domain_id

from ..bag.reader import read_messages
from ..graph.orchestrator import run
from ..graph.scenario import Scenario

#: steps of the deliveries run (lockstep publishes the same messages every step pattern)
DELIVERY_STEPS = 200


def measure_deliveries(scenario: Scenario, out: Path) -> tuple[float, dict[str, tuple[int, int]]]:
    """Messages delivered to subscribers per step, measured: a processes-mode run of
    :data:`DELIVERY_STEPS` steps recording every topic (so each publication is counted),
    while a probe node samples each topic's matched subscriptions; a delivery is one message
    to one subscription, the recorder's own left out on topics the scenario does not record.
    The probe joins the run's own ROS domain (claimed here when none is set, as the
    orchestrator would): in another domain it would see no subscriptions at all.
    Returns (deliveries per step, topic -> (messages, subscriptions))."""
    short = dataclasses.replace(scenario, duration_s=DELIVERY_STEPS / scenario.sim_rate_hz, record="all")
    claim = None
    if not os.environ.get("ROS_DOMAIN_ID"):
        claim = claim_domain_id()
        os.environ["ROS_DOMAIN_ID"] = str(claim.domain_id)
    try:
        subs = _probe_run(short, out)
    finally:
        if claim is not None:
            os.environ.pop("ROS_DOMAIN_ID", None)
            claim.release()
    counts: dict[str, int] = {}
    for msg in read_messages(out)[0]:
        counts[msg.topic] = counts.get(msg.topic, 0) + 1
    recorded = set(scenario.record) if scenario.record != "all" else set(counts)
    table = {t: (n, max(0, subs.get(t, 0) - (0 if t in recorded else 1))) for t, n in sorted(counts.items())}
    return sum(n * k for n, k in table.values()) / DELIVERY_STEPS, table


def _probe_run(short: Scenario, out: Path) -> dict[str, int]:
    """Run ``short`` (processes mode) while a probe node in the run's domain samples each
    topic's matched subscriptions every 0.1 s; topic -> the most seen."""
    import rclpy
    from rclpy.context import Context

    ctx = Context()
    rclpy.init(context=ctx, domain_id=int(os.environ["ROS_DOMAIN_ID"]))
    probe = rclpy.create_node("gimbal_bench_probe", context=ctx)
    subs: dict[str, int] = {}
    stop = threading.Event()

    def sample() -> None:
        while not stop.wait(0.1):
            for topic, _ in probe.get_topic_names_and_types():
                subs[topic] = max(subs.get(topic, 0), probe.count_subscribers(topic))
    thread = threading.Thread(target=sample, daemon=True)
    thread.start()
    try:
        run(short, out, "processes", progress=False)
    finally:
        stop.set()
        thread.join()
        probe.destroy_node()
        rclpy.shutdown(context=ctx)
    return subs


def deliveries_row(scenario: Scenario, out: Path) -> tuple[str, str]:
    """The report's row of :func:`measure_deliveries`: per step, and per topic rate x subscriptions."""
    per_step, table = measure_deliveries(scenario, out)
    return ("messages delivered per step", f"{per_step:.2f} (every topic's messages x its matched subscriptions, "
            f"measured over {DELIVERY_STEPS} steps: " + ", ".join(
                f"{t} {n / DELIVERY_STEPS:.2f}x{k}" for t, (n, k) in table.items() if n and k) + ")")
