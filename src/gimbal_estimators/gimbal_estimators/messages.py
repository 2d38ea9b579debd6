"""Message conversion for gimbal_estimators (the package's one module that reads or builds
ROS messages). Stamps map to lockstep steps as in :mod:`gimbal_sim.messages`."""
from __future__ import annotations

from typing import Sequence

from sensor_msgs.msg import JointState

from gimbal_sim.messages import (  # noqa: F401
    NAV_FRAME, clock_msg, stamp_ns, step_of_stamp, step_stamp_ns, vec_of, vector3_msg,
)

# --- paper 3 rotation-modulated alignment -----------------------------------------------------
PLATFORM_FRAME = "platform_frd"
#: Standard-deviation component of a vector element the estimator does not estimate
#: (the REP 145 "not provided" marker, used per element).
NOT_ESTIMATED = -1.0


def joint_position_velocity(msg: JointState, name: str) -> tuple[float, float | None] | None:
    """(position, velocity or None) of joint ``name``; None when the message lacks it."""
    names = list(msg.name)
    if name not in names:
        return None
    i = names.index(name)
    if i >= len(msg.position):
        return None
    vel = float(msg.velocity[i]) if i < len(msg.velocity) else None
    return float(msg.position[i]), vel


def enu_to_ned(v: Sequence[float]) -> tuple[float, float, float]:
    """Components (E, N, U) → (N, E, D) of the same vector."""
    return float(v[1]), float(v[0]), -float(v[2])


def sigma_enu_to_ned(s: Sequence[float]) -> tuple[float, float, float]:
    """Standard deviations (E, N, U) → (N, E, D)."""
    return float(s[1]), float(s[0]), float(s[2])


def planar(v: Sequence[float], sigma: bool = False) -> tuple[float, float, float]:
    """An (x, y) estimate as a 3-vector: z = 0, or the not-estimated marker for a σ vector."""
    return float(v[0]), float(v[1]), NOT_ESTIMATED if sigma else 0.0


def north_only(value: float, sigma: bool = False) -> tuple[float, float, float]:
    """A north component as an NED vector (east/down 0, or not-estimated for a σ vector)."""
    rest = NOT_ESTIMATED if sigma else 0.0
    return float(value), rest, rest
