"""Message types and their ``ros2msg`` schema text, built from the installed ``.msg`` files.

The MCAP ``ros2`` profile stores a type's full definition: its own ``.msg`` text, then each
type it depends on (depth first, each once) after a line of 80 ``=`` and ``MSG: pkg/Type``,
the layout rosbag2 writes and every ros2msg parser reads.
"""
from __future__ import annotations

import importlib
import re
import sys
from functools import lru_cache
from pathlib import Path

PRIMITIVES = frozenset({
    "bool", "byte", "char", "float32", "float64", "int8", "uint8", "int16", "uint16", "int32", "uint32",
    "int64", "uint64", "string", "wstring",
})
SEPARATOR = "=" * 80
_FIELD = re.compile(r"^\s*([A-Za-z][\w/]*)(\[[^\]]*\])?(<=\d+)?\s+\w+")


def split_type(type_name: str) -> tuple[str, str]:
    """('sensor_msgs', 'Imu') from 'sensor_msgs/msg/Imu' or 'sensor_msgs/Imu'."""
    parts = type_name.split("/")
    if len(parts) == 3 and parts[1] == "msg":
        return parts[0], parts[2]
    if len(parts) == 2:
        return parts[0], parts[1]
    raise ValueError(f"not a message type name: {type_name!r}")


def message_class(type_name: str) -> type:
    """The Python class of a ROS message type ('sensor_msgs/msg/Imu')."""
    pkg, name = split_type(type_name)
    try:
        return getattr(importlib.import_module(f"{pkg}.msg"), name)
    except (ImportError, AttributeError) as exc:
        raise ValueError(f"message type {type_name!r} is not installed") from exc


def _share_dir(pkg: str) -> Path:
    try:
        from ament_index_python.packages import PackageNotFoundError, get_package_share_directory

        try:
            return Path(get_package_share_directory(pkg))
        except (PackageNotFoundError, OSError):  # OSError: no AMENT_PREFIX_PATH at all
            pass
    except ImportError:
        pass
    # ROS from PyPI wheels: share/ sits under the environment's prefix.
    return Path(sys.prefix) / "share" / pkg


@lru_cache(maxsize=None)
def msg_text(pkg: str, name: str) -> str:
    path = _share_dir(pkg) / "msg" / f"{name}.msg"
    if not path.is_file():
        raise ValueError(f"no message definition {pkg}/{name} at {path}")
    return path.read_text()


def _dependencies(pkg: str, text: str) -> list[tuple[str, str]]:
    """(package, type) of every non-primitive field type, in order of appearance."""
    deps = []
    for line in text.splitlines():
        line = line.split("#", 1)[0]
        match = _FIELD.match(line)
        if not match or match.group(1) in PRIMITIVES:
            continue
        base = match.group(1)
        if "/" in base:
            dep = (base.split("/")[0], base.split("/")[-1])
        else:  # a type of the same package; 'Header' is the historical std_msgs alias
            dep = ("std_msgs", "Header") if base == "Header" else (pkg, base)
        if dep not in deps:
            deps.append(dep)
    return deps


@lru_cache(maxsize=None)
def ros2msg_schema(type_name: str) -> str:
    """Full ``ros2msg`` definition of ``type_name`` with its dependencies appended."""
    pkg, name = split_type(type_name)
    root = msg_text(pkg, name)
    seen: list[tuple[str, str]] = []

    def visit(p: str, n: str) -> None:
        for dep in _dependencies(p, msg_text(p, n)):
            if dep not in seen:
                seen.append(dep)
                visit(*dep)

    visit(pkg, name)
    parts = [root.rstrip("\n")]
    for dep_pkg, dep_name in seen:
        parts += [SEPARATOR, f"MSG: {dep_pkg}/{dep_name}", msg_text(dep_pkg, dep_name).rstrip("\n")]
    return "\n".join(parts) + "\n"
