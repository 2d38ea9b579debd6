"""Declare a node's parameters from one table and load them for its pure-Python core.

Every parameter is declared in a single ``declare_parameters`` call with a
``ParameterDescriptor`` that carries its description (with units) and its range, so rclpy
itself refuses an out-of-range or wrongly typed value at startup and names the parameter.
Checks a range cannot express (choices, cross-parameter rules) run when the values are
loaded into the core's frozen dataclass, which raises ``ValueError`` naming the parameter.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Sequence

from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor
from rclpy.exceptions import (
    InvalidParameterTypeException, InvalidParameterValueException, ParameterUninitializedException,
)
from rclpy.node import Node
from rclpy.parameter import Parameter


@dataclass(frozen=True)
class Param:
    """One parameter: name, default (its type is the parameter's type), description with
    units, and for numbers an inclusive range [low, high]; for strings a set of choices.

    An empty-list default cannot carry its element type, so it needs ``array_type``
    (e.g. ``Parameter.Type.STRING_ARRAY``); unset, such a parameter reads as ``[]``."""

    name: str
    default: Any
    description: str
    low: float | None = None
    high: float | None = None
    choices: tuple[str, ...] = ()
    array_type: Parameter.Type | None = None

    def __post_init__(self) -> None:
        if isinstance(self.default, list) and not self.default and self.array_type is None:
            raise ValueError(f"Param {self.name!r}: an empty-list default needs array_type")

    def declared_value(self) -> Any:
        return self.array_type if self.array_type is not None and not self.default else self.default

    def descriptor(self) -> ParameterDescriptor:
        desc = ParameterDescriptor(description=self.description)
        if self.choices:
            desc.additional_constraints = "one of: " + ", ".join(self.choices)
        if isinstance(self.default, bool):
            return desc
        if isinstance(self.default, float) and (self.low is not None or self.high is not None):
            desc.floating_point_range = [FloatingPointRange(
                from_value=-math.inf if self.low is None else float(self.low),
                to_value=math.inf if self.high is None else float(self.high), step=0.0)]
        elif isinstance(self.default, int) and (self.low is not None or self.high is not None):
            desc.integer_range = [IntegerRange(
                from_value=-(2**63) if self.low is None else int(self.low),
                to_value=2**63 - 1 if self.high is None else int(self.high), step=1)]
        return desc


class ParameterError(ValueError):
    """A parameter was refused at startup; the message names it."""


def declare_and_read(node: Node, params: Sequence[Param]) -> dict[str, Any]:
    """Declare ``params`` in one call and return their values by name.

    Raises :class:`ParameterError` naming the parameter for a value rclpy refuses (range,
    type) or one outside its choices.
    """
    try:
        node.declare_parameters("", [(p.name, p.declared_value(), p.descriptor()) for p in params])
    except (InvalidParameterValueException, InvalidParameterTypeException) as exc:
        raise ParameterError(str(exc)) from exc
    values = {}
    for p in params:
        try:
            values[p.name] = node.get_parameter(p.name).value
        except ParameterUninitializedException:
            values[p.name] = []
    for p in params:
        if p.choices and values[p.name] not in p.choices:
            raise ParameterError(f"parameter {p.name!r} = {values[p.name]!r} is not one of {list(p.choices)}")
    return values


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
