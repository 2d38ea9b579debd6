"""Shared pieces of the reports: decoding a bag into series, and plotting."""
from __future__ import annotations

import math
from collections import defaultdict
from pathlib import Path

import numpy as np
import yaml

from gimbal_kinematics.maths.earth import earth_rate_n
from gimbal_kinematics.ros.cdr import CdrError
from gimbal_kinematics.ros.views import VIEWS

from ..bag.reader import BagContents, read_messages
from ..bag.schemas import message_class
from ..figures import save_stacked, stacked, style


#: Types decoded by struct (:mod:`gimbal_kinematics.ros.views`) into read-only views with
#: the same field names: twenty times faster than message objects on the 1 kHz topics.
_VIEWS = VIEWS


def load_series(bag_dir: Path, topics: set[str] | None = None) -> tuple[dict[str, list], BagContents]:
    """Messages by topic (each a list of (t [s], message)), and the bag summary. Imu,
    Vector3Stamped and JointState come as views (same field names, tuples for arrays);
    anything else, or a message the fast decoder does not recognise, as a message object."""
    from rclpy.serialization import deserialize_message

    raw, contents = read_messages(bag_dir, topics)
    series: dict[str, list] = defaultdict(list)
    classes: dict[str, type] = {}

    def decode(type_name: str, data: bytes):
        view = _VIEWS.get(type_name)
        if view is not None:
            try:
                return view(data)
            except CdrError:
                pass
        cls = classes.get(type_name) or classes.setdefault(type_name, message_class(type_name))
        return deserialize_message(data, cls)

    for msg in raw:
        series[msg.topic].append((msg.log_time_ns * 1e-9, decode(msg.type_name, msg.data)))
    return series, contents


def quat_to_los(q) -> tuple[float, float]:
    x, y, z, w = q.x, q.y, q.z, q.w
    lx, ly, lz = 1 - 2 * (y * y + z * z), 2 * (x * y + z * w), 2 * (x * z - y * w)
    return math.atan2(ly, lx), math.atan2(-lz, math.hypot(lx, ly))


def plot(path: Path, title: str, t: np.ndarray, curves: dict[str, np.ndarray], ylabel: str) -> None:
    """One panel of ``curves`` {label: (N,)} over sim time ``t`` (N,) [s]."""
    fig, axes = stacked(1, 4.5)
    for label, y in curves.items():
        axes[0, 0].plot(t, y, label=label, linewidth=1.0)
    style(axes[0, 0], ylabel)
    save_stacked(fig, axes, path, title)


def times(samples: list) -> np.ndarray:
    """Log times [s] of a topic's (t, message) list, shape (N,)."""
    return np.array([t for t, _ in samples])


def vectors(samples: list) -> np.ndarray:
    """The Vector3Stamped payloads of a topic's (t, message) list, shape (N, 3)."""
    return np.array([[m.vector.x, m.vector.y, m.vector.z] for _, m in samples]).reshape(-1, 3)


def vehicle_site(bag_dir: Path) -> tuple[float, bool]:
    """(latitude [rad], earth rate on) of the run, from its scenario.yaml (defaults if absent)."""
    scenario_file = bag_dir / "scenario.yaml"
    params = {}
    if scenario_file.is_file():
        nodes = yaml.safe_load(scenario_file.read_text()).get("nodes", {})
        params = next((n.get("params", {}) for n in nodes.values() if n.get("executable") == "vehicle_dynamics"), {})
    profile_params = yaml.safe_load(params.get("profile_params", "{}")) or {}
    return math.radians(float(profile_params.get("lat_deg", 0.0))), bool(params.get("earth_rate", True))


def site_rate_n(lat: float, earth_rate: bool) -> np.ndarray:
    """ω_in^n [rad/s] (3,) of a fixed site at latitude ``lat`` [rad]: the earth rate, or zero
    when the run's NED is inertial (``earth_rate: false``); for
    :func:`gimbal_kinematics.maths.los.inertial_los`."""
    return earth_rate_n(lat) if earth_rate else np.zeros(3)
