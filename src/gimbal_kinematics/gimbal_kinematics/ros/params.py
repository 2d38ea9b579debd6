"""Declare a node's :class:`~gimbal_kinematics.params.table.Param` table with rclpy and read it.

Every parameter is declared in a single ``declare_parameters`` call with a
``ParameterDescriptor`` that carries its description (with units) and its range, so rclpy
itself refuses an out-of-range or wrongly typed value at startup and names the parameter.
Checks a range cannot express (choices, cross-parameter rules) run when the values are
loaded into the core's frozen dataclass (``from_values``), which raises ``ValueError``
naming the parameter.
"""
from __future__ import annotations

import math
from typing import Any, Sequence

from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor
from rclpy.exceptions import (
    InvalidParameterTypeException, InvalidParameterValueException, ParameterUninitializedException,
)
from rclpy.node import Node
from rclpy.parameter import Parameter

from gimbal_kinematics.params.table import Param, ParameterError

_ARRAY_TYPES = {"string_array": Parameter.Type.STRING_ARRAY, "double_array": Parameter.Type.DOUBLE_ARRAY,
                "integer_array": Parameter.Type.INTEGER_ARRAY, "bool_array": Parameter.Type.BOOL_ARRAY}


def declared_value(p: Param) -> Any:
    """What ``declare_parameters`` gets: the default, or the array type of an empty list."""
    return _ARRAY_TYPES[p.array_type] if p.array_type is not None and not p.default else p.default


def descriptor(p: Param) -> ParameterDescriptor:
    desc = ParameterDescriptor(description=p.description)
    if p.choices:
        desc.additional_constraints = "one of: " + ", ".join(p.choices)
    if isinstance(p.default, bool):
        return desc
    if isinstance(p.default, float) and (p.low is not None or p.high is not None):
        desc.floating_point_range = [FloatingPointRange(
            from_value=-math.inf if p.low is None else float(p.low),
            to_value=math.inf if p.high is None else float(p.high), step=0.0)]
    elif isinstance(p.default, int) and (p.low is not None or p.high is not None):
        desc.integer_range = [IntegerRange(
            from_value=-(2**63) if p.low is None else int(p.low),
            to_value=2**63 - 1 if p.high is None else int(p.high), step=1)]
    return desc


def _alias_descriptor(p: Param, alias: str) -> ParameterDescriptor:
    desc = descriptor(p)
    desc.description = f"deprecated alias of {p.name!r}: {p.description}"
    return desc


def declare_and_read(node: Node, params: Sequence[Param]) -> dict[str, Any]:
    """Declare ``params`` in one call and return their values by name.

    A deprecated alias (``Param.aliases``) is declared without a value; when the node is
    given one, its value is the parameter's (the new name's is ignored) and the node logs
    one warning naming the new name. Raises :class:`ParameterError` naming the parameter
    for a value rclpy refuses (range, type) or one outside its choices.
    """
    aliases = [(a, p) for p in params for a in p.aliases]
    try:
        node.declare_parameters("", [(p.name, declared_value(p), descriptor(p)) for p in params])
        node.declare_parameters("", [(a, Parameter.Type.from_parameter_value(p.default), _alias_descriptor(p, a))
                                     for a, p in aliases])
    except (InvalidParameterValueException, InvalidParameterTypeException) as exc:
        raise ParameterError(str(exc)) from exc
    values = {}
    for p in params:
        try:
            values[p.name] = node.get_parameter(p.name).value
        except ParameterUninitializedException:
            values[p.name] = []
    for alias, p in aliases:
        try:
            values[p.name] = node.get_parameter(alias).value
        except ParameterUninitializedException:
            continue
        node.get_logger().warning(f"parameter {alias!r} is deprecated: use {p.name!r} "
                                  f"(taking {alias} = {values[p.name]!r})")
    for p in params:
        if p.choices and values[p.name] not in p.choices:
            raise ParameterError(f"parameter {p.name!r} = {values[p.name]!r} is not one of {list(p.choices)}")
    return values
