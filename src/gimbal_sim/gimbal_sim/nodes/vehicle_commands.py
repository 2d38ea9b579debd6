"""What ``vehicle_dynamics`` takes as a step's command, and when it may step (pure Python, no
rclpy): the command contracts of :mod:`.vehicle_dynamics_node`, its start-up handshake and
its pacing against the readers' ``~/progress``. The node decodes the messages, keeps the
clock and publishes.

Contracts (the node's module docstring says which applies when):

* lockstep, the graph's own topic: the command stamped for the step at hand, anything else
  refused and counted (``rejected``);
* realtime: the newest command is held; one stamped for an earlier step than the one at hand
  is late, still taken for the next step (the node counts late steps);
* ros2_control: a command is for the next step, whatever its stamp; in lockstep one per step,
  queued in arrival order; a bad one holds the last good command for its step.
"""
from __future__ import annotations

import math
from collections import deque
from typing import Any, Callable, Mapping, Sequence

from gimbal_kinematics.maths.frames import GIMBAL_COMMAND_JOINTS, PLATFORM_JOINTS
from gimbal_kinematics.params.table import topic_counts
from gimbal_kinematics.ros import messages as m

#: the command joints of each plant, in plant order (the host alone takes none)
COMMAND_JOINTS = {"two_axis_gimbal": GIMBAL_COMMAND_JOINTS, "four_gimbal_platform": PLATFORM_JOINTS}


class CommandInbox:
    """The command of each step (module docstring). ``names``: the plant's command joints in
    plant order; ``warn(text)`` hears of each command refused (the node throttles it)."""

    def __init__(self, names: Sequence[str], size: int, sim_rate_hz: float, realtime: bool,
                 warn: Callable[[str], None]) -> None:
        self.names = tuple(names)
        self.sim_rate_hz = sim_rate_hz
        self.realtime = realtime
        self.warn = warn
        self.command: tuple[float, ...] = (0.0,) * size
        self.command_k: int | None = None  # the step of the newest command taken
        self.rejected = 0  # NaN/inf, wrong size or names, stale or future stamps, malformed
        self.late = 0  # realtime: steps taken with a held command (none for the step yet)
        self._queued: deque[tuple[float, ...] | None] = deque()  # ros2_control in lockstep

    def refuse(self, text: str) -> None:
        self.rejected += 1
        self.warn(f"{text} ({self.rejected} rejected)")

    def on_command(self, msg: m.JointStateData, started: bool, k_now: int) -> bool:
        """The graph's command topic; True when it is the lockstep step's command (step now)."""
        k = m.step_of_stamp(msg.stamp_ns, self.sim_rate_hz)
        if self.realtime and started and k < k_now and (self.command_k is None or k > self.command_k):
            # late: the newest command is held for the next step (still counted late there)
            values = self.values(msg)
            if values is not None:
                self.command, self.command_k = values, k
            return False
        if not started or k != k_now:
            self.refuse(f"command stamped for step {k} while at step {k_now}: ignored")
            return False
        self.command_k = k
        values = self.values(msg)
        if values is not None:
            self.command = values
        return not self.realtime

    def on_ros2_control(self, msg: m.JointStateData, started: bool, k_now: int) -> bool:
        """A command in ros2_control's contract; True when a lockstep step may now be taken."""
        if not started:
            self.refuse("command before step 0: ignored")
            return False
        values = self.values(msg)
        if self.realtime:
            if values is not None:
                self.command = values
            self.command_k = k_now
            return False
        self._queued.append(values)
        return True

    def count_late(self, k_now: int) -> None:
        """A realtime step ``k_now`` about to be taken: late when its command is not in."""
        if self.command_k != k_now:
            self.late += 1

    def take(self, k_now: int, ros2_control: bool) -> bool:
        """Whether lockstep step ``k_now``'s command is in (a queued ros2_control one taken)."""
        if not ros2_control:
            return self.command_k == k_now
        if not self._queued:
            return False
        values = self._queued.popleft()
        if values is not None:
            self.command = values
        return True

    def values(self, msg: m.JointStateData) -> tuple[float, ...] | None:
        """The command in plant order, or None (counted, warned) if it must not be used."""
        effort = list(msg.effort)
        if msg.name:
            if set(msg.name) != set(self.names) or len(msg.name) != len(effort):
                problem = f"joint names {list(msg.name)} != {list(self.names)}"
            else:
                order = {name: i for i, name in enumerate(msg.name)}
                effort = [effort[order[name]] for name in self.names]
                problem = ""
        else:
            problem = "" if len(effort) == len(self.names) else f"{len(effort)} efforts"
        if not problem and not all(math.isfinite(v) for v in effort):
            problem = f"non-finite effort {effort}"
        if problem:
            self.refuse(f"bad command ({problem}): holding the last good one")
            return None
        return tuple(effort)


class ReaderPace:
    """The readers that pace the vehicle (``pace_topics``): the next step each still needs,
    from its ``~/progress``; step k+1 waits while it would be ``window`` steps ahead of one."""

    def __init__(self, topics: Sequence[str], window: int) -> None:
        self.next_needed: dict[str, int | None] = dict.fromkeys(topics)
        self.window = window

    def heard(self, topic: str, step: int) -> None:
        self.next_needed[topic] = max(step, self.next_needed[topic] or 0)

    @property
    def ready(self) -> bool:
        """Every reader has reported once (the start-up handshake)."""
        return all(step is not None for step in self.next_needed.values())

    def holds(self, k: int) -> bool:
        """True when publishing step k+1 would put it a window ahead of a reader."""
        needed = self.next_needed.values()
        return bool(needed) and min(needed) + self.window <= k + 1  # type: ignore[type-var]


class StartGate:
    """The start-up handshake (step 0 waits for it): every truth publisher matched by its
    readers (``wait_for_subscribers`` each, or ``subscriber_counts`` entries), the graph
    showing ``topic_subscriber_counts`` (free-timing readers announce no readiness), a
    controlled vehicle's command publisher, and every pacing reader's first progress.
    Publishers and the command subscription are rclpy's (duck-typed here)."""

    def __init__(self, pubs: Mapping[str, Any], values: Mapping[str, Any], count_subscribers: Callable[[str], int],
                 command_sub: Any, pace: ReaderPace) -> None:
        self.needed = {p: values["wait_for_subscribers"] for p in pubs.values()}
        for topic, count in topic_counts(values["subscriber_counts"], "subscriber_counts", list(pubs)).items():
            self.needed[pubs[topic]] = count
        self.graph_needed = topic_counts(values["topic_subscriber_counts"], "topic_subscriber_counts")
        self.count_subscribers, self.command_sub, self.pace = count_subscribers, command_sub, pace

    def open(self) -> bool:
        if any(p.get_subscription_count() < n for p, n in self.needed.items()):
            return False
        if any(self.count_subscribers(t) < n for t, n in self.graph_needed.items()):
            return False
        if self.command_sub is not None and self.command_sub.get_publisher_count() < 1:
            return False
        return self.pace.ready
