"""The parameter reference (docs/parameters.md) says what every node declares: the page is the
generator's output, and each of its rows agrees with what rcl itself holds once the node's
table is declared (value, type, range or choices, description), read back through rclpy's
own parameter services' data, not through our tables."""
from __future__ import annotations

import math
import re

import pytest
import rclpy
import yaml
from rcl_interfaces.msg import ParameterType
from rclpy.context import Context
from rclpy.exceptions import ParameterUninitializedException
from rclpy.node import Node

from gimbal_kinematics.params.table import Param, declaration, param, param_table
from gimbal_kinematics.ros.params import declare_and_read
from gimbal_sim.graph.config_files import DOCS_PATH, parameters_doc
from gimbal_sim.graph.registry import NODE_TYPES

_TYPE_NAMES = {ParameterType.PARAMETER_BOOL: "bool", ParameterType.PARAMETER_INTEGER: "integer",
               ParameterType.PARAMETER_DOUBLE: "double", ParameterType.PARAMETER_STRING: "string",
               ParameterType.PARAMETER_BOOL_ARRAY: "bool_array",
               ParameterType.PARAMETER_INTEGER_ARRAY: "integer_array",
               ParameterType.PARAMETER_DOUBLE_ARRAY: "double_array",
               ParameterType.PARAMETER_STRING_ARRAY: "string_array"}


def _sections(text: str) -> dict[str, list[list[str]]]:
    """Node name -> the cells of each row of its table (markdown, ``\\|`` kept in a cell)."""
    out: dict[str, list[list[str]]] = {}
    node = None
    for line in text.splitlines():
        if line.startswith("## "):
            node = line[3:].strip()
            out[node] = []
        elif node and line.startswith("| `"):
            cells = [c.strip().replace("\\|", "|") for c in re.split(r"(?<!\\)\|", line)[1:-1]]
            out[node].append(cells)
    return out


def _range(descriptor) -> str:
    if descriptor.floating_point_range:
        r = descriptor.floating_point_range[0]
        return f"[{r.from_value:g}, {r.to_value:g}]"
    if descriptor.integer_range:
        r = descriptor.integer_range[0]
        return f"[{r.from_value}, {r.to_value}]"
    if descriptor.additional_constraints:
        return ", ".join(f"`{c}`" for c in descriptor.additional_constraints.removeprefix("one of: ").split(", "))
    return ""


def test_reference_page_is_generated_from_the_declarations():
    assert DOCS_PATH.read_text() == parameters_doc(), "regenerate: python -m gimbal_sim.graph.config_files"


def test_every_row_is_what_the_node_declares_in_rcl(ros_domain_env):
    sections = _sections(DOCS_PATH.read_text())
    assert list(sections) == list(NODE_TYPES)
    context = Context()
    rclpy.init(args=[], context=context, domain_id=int(ros_domain_env["ROS_DOMAIN_ID"]))
    try:
        for node_name, node_type in NODE_TYPES.items():
            node = Node(node_name, context=context, start_parameter_services=False)
            builtin = set(node.list_parameters([], 1).names)  # rclpy's own (use_sim_time, ...)
            declare_and_read(node, node_type.params)
            aliases = {a for p in node_type.params for a in p.aliases}
            declared = [n for n in node.list_parameters([], 1).names if n not in aliases | builtin]
            rows = {cells[0].strip("`"): cells for cells in sections[node_name]}
            assert sorted(rows) == sorted(declared), node_name
            for name, (_, kind, default, unit, limits, text) in rows.items():
                where = f"{node_name}.{name}"
                descriptor = node.describe_parameter(name)
                try:
                    value = node.get_parameter(name).value
                except ParameterUninitializedException:  # an empty list, declared by its type
                    value = None
                assert kind == _TYPE_NAMES[descriptor.type], where
                documented = yaml.safe_load(default.strip("`"))
                assert documented == ([] if value is None else (list(value) if kind.endswith("_array") else value)), where
                assert limits == _range(descriptor), where
                # the descriptor's text is the page's, with the unit appended in brackets
                stem = re.sub(r" \(was `[a-z_]+`\)", "", text)
                assert descriptor.description == stem + (f" [{unit}]" if unit else ""), where
                real = kind in ("double", "double_array") and value not in (None, [])
                assert unit or not real, f"{where}: give the unit"
            node.destroy_node()
    finally:
        rclpy.shutdown(context=context)


def test_a_declaration_field_becomes_its_table_entry():
    from dataclasses import dataclass

    @dataclass(frozen=True)
    class Example:
        """An example node:
        its help text."""

        rate_hz: float = param(100.0, "sample rate", 1e-3, math.inf, unit="Hz")
        names: tuple[str, ...] = param((), "topics", array_type="string_array", aliases=("topics_old",))
        not_a_parameter: int = 3

    rate, names = param_table(Example)
    assert rate == Param("rate_hz", 100.0, "sample rate [Hz]", 1e-3, math.inf, unit="Hz")
    assert rate.text == "sample rate"
    assert names.default == [] and names.array_type == "string_array" and names.aliases == ("topics_old",)
    assert Example().rate_hz == 100.0 and Example().names == ()
    assert declaration(Example) == ((rate, names), "An example node: its help text.")
    with pytest.raises(ValueError, match="array_type"):
        @dataclass(frozen=True)
        class Untyped:
            names: tuple[str, ...] = param((), "topics")
        param_table(Untyped)
    with pytest.raises(ValueError, match="docstring"):
        @dataclass(frozen=True)
        class Undocumented:
            rate_hz: float = param(1.0, "rate", unit="Hz")
        declaration(Undocumented)
