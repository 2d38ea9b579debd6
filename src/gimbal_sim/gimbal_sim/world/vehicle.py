"""Vehicle dynamics core: host motion profile + plant, stepped in lockstep (no rclpy).

One ``VehicleCore`` owns the simulation clock (step index k, t = k·dt) and integrates the
host (analytic profile) and one plant:

* ``two_axis_gimbal``: the paper 1 sighting system (:mod:`.plant.gimbal_simulator`, with the
  rigid-body model of :mod:`gimbal_kinematics.gimbal.gimbal_dynamics`),
  commanded by joint torques (τ_a, τ_e) [N·m], applied directly (``gimbal_actuator: torque``)
  or as the torque demands of a brushed DC motor and PWM drive per joint
  (``dc_motor``, :mod:`.plant.dc_motor`: armature R, L, k_t, k_e, bus limit, duty steps);
* ``four_gimbal_platform``: the paper 3 four-gimbal platform, one single-axis DC-motor
  loop per gimbal joint (:mod:`.plant.platform_loops`), commanded by the gimbal motor
  voltages [V] in the order azimuth a, inner roll q, pitch p, outer roll r;
* ``host_only``: no plant (e.g. the ship carrying the LGUs of paper 5).

Platform model: each loop is a gimbal joint of the chain base → outer roll r → pitch p →
inner roll q → azimuth a (:mod:`gimbal_kinematics.maths.four_gimbal`): its angle and rate are the
joint's, relative to the outer member, driven by that joint's motor. The stable element's
attitude is ``C_sn = C_sb(θ_a, θ_q, θ_p, θ_r) C_bn`` and its inertial rate the chain's
(``four_gimbal.platform_rate_s``), so the azimuth turns the platform about its own axis and
a tilt stays fixed in n while it turns. The joints are decoupled and see no base motion:
the host must be at rest relative to the earth (paper 3's experiments), whose constant rate
does not enter the relative joint dynamics.

:meth:`VehicleCore.truth` returns the exact state at t_k; :meth:`VehicleCore.step` advances
to t_{k+1} with the command held over the step (zero-order hold).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Mapping, NamedTuple, Sequence

import numpy as np
import yaml

from gimbal_kinematics.maths.four_gimbal import outer_member_rates
from gimbal_kinematics.maths.platform_kernels import platform_truth
from gimbal_kinematics.params.table import ParameterError
from gimbal_kinematics.maths.rotations import (
    quat_canonical, quat_conj, quat_from_euler321, quat_from_rotation_vector,
    quat_mul, rotation_vector_from_quat,
)

from .plant.dc_motor import GIMBAL_ACTUATORS, DcMotorDrive, DcMotorParams
from .plant.gimbal_simulator import GimbalSimulator
from .plant.sighting_plant_kernels import inner_gimbal_truth
from gimbal_kinematics.maths.frames import GIMBAL_ENCODER_JOINTS as GIMBAL_JOINTS, PLATFORM_JOINTS
from gimbal_kinematics.gimbal.gimbal_params import GimbalParams
from gimbal_kinematics.gimbal.host_state import inertial_rates_trig
from .plant.motion_profiles import PROFILE_NAMES, make_profile
from .plant.platform_kernels import P_KT, platform_step
from .plant.platform_loops import PlatformAxis, paper3_axis_params
from gimbal_kinematics.gimbal.turret_base import site_environment

PLANTS = ("two_axis_gimbal", "four_gimbal_platform", "host_only")
PLATFORM_INTEGRATORS = ("rk4", "quasi_static")
_PLATFORM_AXES = ("a", "q", "p", "r")


@dataclass(frozen=True)
class VehicleConfig:
    """Parameters of the vehicle core; angles at this edge in degrees (unit in the name).

    ``profile_params`` is the mapping :func:`.plant.motion_profiles.make_profile` takes.
    ``initial_joints_deg``: (ψm, θm) for the gimbal; (θ_a, θ_q, θ_p, θ_r) for the platform.
    ``platform_substeps``: RK4 substeps per simulation step of the DC-motor loops (their
    electrical time constant is about 1 ms). ``platform_integrator``: ``rk4`` (those substeps)
    or ``quasi_static`` (one implicit step per simulation step with the armature current at
    its quasi-static value, :meth:`.plant.platform_loops.PlatformAxis.step_quasi_static`: for
    control rates of tens of Hz, where RK4 would need a substep per 2 ms).
    ``platform_base_motion``: the host's motion enters each gimbal loop (paper 3 Fig. 2): the
    joint states stay relative to the outer member, whose inertial rate ω_A about the joint
    axis (:func:`gimbal_kinematics.maths.four_gimbal.outer_member_rates`) accelerates and so torques
    the gimbal by −J ω̇_A (differenced over the last step), while the bearing friction and the
    back-EMF see the relative rate; off (default), the joints see no base motion.
    ``gimbal_actuator`` (two_axis_gimbal): ``torque`` (the command is the joint torques) or
    ``dc_motor`` (the command is each joint's torque demand to a DC motor's PWM drive,
    ``motor``'s figures; :mod:`.plant.dc_motor`).
    """

    profile: str = "paper1_land_vehicle"
    profile_params: Mapping[str, Any] = field(default_factory=dict)
    plant: str = "two_axis_gimbal"
    sim_rate_hz: float = 1000.0
    duration_s: float = 120.0
    earth_rate: bool = True
    initial_joints_deg: tuple[float, ...] = ()
    platform_substeps: int = 4
    platform_integrator: str = "rk4"
    platform_base_motion: bool = False
    gimbal_actuator: str = "torque"
    motor: DcMotorParams = field(default_factory=DcMotorParams)

    def __post_init__(self) -> None:
        if self.gimbal_actuator not in GIMBAL_ACTUATORS:
            raise ValueError(f"gimbal_actuator must be one of {list(GIMBAL_ACTUATORS)}, got {self.gimbal_actuator!r}")
        if not isinstance(self.motor, DcMotorParams):
            raise ValueError("motor must be a DcMotorParams")
        if self.profile not in PROFILE_NAMES:
            raise ValueError(f"profile {self.profile!r} is unknown; known: {sorted(PROFILE_NAMES)}")
        if self.plant not in PLANTS:
            raise ValueError(f"plant {self.plant!r} is unknown; known: {list(PLANTS)}")
        if not (math.isfinite(self.sim_rate_hz) and self.sim_rate_hz > 0.0):
            raise ValueError(f"sim_rate_hz must be > 0, got {self.sim_rate_hz}")
        if not (math.isfinite(self.duration_s) and self.duration_s > 0.0):
            raise ValueError(f"duration_s must be > 0, got {self.duration_s}")
        n_joints = {"two_axis_gimbal": 2, "four_gimbal_platform": 4, "host_only": 0}[self.plant]
        if self.initial_joints_deg and len(self.initial_joints_deg) != n_joints:
            raise ValueError(
                f"initial_joints_deg needs {n_joints} values for plant {self.plant!r}, "
                f"got {len(self.initial_joints_deg)}")
        if not all(math.isfinite(v) for v in self.initial_joints_deg):
            raise ValueError("initial_joints_deg must be finite")
        if self.platform_substeps < 1:
            raise ValueError(f"platform_substeps must be >= 1, got {self.platform_substeps}")
        if self.platform_integrator not in PLATFORM_INTEGRATORS:
            raise ValueError(f"platform_integrator must be rk4 or quasi_static, got {self.platform_integrator!r}")

    @classmethod
    def from_values(cls, values: dict) -> VehicleConfig:
        """The config from a ``vehicle_dynamics`` node's values (name -> value, as declared in
        :mod:`..nodes.vehicle_dynamics_params`; ``profile_params`` a YAML mapping, the initial joints
        those of the chosen plant); :class:`ParameterError` names the parameter refused."""
        try:
            profile_params = yaml.safe_load(values["profile_params"]) or {}
        except yaml.YAMLError as exc:
            raise ParameterError(f"parameter 'profile_params' is not valid YAML: {exc}") from exc
        if not isinstance(profile_params, dict):
            raise ParameterError("parameter 'profile_params' must be a YAML mapping")
        initial = {"two_axis_gimbal": values["initial_gimbal_deg"],
                   "four_gimbal_platform": values["initial_platform_deg"], "host_only": []}[values["plant"]]
        try:
            return cls(profile=values["profile"], profile_params=profile_params, plant=values["plant"],
                       sim_rate_hz=values["sim_rate_hz"], duration_s=values["duration_s"],
                       earth_rate=values["earth_rate"], initial_joints_deg=tuple(initial),
                       platform_substeps=values["platform_substeps"],
                       platform_integrator=values["platform_integrator"],
                       platform_base_motion=values["platform_base_motion"],
                       gimbal_actuator=values["gimbal_actuator"],
                       # the motor_* parameters are DcMotorParams' fields by name
                       motor=DcMotorParams(**{k[len("motor_"):]: x for k, x in values.items()
                                              if k.startswith("motor_")}))
        except ValueError as exc:
            raise ParameterError(str(exc)) from exc

    @property
    def dt(self) -> float:
        return 1.0 / self.sim_rate_hz

    @property
    def n_steps(self) -> int:
        """Number of steps to reach ``duration_s``."""
        return int(round(self.duration_s * self.sim_rate_hz))

    @property
    def command_size(self) -> int:
        return {"two_axis_gimbal": 2, "four_gimbal_platform": 4, "host_only": 0}[self.plant]


class VehicleTruth(NamedTuple):
    """Exact state at step ``k`` (t = k·dt) [SI units, rad].

    ``quat_nb``: host attitude (x, y, z, w); ``omega_ib_b``: host inertial rate in b;
    ``specific_force_b``: pivot acceleration minus gravity in b [m/s²];
    ``delta_angle_b``: the exact rotation vector of b over the step ending at t, resolved
    in b at the step's start (zeros at k = 0). ``joint_*``: per ``joint_names``.
    ``quat_nm``/``omega_im_m``: inner gimbal (or stable element, for the platform)
    attitude and inertial rate; ``specific_force_m``: its specific force [m/s²].
    """

    k: int
    t: float
    euler: tuple[float, float, float]
    quat_nb: np.ndarray
    omega_ib_b: tuple[float, float, float]
    specific_force_b: tuple[float, float, float]
    delta_angle_b: np.ndarray
    joint_names: tuple[str, ...]
    joint_position: tuple[float, ...]
    joint_velocity: tuple[float, ...]
    joint_effort: tuple[float, ...]
    quat_nm: np.ndarray | None
    omega_im_m: tuple[float, float, float] | None
    specific_force_m: tuple[float, float, float] | None


class VehicleCore:
    """Host + plant integrated at ``config.dt``; see the module docstring."""

    def __init__(self, config: VehicleConfig, gimbal_params: GimbalParams | None = None) -> None:
        self.config = config
        self.profile = make_profile(config.profile, dict(config.profile_params))
        site = self.profile.site
        self.env = site_environment(site.lat_rad, site.height_m, config.earth_rate)
        w = self.env.omega_in_n
        # exp([ω_in dt ×]): n's inertial rotation over one step (constant).
        self._q_earth = quat_from_rotation_vector(w[0] * config.dt, w[1] * config.dt, w[2] * config.dt)
        self.k = 0
        self._gimbal: GimbalSimulator | None = None
        self._motor: DcMotorDrive | None = None
        self._platform: list[PlatformAxis] = []
        self._platform_x = np.zeros((0, 3))  # (θ, ω, i) per axis a, q, p, r
        self._applied: tuple[float, ...] = (0.0,) * config.command_size
        init = [math.radians(v) for v in config.initial_joints_deg] or [0.0] * config.command_size
        if config.plant == "two_axis_gimbal":
            self._gimbal = GimbalSimulator(self.profile, config.dt, gimbal_params,
                                           x0=(init[0], init[1], 0.0, 0.0), earth_rate=config.earth_rate)
            self._host = self._gimbal.host
            if config.gimbal_actuator == "dc_motor":
                self._motor = DcMotorDrive(config.motor, 2)
        else:
            self._host = self.profile.sample(0.0)
        if config.plant == "four_gimbal_platform":
            self._platform = [PlatformAxis(paper3_axis_params(axis)) for axis in _PLATFORM_AXES]
            self._platform_x = np.array([(angle, 0.0, 0.0) for angle in init], dtype=float)
            self._platform_params = np.array([axis.kernel_params for axis in self._platform])
            self._platform_quasi_static = config.platform_integrator == "quasi_static"
        self._q_nb = host_quat(self._host.roll, self._host.pitch, self._host.yaw)
        self._delta = (0.0, 0.0, 0.0)
        self._constant_delta: tuple[float, float, float] | None = None
        self._outer_rates: tuple[float, ...] | None = None  # ω_A of the last step (platform_base_motion)

    def _base_torques(self) -> tuple[float, ...]:
        """−J ω̇_A per platform joint (a, q, p, r) [N·m], ω̇_A differenced from the last step."""
        host = self._host
        omega_b = inertial_rates_trig(host, self.env.omega_in_n, math.cos(host.roll), math.sin(host.roll),
                                      math.cos(host.pitch), math.sin(host.pitch))[:3]
        w = outer_member_rates(omega_b, self._platform_x[:, 0].tolist(), self._platform_x[:, 1].tolist())
        last = self._outer_rates if self._outer_rates is not None else w
        self._outer_rates = w
        dt = self.config.dt
        return tuple(-axis.params.inertia_kg_m2 * (w1 - w0) / dt for axis, w1, w0 in zip(self._platform, w, last))

    @property
    def t(self) -> float:
        return self.k * self.config.dt

    @property
    def finished(self) -> bool:
        return self.k >= self.config.n_steps

    def saturate(self, command: Sequence[float]) -> tuple[float, ...]:
        """The command the plant actually applies (torque or voltage limits)."""
        if self._gimbal is not None:
            return self._gimbal.dynamics.saturate(command)
        return tuple(axis.saturate(v) for axis, v in zip(self._platform, command))

    def step(self, command: Sequence[float] = ()) -> None:
        """Advance from t_k to t_{k+1} holding ``command`` (length ``config.command_size``)."""
        if len(command) != self.config.command_size:
            raise ValueError(f"command needs {self.config.command_size} values, got {len(command)}")
        dt = self.config.dt
        if self._gimbal is not None:
            if self._motor is not None:  # the motors' torques over the step, from the joint rates at its start
                command = self._motor.step(command, self._gimbal.x[2:], dt)
            self._gimbal.step(command)
            self._applied = self._gimbal.applied_torque
            host1 = self._gimbal.host
        else:
            host1 = self.profile.sample((self.k + 1) * dt)
        if self._platform:
            self._applied = self.saturate(command)
            torques = self._base_torques() if self.config.platform_base_motion else (0.0, 0.0, 0.0, 0.0)
            platform_step(self._platform_x, np.array(self._applied), np.array(torques), dt,
                          self.config.platform_substeps, self._platform_quasi_static, self._platform_params)
        if self._constant_delta is None:
            q_nb1 = host_quat(host1.roll, host1.pitch, host1.yaw)
            self._delta = step_rotation(self._q_nb, self._q_earth, q_nb1)
            self._q_nb = q_nb1
            if self.profile.constant:  # the same attitude every step: the same δ, bit for bit
                self._constant_delta = self._delta
        self._host = host1
        self.k += 1

    def truth(self) -> VehicleTruth:
        """Exact state at the current step."""
        host = self._host
        cr, sr = math.cos(host.roll), math.sin(host.roll)
        cp, sp = math.cos(host.pitch), math.sin(host.pitch)
        omega_b = inertial_rates_trig(host, self.env.omega_in_n, cr, sr, cp, sp)[:3]
        # f_b = a_b − C_bn (0, 0, g); C_bn's third column is C_nb's third row (−sθ, sφ cθ, cφ cθ).
        g = self.env.gravity_m_s2
        f_b = (host.accel_x - (-sp) * g, host.accel_y - (sr * cp) * g, host.accel_z - (cr * cp) * g)
        names: tuple[str, ...] = ()
        pos: tuple[float, ...] = ()
        vel: tuple[float, ...] = ()
        quat_nm = omega_m = f_m = None
        if self._gimbal is not None:
            psi_m, theta_m, psi_m_dot, theta_m_dot = self._gimbal.x
            names = GIMBAL_JOINTS
            pos = (host.psi_t, psi_m, theta_m)
            vel = (host.psi_t_dot, psi_m_dot, theta_m_dot)
            quat_nm, omega_m, f_m = _inner_gimbal_truth(self._q_nb, pos, vel, omega_b, f_b)
            quat_nm = np.array(quat_nm)
            effort = (0.0,) + tuple(self._applied)
        elif self._platform:
            names = PLATFORM_JOINTS
            pos = tuple(self._platform_x[:, 0].tolist())
            vel = tuple(self._platform_x[:, 1].tolist())
            q, omega_m, f_m = platform_truth(np.array((host.roll, host.pitch, host.yaw)), self._platform_x[:, 0],
                                             self._platform_x[:, 1], np.array(omega_b), np.array(f_b))
            quat_nm = np.array(q)
            effort = tuple((self._platform_x[:, 2] * self._platform_params[:, P_KT]).tolist())
        else:
            effort = ()
        return VehicleTruth(
            k=self.k, t=self.t, euler=(host.roll, host.pitch, host.yaw),
            quat_nb=np.array(self._q_nb), omega_ib_b=omega_b, specific_force_b=f_b,
            delta_angle_b=np.array(self._delta), joint_names=names, joint_position=pos,
            joint_velocity=vel, joint_effort=effort, quat_nm=quat_nm, omega_im_m=omega_m,
            specific_force_m=f_m,
        )


def host_quat(roll: float, pitch: float, yaw: float) -> tuple[float, float, float, float]:
    """The host's attitude q_nb (x, y, z, w) of its Euler angles [rad], canonical sign."""
    return quat_canonical(quat_from_euler321(roll, pitch, yaw))


def step_rotation(q0, q_earth, q1) -> tuple[float, float, float]:
    """The host's rotation vector over a step, in b at its start: δ = log(C_nb(t_k)ᵀ
    exp([ω_in dt×]) C_nb(t_k+1)), composed as quaternions (q_earth: n's inertial step rotation)."""
    return rotation_vector_from_quat(*quat_mul(quat_mul(quat_conj(q0), q_earth), q1))


def _inner_gimbal_truth(q_nb, pos, vel, omega_b, f_b):
    """(quat_nm, ω_im^m, f_m) of the inner gimbal (:func:`.plant.sighting_plant_kernels.inner_gimbal_truth`)."""
    return inner_gimbal_truth(tuple(q_nb), tuple(pos), tuple(vel), tuple(omega_b), tuple(f_b))
