"""The ``vehicle_dynamics`` node's parameters and --help text, declared once in
:class:`VehicleDynamicsNodeParams`. The mapping to the core's config is
:meth:`..world.vehicle.VehicleConfig.from_values`.
"""
from __future__ import annotations

from dataclasses import dataclass

from gimbal_kinematics.gimbal.gimbal_params import GIMBAL_MODELS
from gimbal_kinematics.params.table import SHARED, declaration, param, same_as

from ..world.plant.motion_profiles import PROFILE_NAMES
from ..world.plant.dc_motor import GIMBAL_ACTUATORS, SMALL_GIMBAL_MOTOR as _M
from ..world.vehicle import PLANTS, PLATFORM_INTEGRATORS


@dataclass(frozen=True)
class VehicleDynamicsNodeParams:
    """Simulated host vehicle and gimbal/platform dynamics. Owns /clock and publishes the truth topics every step;
    in lockstep it integrates step k -> k+1 only after the command stamped k has arrived.
    """

    profile: str = param("paper1_land_vehicle", "host motion profile", choices=PROFILE_NAMES)
    profile_params: str = param("{}", "profile parameters as a YAML mapping, e.g. '{lat_deg: 39.9}' "
        "(docs/interfaces.md: host motion profiles)")
    plant: str = param("two_axis_gimbal", "plant carried by the host", choices=PLANTS)
    gimbal_model: str = param("paper1", "two-axis gimbal mass properties, friction and torque limits: paper1 (~10 kg "
        "payload) or uav_small (paper 2's ~1 kg UAV gimbal)", choices=tuple(GIMBAL_MODELS))
    sim_rate_hz: float = param(1000.0, "simulation (lockstep) rate", 1.0, 100000.0, unit="Hz")
    duration_s: float = param(120.0, "simulated duration; the node stops stepping there", 1e-3, 1e7, unit="s")
    earth_rate: bool = param(True, "include the earth rate in inertial rates (false: NED is inertial)")
    initial_gimbal_deg: tuple[float, ...] = param((0.0, 0.0), "initial gimbal azimuth psi_m and elevation theta_m",
        unit="deg")
    initial_platform_deg: tuple[float, ...] = param((0.0, 0.0, 0.0, 0.0), "initial platform loop angles azimuth, "
        "inner roll, pitch, outer roll", unit="deg")
    timing: str = param("lockstep", "lockstep: step on commands/events; realtime: pace to the wall clock",
        choices=("lockstep", "realtime"), aliases=("mode",))
    real_time_factor: float = param(1.0, "realtime timing: simulated seconds per wall-clock second (1: real time; "
        "below 1 slows the wall clock down, giving a loaded machine headroom; stamps stay sim time)",
        0.01, 10.0, unit="s/s")
    controlled: bool = param(False, "a controller commands the plant (lockstep waits for its command)")
    command_interface: str = same_as(SHARED["command_interface"])
    ros2_control_topic: str = same_as(SHARED["ros2_control_topic"])
    wait_for_subscribers: int = param(1, "matched subscriptions each truth topic needs before step 0", 0, 1000)
    subscriber_counts: tuple[str, ...] = param((), "per-topic overrides of wait_for_subscribers, as 'topic=count' "
        "entries", array_type="string_array")
    topic_subscriber_counts: tuple[str, ...] = param((), "before step 0, wait until the ROS graph shows this many "
        "subscriptions on topics the vehicle does not publish, as 'topic=count' entries (realtime runs: free-timing "
        "nodes that report no readiness, e.g. '/gimbal/imu=3')", array_type="string_array")
    pace_topics: tuple[str, ...] = param((), "rosgraph_msgs/Clock progress topics (time of the next step the reader "
        "needs) of readers to wait for and not outrun", array_type="string_array")
    pace_window_steps: int = param(50, "steps the vehicle may run ahead of the slowest pace topic", 1, 10**6)
    exit_at_end: bool = param(False, "exit the process after the last step")
    platform_substeps: int = param(4, "four_gimbal_platform: RK4 substeps per step of the DC-motor loops (electrical "
        "time constant ~1 ms: keep a substep <= 2 ms at low sim_rate_hz)", 1, 10**4)
    platform_integrator: str = param("rk4", "four_gimbal_platform: rk4 (platform_substeps RK4 substeps per step) or "
        "quasi_static (one implicit step per step, the armature current at its quasi-static value: for loops at a few "
        "Hz, where RK4 would need a substep per 2 ms)", choices=PLATFORM_INTEGRATORS)
    platform_base_motion: bool = param(False, "four_gimbal_platform: the host's motion enters each gimbal loop (the "
        "outer member's inertial acceleration torques the gimbal; friction and back-EMF see the relative rate); "
        "false: the joints see no base motion (a base at rest)")
    gimbal_actuator: str = param("torque", "two_axis_gimbal: torque (the command's joint torques act directly) or "
        "dc_motor (each joint is a direct-drive brushed DC motor on a PWM H-bridge: the command is its torque demand, "
        "turned into a duty with the motor_* figures; armature lag, back-EMF, bus limit and duty steps act)",
        choices=GIMBAL_ACTUATORS)
    motor_resistance_ohm: float = param(_M.resistance_ohm, "dc_motor: armature resistance R (default: FAULHABER "
        "2342 S 012 CR)", 1e-6, 1e6, unit="ohm")
    motor_inductance_h: float = param(_M.inductance_h, "dc_motor: armature inductance L", 1e-9, 10.0, unit="H")
    motor_torque_constant_nm_a: float = param(_M.torque_constant_nm_a, "dc_motor: torque constant k_t", 1e-6, 100.0,
        unit="N*m/A")
    motor_back_emf_v_s_rad: float = param(_M.back_emf_v_s_rad, "dc_motor: back-EMF constant k_e", 1e-6, 100.0,
        unit="V*s/rad")
    motor_bus_voltage_v: float = param(_M.bus_voltage_v, "dc_motor: H-bridge supply voltage (stall torque "
        "k_t V/R)", 1e-3, 1e4, unit="V")
    motor_pwm_hz: float = param(_M.pwm_hz, "dc_motor: PWM switching frequency (averaged model: the armature "
        "sees the duty's mean voltage)", 1.0, 1e7, unit="Hz")
    motor_pwm_timer_hz: float = param(_M.pwm_timer_hz, "dc_motor: PWM timer clock; timer/PWM counts per period "
        "set the duty resolution (0: continuous duty)", 0.0, 1e10, unit="Hz")
    position_truth_every_steps: int = param(0, "publish the host's true position (/truth/host/fix, NavSatFix) and "
        "NED velocity (/truth/host/velocity, m/s) every N steps; 0: not published", 0, 10**9)


PARAMS, DESCRIPTION = declaration(VehicleDynamicsNodeParams)
