"""ROS 2 parameter files read as ROS 2 reads them: node blocks, namespaces and wildcards.

A file maps node names to ``{ros__parameters: {...}}`` (rcl_yaml_param_parser). A key may be
a fully qualified name (``/ns/node``), a relative one (``node``, i.e. ``/node``), or a
namespace holding further keys (``/ns: {node: {ros__parameters: ...}}``); nested parameter
mappings are parameter namespaces (``a: {b: 1}`` is ``a.b``). Node names may hold wildcards
as rclcpp and rclpy resolve them: ``*`` is one name token, ``**`` any number of tokens, so
``/**`` is every node. Every matching block applies, in file order, a later value winning.

Scalars are read as rcl reads them (:func:`load_ros_yaml`): YAML 1.1 (PyYAML) takes a
number with an exponent and no dot, or no sign in its exponent (``1e2``, ``1.5e3``), for a
string, where rcl (and so a node started alone) reads a double.
"""
from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Any

import yaml


_TOKEN = re.compile(r"[A-Za-z0-9_]+")


class RosLoader(yaml.SafeLoader):
    """PyYAML's safe loader, with rcl's doubles: ``1e2``, ``1.5e3``, ``-2E-3`` (module docstring)."""


RosLoader.add_implicit_resolver("tag:yaml.org,2002:float",
                                re.compile(r"^[-+]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)[eE][-+]?[0-9]+$"),
                                list("-+0123456789."))


def load_ros_yaml(text: str) -> Any:
    """``text`` parsed as a ROS 2 parameter file or ``-p`` value is (:class:`RosLoader`)."""
    return yaml.load(text, Loader=RosLoader)  # noqa: S506 - a SafeLoader subclass


class ParamsFileError(ValueError):
    """The file is not a ROS 2 parameter file; the message says where."""


@dataclass(frozen=True)
class Block:
    """One ``ros__parameters`` block: the node pattern it addresses (fully qualified, e.g.
    ``/**`` or ``/ns/node``) and its parameters, flattened to dotted names."""

    pattern: str
    params: dict[str, Any]

    @property
    def wildcard(self) -> bool:
        return "*" in self.pattern

    def matches(self, fqn: str) -> bool:
        return pattern_regex(self.pattern).fullmatch(fqn) is not None


def pattern_regex(pattern: str) -> re.Pattern:
    """``/**`` -> any number of ``/token``; ``/*`` -> exactly one; the rest literal (a token is
    a whole wildcard or none: rcl refuses ``gyro_*``)."""
    out = ""
    for token in pattern.strip("/").split("/"):
        if token == "**":
            out += r"(/[^/]+)*"
        else:
            out += "/[^/]+" if token == "*" else "/" + re.escape(token)
    return re.compile(out)


def _flat_params(params: dict, prefix: str = "") -> dict[str, Any]:
    out: dict[str, Any] = {}
    for name, value in params.items():
        key = f"{prefix}{name}"
        if isinstance(value, dict):
            out.update(_flat_params(value, key + "."))
        else:
            out[key] = value
    return out


def blocks(data: Any, where: str, namespace: str = "") -> list[Block]:
    """Every ``ros__parameters`` block of a loaded file, in file order."""
    if not isinstance(data, dict) or not data:
        raise ParamsFileError(f"{where}: expected a ROS 2 parameter file: node: {{ros__parameters: {{...}}}}")
    out = []
    for key, value in data.items():
        name = f"{namespace}/{str(key).strip('/')}"
        if not isinstance(value, dict):
            raise ParamsFileError(f"{where}: {name}: expected a mapping with ros__parameters or nodes of a namespace")
        bad = [t for t in name.strip("/").split("/") if t not in ("*", "**") and not _TOKEN.fullmatch(t)]
        if bad:
            raise ParamsFileError(f"{where}: {name}: a node or namespace name is letters, digits and '_' "
                                  f"(or the wildcards * and **), not {bad[0]!r}")
        if "ros__parameters" in value:
            if set(value) != {"ros__parameters"} or not isinstance(value["ros__parameters"], dict):
                raise ParamsFileError(f"{where}: {name}: a node block holds only a mapping 'ros__parameters'")
            out.append(Block(name, _flat_params(value["ros__parameters"])))
        else:
            out += blocks(value, where, name)
    return out
