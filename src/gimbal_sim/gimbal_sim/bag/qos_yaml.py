"""QoS profiles as rosbag2 writes them (``offered_qos_profiles``, metadata version 9).

Version 9 serialises enums by name (``keep_last``, ``reliable``, ``transient_local``);
the MCAP channel metadata carries the same list as a YAML string.
"""
from __future__ import annotations

from typing import TYPE_CHECKING, Any

import yaml

if TYPE_CHECKING:  # rclpy loads only to build a profile: the engine writes bags without ROS
    from rclpy.qos import QoSProfile

_INFINITE = {"sec": 2147483647, "nsec": 4294967295}


def _duration(d) -> dict[str, int]:
    ns = d.nanoseconds if hasattr(d, "nanoseconds") else 0
    return dict(_INFINITE) if ns == 0 else {"sec": ns // 1_000_000_000, "nsec": ns % 1_000_000_000}


def qos_to_dict(qos: QoSProfile) -> dict[str, Any]:
    """One entry of ``offered_qos_profiles`` (v9) for an rclpy profile."""
    return {
        "history": qos.history.name.lower(),
        "depth": int(qos.depth),
        "reliability": qos.reliability.name.lower(),
        "durability": qos.durability.name.lower(),
        "deadline": _duration(qos.deadline),
        "lifespan": _duration(qos.lifespan),
        "liveliness": qos.liveliness.name.lower(),
        "liveliness_lease_duration": _duration(qos.liveliness_lease_duration),
        "avoid_ros_namespace_conventions": bool(qos.avoid_ros_namespace_conventions),
    }


def qos_yaml(profiles: list[dict[str, Any]]) -> str:
    """The YAML string stored in an MCAP channel's ``offered_qos_profiles``."""
    return yaml.safe_dump(profiles, default_flow_style=False, sort_keys=False).strip() if profiles else ""


def qos_from_dict(entry: dict[str, Any], fallback: QoSProfile) -> QoSProfile:
    """An rclpy profile from a recorded entry; fields it cannot read come from ``fallback``."""
    from rclpy.qos import DurabilityPolicy, HistoryPolicy, LivelinessPolicy, QoSProfile, ReliabilityPolicy

    def policy(enum, key, default):
        value = entry.get(key)
        if isinstance(value, int):
            try:
                return enum(value)
            except ValueError:
                return default
        if isinstance(value, str) and value.upper() in enum.__members__:
            return enum[value.upper()]
        return default

    history = policy(HistoryPolicy, "history", fallback.history)
    if history in (HistoryPolicy.SYSTEM_DEFAULT, HistoryPolicy.UNKNOWN):
        history = fallback.history
    return QoSProfile(
        history=history,
        depth=int(entry.get("depth") or fallback.depth or 1),
        reliability=policy(ReliabilityPolicy, "reliability", fallback.reliability),
        durability=policy(DurabilityPolicy, "durability", fallback.durability),
        liveliness=policy(LivelinessPolicy, "liveliness", fallback.liveliness),
    )
