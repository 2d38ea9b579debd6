"""Pure-Python plant models (no rclpy): host motion profiles, the two-axis gimbal of
paper 1 and the single-axis DC-motor loops of paper 3. The ``vehicle_dynamics`` node wraps
these (the rigid-body gimbal model itself lives in :mod:`gimbal_kinematics.gimbal`, where the
controller that inverts it finds it); see each module's docstring for equations, units and chosen parameters."""
from gimbal_kinematics.gimbal.gimbal_dynamics import TwoAxisGimbal
from gimbal_kinematics.gimbal.gimbal_params import GimbalParams, inertia_matrix
from gimbal_kinematics.gimbal.host_state import HostState, body_inertial_rates, host_state_from_euler
from gimbal_kinematics.gimbal.turret_base import (
    SiteEnvironment, TurretBase, rest_base, site_environment, turret_base_from_host,
)

from .gimbal_simulator import GimbalSimulator
from .motion_profiles import (
    PROFILE_NAMES,
    SinusoidChannel,
    SinusoidProfile,
    Site,
    make_profile,
    paper1_land_vehicle,
    paper5_ship,
    static_base,
)
from .platform_loops import PAPER3_TABLE1, PlatformAxis, PlatformAxisParams, paper3_axis_params
from .rk4 import rk4_step

__all__ = [
    "GimbalParams", "GimbalSimulator", "HostState", "PAPER3_TABLE1", "PROFILE_NAMES",
    "PlatformAxis", "PlatformAxisParams", "SinusoidChannel", "SinusoidProfile", "Site",
    "SiteEnvironment", "TurretBase", "TwoAxisGimbal", "body_inertial_rates",
    "host_state_from_euler", "inertia_matrix", "make_profile", "paper1_land_vehicle",
    "paper3_axis_params", "paper5_ship", "rest_base", "rk4_step", "site_environment",
    "static_base", "turret_base_from_host",
]
