"""A node's parameters, readable without ROS, declared once: a frozen dataclass whose fields
are made with :func:`param` (default, description, unit, range or choices, ...).

That declaration generates everything else: :func:`param_table` turns it into the node's
table of :class:`Param` entries, which the node declares through
:mod:`gimbal_kinematics.ros.params` (rclpy turns the ranges into descriptors and refuses an
out-of-range value at startup); the core loop and the experiments read the same defaults
without rclpy; :func:`params_yaml` writes ``config/<node>.yaml`` and :func:`params_markdown`
the node's section of ``docs/parameters.md`` from it. :func:`declaration` gives a node's table
and its --help text (the declaration's docstring). Parameters several nodes declare alike are
declared once in :class:`SharedParams` (taken with :func:`same_as`), and the leading ones of the
estimators and controllers by inheriting :class:`TimedParams` or :class:`CommandingParams`.
"""
from __future__ import annotations

import dataclasses
import inspect
import math
from dataclasses import dataclass
from typing import Any, Mapping, Sequence, TypeVar

#: Element types of an empty-list default (rcl cannot infer them from ``[]``).
ARRAY_TYPES = ("string_array", "double_array", "integer_array", "bool_array")

T = TypeVar("T")

#: The metadata key of a :func:`param` field.
_SPEC = "gimbal_param"


@dataclass(frozen=True)
class Param:
    """One parameter: name, default (its type is the parameter's type), description (ending
    in its unit in brackets when it has one), and for numbers an inclusive range [low, high];
    for strings a set of choices. Made by :func:`param_table` from a :func:`param` field.

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
    unit: str = ""

    def __post_init__(self) -> None:
        if isinstance(self.default, list) and not self.default and self.array_type is None:
            raise ValueError(f"Param {self.name!r}: an empty-list default needs array_type")
        if self.array_type is not None and self.array_type not in ARRAY_TYPES:
            raise ValueError(f"Param {self.name!r}: array_type must be one of {ARRAY_TYPES}")

    @property
    def text(self) -> str:
        """The description without its unit."""
        return self.description.removesuffix(f" [{self.unit}]") if self.unit else self.description

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


def param(default: Any, description: str, low: float | None = None, high: float | None = None, *,
          unit: str = "", choices: Sequence[str] = (), array_type: str | None = None,
          aliases: Sequence[str] = ()) -> Any:
    """A dataclass field that declares one node parameter: its ``default`` (a sequence is
    kept as a tuple in the dataclass and declared as a list), ``description`` (without the
    unit), ``unit`` (``"-"``: dimensionless), the inclusive range ``low``..``high`` of a
    number, the ``choices`` of a string, the ``array_type`` of an empty list (one of
    :data:`ARRAY_TYPES`) and deprecated ``aliases`` (:class:`Param`)."""
    if isinstance(default, list):
        default = tuple(default)
    spec = {"description": description, "unit": unit, "low": low, "high": high, "choices": tuple(choices),
            "array_type": array_type, "aliases": tuple(aliases)}
    return dataclasses.field(default=default, metadata={_SPEC: spec})


def field_param(f: dataclasses.Field) -> Param:
    """The :class:`Param` a :func:`param` field declares."""
    spec = f.metadata[_SPEC]
    default = list(f.default) if isinstance(f.default, tuple) else f.default
    description = spec["description"] + (f" [{spec['unit']}]" if spec["unit"] else "")
    return Param(f.name, default, description, spec["low"], spec["high"], spec["choices"], spec["array_type"],
                 spec["aliases"], spec["unit"])


def param_table(*declarations: type) -> tuple[Param, ...]:
    """The parameter table of one or more declarations (dataclasses), in field order. A
    field made without :func:`param` declares no parameter (a core's derived field)."""
    return tuple(field_param(f) for cls in declarations for f in dataclasses.fields(cls) if _SPEC in f.metadata)


def from_values(declaration: type[T], values: Mapping[str, Any]) -> T:
    """The ``declaration`` dataclass built from a node's values (name -> value, a superset of
    its fields); a ValueError of its checks becomes a :class:`ParameterError` naming the
    parameter."""
    try:
        return declaration(**{f.name: values[f.name] for f in dataclasses.fields(declaration) if f.init})
    except ValueError as exc:
        raise ParameterError(f"parameter {exc}") from exc


def same_as(shared: Param) -> Any:
    """A field that declares ``shared`` again (a parameter several nodes share), with the same
    default, description, unit, range and aliases."""
    return param(shared.default, shared.text, shared.low, shared.high, unit=shared.unit, choices=shared.choices,
                 array_type=shared.array_type, aliases=shared.aliases)


#: Deprecated names of ``clock_jump_s`` (the backward stamp step [s] beyond which a stream's
#: clock counts as jumped back: a bag looping, a restarted driver), aliases for one release.
CLOCK_JUMP_ALIASES = ("reset_backjump_s", "backward_jump_s")

#: The two timings of an estimator or controller node (:mod:`gimbal_kinematics.ros.node_io`).
TIMING_CHOICES = ("free", "lockstep")

#: How a controller sends, and ``vehicle_dynamics`` takes, the joint effort commands: ``graph``,
#: the toolkit's own (``/gimbal/torque_cmd`` or ``/platform/voltage_cmd``, the stamp names the
#: step the command is for), or ``ros2_control``, the contract of ``topic_based_ros2_control``'s
#: TopicBasedSystem (a sensor_msgs/JointState of joint names and efforts on ``ros2_control_topic``,
#: reliable, volatile, keep-last 1; the stamp is the sender's clock, not a step: each command
#: is applied from the plant's next step on).
COMMAND_INTERFACES = ("graph", "ros2_control")


@dataclass(frozen=True)
class SharedParams:
    """Parameters several nodes declare alike; a node's declaration takes one with
    ``name: type = same_as(SHARED["name"])``."""

    timing: str = param("free", "free: step on message stamps, SensorDataQoS inputs (a driver, a bag, ros2 bag "
                        "play); lockstep: the orchestrator's deterministic graph (GRAPH_QOS, step grid)",
                        choices=TIMING_CHOICES)
    command_interface: str = param(
        "graph", "graph: effort commands on the toolkit's command topic, stamped with the step they are for; "
        "ros2_control: topic_based_ros2_control's joint-command contract on ros2_control_topic (docs/hardware.md: "
        "ros2_control)", choices=COMMAND_INTERFACES)
    #: topic_based_ros2_control's default ``joint_commands_topic``.
    ros2_control_topic: str = param(
        "/robot_joint_commands", "command_interface ros2_control: the sensor_msgs/JointState effort-command topic "
        "(the joint_commands_topic of topic_based_ros2_control)")
    progress_every_steps: int = param(10, "report on ~/progress (time of the next step needed) every N steps; "
                                      "vehicle_dynamics waits for and paces on it", 1, 10**6)
    wait_for_subscribers: int = param(0, "matched subscriptions each output needs before ~/progress reports ready",
                                      0, 1000)
    diagnostics_period_s: float = param(1.0, "free timing: /diagnostics with the counters every this much stamp "
                                        "time", 1e-3, 3600.0, unit="s")


#: :class:`SharedParams` by name.
SHARED = {p.name: p for p in param_table(SharedParams)}
#: The ``timing`` entry of every estimator and controller node's parameter table.
TIMING_PARAM = SHARED["timing"]
COMMAND_INTERFACE_PARAM = SHARED["command_interface"]
ROS2_CONTROL_TOPIC_PARAM = SHARED["ros2_control_topic"]


@dataclass(frozen=True)
class TimedParams:
    """The first parameter of every estimator and controller node: its ``timing``."""

    timing: str = same_as(TIMING_PARAM)


@dataclass(frozen=True)
class CommandingParams(TimedParams):
    """A controller's first parameters: its ``timing`` and how it sends its effort commands."""

    command_interface: str = same_as(COMMAND_INTERFACE_PARAM)
    ros2_control_topic: str = same_as(ROS2_CONTROL_TOPIC_PARAM)


def declaration(*declarations: type) -> tuple[tuple[Param, ...], str]:
    """A node's parameter table (:func:`param_table` of ``declarations``, in order) and its
    ``--help`` text: the first declaration's docstring, on one line."""
    doc = declarations[0].__doc__ or ""
    if not doc.strip() or doc.startswith(f"{declarations[0].__name__}("):  # dataclass' own stand-in
        raise ValueError(f"{declarations[0].__name__} needs a docstring: the node's --help text")
    return param_table(*declarations), " ".join(inspect.cleandoc(doc).split())


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


def _cell(value: Any) -> str:
    import yaml

    text = yaml.safe_dump(value, default_flow_style=True, width=1000).strip().removesuffix("\n...")
    return "`" + text.replace("|", "\\|") + "`"


def _bound(value: float) -> str:
    return str(value) if isinstance(value, int) else f"{value:g}"


def _limits(p: Param) -> str:
    if p.choices:
        return ", ".join(f"`{c}`" for c in p.choices)
    if p.low is None and p.high is None:
        return ""
    return f"[{_bound(-math.inf if p.low is None else p.low)}, {_bound(math.inf if p.high is None else p.high)}]"


#: ROS 2 parameter type names (``ros2 param describe``) by Python type.
_ROS_TYPES = {bool: "bool", int: "integer", float: "double", str: "string"}


def params_markdown(node_name: str, package: str, summary: str, params: Sequence[Param]) -> str:
    """The node's section of the parameter reference (``docs/parameters.md``): its summary
    and one table row per parameter (name, type, default, unit, range or choices, description,
    deprecated aliases)."""
    lines = [f"## {node_name}", "", f"`ros2 run {package} {node_name}`: {summary}", "",
             "| parameter | type | default | unit | range / choices | description |",
             "| --- | --- | --- | --- | --- | --- |"]
    for p in params:
        kind = p.array_type or (f"{_ROS_TYPES[type(p.default[0])]}_array" if isinstance(p.default, list)
                                else _ROS_TYPES[type(p.default)])
        text = p.text.replace("|", "\\|") + "".join(f" (was `{a}`)" for a in p.aliases)
        lines.append(f"| `{p.name}` | {kind} | {_cell(p.default)} | {p.unit} | {_limits(p)} | {text} |")
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
