"""A node's parameter table, readable without ROS: one :class:`Param` per parameter (name,
default, description with units, range or choices).

The table is the single source of a node's parameters: the node declares it through
:mod:`gimbal_kinematics.ros.params` (rclpy turns the ranges into descriptors and refuses an
out-of-range value at startup), the core loop and the experiments read the same defaults
without rclpy, and the config generator writes ``config/<node>.yaml`` from it.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Sequence

#: Element types of an empty-list default (rcl cannot infer them from ``[]``).
ARRAY_TYPES = ("string_array", "double_array", "integer_array", "bool_array")


@dataclass(frozen=True)
class Param:
    """One parameter: name, default (its type is the parameter's type), description with
    units, and for numbers an inclusive range [low, high]; for strings a set of choices.

    An empty-list default cannot carry its element type, so it needs ``array_type`` (one of
    :data:`ARRAY_TYPES`); unset, such a parameter reads as ``[]``.

    ``aliases``: deprecated names of the same parameter. A node given one uses its value
    and logs one warning naming the new name (:func:`gimbal_kinematics.ros.params.declare_and_read`);
    the config generator writes only :attr:`name`."""

    name: str
    default: Any
    description: str
    low: float | None = None
    high: float | None = None
    choices: tuple[str, ...] = ()
    array_type: str | None = None
    aliases: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        if isinstance(self.default, list) and not self.default and self.array_type is None:
            raise ValueError(f"Param {self.name!r}: an empty-list default needs array_type")
        if self.array_type is not None and self.array_type not in ARRAY_TYPES:
            raise ValueError(f"Param {self.name!r}: array_type must be one of {ARRAY_TYPES}")

    def refusal(self, value: Any) -> str | None:
        """Why the node would refuse ``value`` (already of the parameter's type) at startup:
        outside the range its descriptor carries (a NaN is in no range) or not one of its
        choices; None if it would take it. Cross-parameter rules are checked by the node."""
        if self.choices and isinstance(value, str) and value not in self.choices:
            return f"{value!r} is not one of {list(self.choices)}"
        number = isinstance(value, (int, float)) and not isinstance(value, bool)
        if number and (self.low is not None or self.high is not None):
            low = -math.inf if self.low is None else self.low
            high = math.inf if self.high is None else self.high
            if not low <= value <= high:
                return f"{value!r} is outside [{low:g}, {high:g}]"
        return None


#: Deprecated names of ``clock_jump_s`` (the backward stamp step [s] beyond which a stream's
#: clock counts as jumped back: a bag looping, a restarted driver), aliases for one release.
CLOCK_JUMP_ALIASES = ("reset_backjump_s", "backward_jump_s")

#: The two timings of an estimator or controller node (:mod:`gimbal_kinematics.ros.node_io`).
TIMING_CHOICES = ("free", "lockstep")

#: The ``timing`` entry of every estimator and controller node's parameter table.
TIMING_PARAM = Param(
    "timing", "free",
    "free: step on message stamps, SensorDataQoS inputs (a driver, a bag, ros2 bag play); "
    "lockstep: the orchestrator's deterministic graph (GRAPH_QOS, step grid)",
    choices=TIMING_CHOICES)


#: How a controller sends, and ``vehicle_dynamics`` takes, the joint effort commands: ``graph``,
#: the toolkit's own (``/gimbal/torque_cmd`` or ``/platform/voltage_cmd``, the stamp names the
#: step the command is for), or ``ros2_control``, the contract of ``topic_based_ros2_control``'s
#: TopicBasedSystem (a sensor_msgs/JointState of joint names and efforts on ``ros2_control_topic``,
#: reliable, volatile, keep-last 1; the stamp is the sender's clock, not a step: each command
#: is applied from the plant's next step on).
COMMAND_INTERFACES = ("graph", "ros2_control")
COMMAND_INTERFACE_PARAM = Param(
    "command_interface", "graph",
    "graph: effort commands on the toolkit's command topic, stamped with the step they are for; ros2_control: "
    "topic_based_ros2_control's joint-command contract on ros2_control_topic (docs/hardware.md: ros2_control)",
    choices=COMMAND_INTERFACES)
#: topic_based_ros2_control's default ``joint_commands_topic``.
ROS2_CONTROL_TOPIC_PARAM = Param(
    "ros2_control_topic", "/robot_joint_commands",
    "command_interface ros2_control: the sensor_msgs/JointState effort-command topic (the joint_commands_topic "
    "of topic_based_ros2_control)")

class ParameterError(ValueError):
    """A parameter was refused at startup; the message names it."""


def ros2_control_topic(values: dict[str, Any]) -> str:
    """The ``ros2_control_topic`` of a node whose ``command_interface`` is ros2_control;
    raises :class:`ParameterError` naming it when it names no topic."""
    topic = values["ros2_control_topic"]
    if not isinstance(topic, str) or not topic.strip():
        raise ParameterError(f"parameter 'ros2_control_topic' = {topic!r} must name a topic (command_interface "
                             "ros2_control)")
    return topic


def defaults(params: Sequence[Param]) -> dict[str, Any]:
    """Every parameter's default value by name (what a node reads when nothing is set)."""
    return {p.name: p.default for p in params}


def params_yaml(node_name: str, params: Sequence[Param]) -> str:
    """The node's default ``--params-file`` YAML (``ros__parameters``), descriptions as
    comments. An empty-list parameter is written commented out: rcl cannot type ``[]``."""
    import yaml

    lines = [f"# Default parameters of the {node_name} node (units in the names).",
             f"# Use: ros2 run <package> {node_name} --ros-args --params-file {node_name}.yaml",
             f"{node_name}:", "  ros__parameters:"]
    for p in params:
        value = yaml.safe_dump(p.default, default_flow_style=True, width=1000).strip().removesuffix("\n...")
        lines += [f"    # {p.description}", f"    {'# ' if p.default == [] else ''}{p.name}: {value}"]
    return "\n".join(lines) + "\n"


def steps_per_sample(values: dict[str, Any], rate_name: str, base_name: str = "sim_rate_hz") -> int:
    """Lockstep steps per sample of the rate parameter ``rate_name`` [Hz]; raises
    :class:`ParameterError` naming it unless it divides ``base_name``."""
    ratio = values[base_name] / values[rate_name]
    n = int(round(ratio))
    if n < 1 or abs(ratio - n) > 1e-9 * ratio:
        raise ParameterError(f"parameter {rate_name!r} = {values[rate_name]} Hz does not divide {base_name}")
    return n


def topic_counts(entries: Sequence[str], param: str, topics: Sequence[str] | None = None) -> dict[str, int]:
    """Parse a ``'topic=count'`` string-array parameter into {topic: count}. ``topics``, when
    given, are the only topics allowed; raises :class:`ParameterError` naming ``param``."""
    out: dict[str, int] = {}
    for entry in entries:
        topic, _, count = entry.partition("=")
        topic = topic.strip()
        if not topic.startswith("/") or not count.strip().isdigit() or (topics is not None and topic not in topics):
            allowed = "" if topics is None else f" with topic one of {sorted(topics)}"
            raise ParameterError(f"parameter '{param}': entry {entry!r} is not '/topic=count'{allowed}")
        out[topic] = int(count)
    return out
