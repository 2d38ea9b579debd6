"""The platform chain's cores, built as :mod:`.core_loop` builds them, and their states
packed into the arrays :func:`.compiled_platform.platform_block` steps.

:func:`chain_values` says whether a scenario's node set is the chain the compiled block
loop reproduces (any other falls back to the Python loop); :func:`build_chain` builds the
cores from the nodes' parameter values (so a refused value is refused by the same check)
and packs them (:class:`PlatformChain`).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from gimbal_control.dtg_servo import platform_servo_core
from gimbal_estimators.navigator_odometry import NavigatorOdometry, OdometryModel
from gimbal_estimators.platform_navigator import PlatformNavigator
from gimbal_estimators.platform_navigator_params import PlatformNavigatorParams
from gimbal_kinematics.gimbal.gimbal_params import GIMBAL_MODELS
from gimbal_kinematics.maths.frames import PLATFORM_JOINTS
from gimbal_kinematics.params.table import steps_per_sample
from gimbal_kinematics.ros.wire import UNMEASURED_VARIANCE

from .loop_plan import node_values
from ..world.sensor_suite import SensorSuite, SensorSuiteConfig
from ..world.sensors import dtg_kernels
from ..world.vehicle import VehicleConfig, VehicleCore, VehicleTruth

CHAIN = ("vehicle_dynamics", "sensor_models", "platform_navigator", "platform_servo")

#: The block's output row of a step (recorded runs): truth (joint angles, rates, efforts,
#: q_ns, ω_s, f_s), the resolver and IMU samples, the navigator (output this step, accepted
#: samples, L, λ, h, v, held command and whether there is one, ψ̂, torquing) and the servo
#: (tick result, ticks, voltages, signals, φz, φ̇z); the accelerometers' and gyros' true biases
#: (their run-constant and in-run parts) after the step's IMU sample; on DTGs, the pickoffs
#: (lower x, y, upper x, y) and the torquer currents (x, y, z) the servo holds after the step.
OUT_COLUMNS = (
    "pos0", "pos1", "pos2", "pos3", "vel0", "vel1", "vel2", "vel3", "eff0", "eff1", "eff2", "eff3",
    "qx", "qy", "qz", "qw", "wx", "wy", "wz", "fx", "fy", "fz",
    "ra0", "ra1", "ra2", "ra3", "rr0", "rr1", "rr2", "rr3", "if0", "if1", "if2", "iw0", "iw1", "iw2",
    "nav_out", "accepted", "lat", "lon", "h", "vn", "ve", "vd", "cmd_n", "cmd_e", "cmd_d", "has_cmd", "psi", "torquing",
    "tick", "ticks", "v0", "v1", "v2", "v3", "g0", "g1", "g2", "g3", "phi", "phi_rate",
    "ab0", "ab1", "ab2", "gb0", "gb1", "gb2", "phin", "phin_rate", "pk0", "pk1", "pk2", "pk3", "tq0", "tq1", "tq2")
O = {name: i for i, name in enumerate(OUT_COLUMNS)}
N_OUT = len(OUT_COLUMNS)
#: the navigator node's joint sample (has one, stamp ns, θ, rate), held command (has one, N, E,
#: D), the navigator's last and first stamps [ns] (NaN: none yet) and the servo's
#: ``~/modulation_next`` (stamp ns, NaN: none yet; φz, φ̇z)
J_HAS, J_T_NS, J_THETA, J_RATE, J_HAS_CMD, J_CMD, J_NAV_LAST, J_NAV_T0, J_NEXT_T, J_NEXT_PHI, J_NEXT_RATE = \
    0, 1, 2, 3, 4, 5, 8, 9, 10, 11, 12
N_JOINT = 13


def chain_values(values: dict[str, tuple[str, dict[str, Any]]]) -> dict[str, tuple[str, dict]] | None:
    """executable -> (node name, values) when the nodes are the chain with the parameters the
    compiled step reproduces (the servo on its gyro triad, or on the DTG pair with ``dtg``
    among the sensors; the azimuth from the resolvers, or from the servo's
    ``~/modulation_next`` at the servo's and the IMU's rate); None otherwise."""
    by_exe = {exe: (name, v) for name, (exe, v) in values.items()}
    if len(values) != len(CHAIN) or set(by_exe) != set(CHAIN):
        return None
    veh = by_exe["vehicle_dynamics"][1]
    sen = by_exe["sensor_models"][1]
    nav = by_exe["platform_navigator"][1]
    srv = by_exe["platform_servo"][1]
    on_dtg = srv["gyro_source"] == "dtg"
    gyros = {"platform_imu", "resolvers", "dtg"} if on_dtg else {"platform_imu", "resolvers"}
    if veh["plant"] != "four_gimbal_platform" or set(sen["sensors"]) != gyros:
        return None
    if not _azimuth_compiled(nav, srv, sen):
        return None
    try:
        vehicle = VehicleCore(VehicleConfig.from_values(veh), GIMBAL_MODELS[veh["gimbal_model"]])
        suite = SensorSuite(SensorSuiteConfig.from_values(sen))
    except (ValueError, KeyError):
        return None  # the Python loop refuses it, naming the parameter
    if not hasattr(vehicle.profile, "packed"):
        return None  # a host the profile kernels do not sample
    return by_exe


def _azimuth_compiled(nav: dict, srv: dict, sen: dict) -> bool:
    """Whether the block loop reads the navigator's azimuth as the node does: the resolvers'
    azimuth joint, or the servo's φz of each IMU step, made by the servo a step ahead
    (``modulation_next``; the navigator's joint, the servo's and the IMU's rates one)."""
    if nav["azimuth_source"] == "resolver":
        return nav["joint_topic"] == "/platform/resolvers" and nav["azimuth_joint"] in PLATFORM_JOINTS \
            and not srv["modulation_next"]
    rates = {steps_per_sample(nav, "joint_rate_hz"), steps_per_sample(srv, "imu_rate_hz"),
             steps_per_sample(sen, "platform_imu_rate_hz")}
    return srv["modulation_next"] and srv["command_source"] == "navigator" and len(rates) == 1


@dataclass
class PlatformChain:
    """The packed chain: the block's arrays and what its recording needs."""

    n_steps: int
    rate_hz: float
    dt: float
    config: np.ndarray
    host: np.ndarray
    x: np.ndarray
    plant_params: np.ndarray
    res_every: int
    imu_every: int
    res_noise: float
    res_state: np.ndarray
    res_stream: Any
    acc: np.ndarray
    acc_k: np.ndarray
    acc_c: np.ndarray
    acc_need: int
    acc_stream: Any
    gyr: np.ndarray
    gyr_k: np.ndarray
    gyr_c: np.ndarray
    gyr_need: int
    gyr_stream: Any
    nav_state: np.ndarray
    nav_params: np.ndarray
    joint: np.ndarray
    servo_state: np.ndarray
    servo_params: np.ndarray
    pid_state: np.ndarray
    pid_gains: np.ndarray
    names: dict[str, str]             # executable -> node name
    values: dict[str, dict]           # executable -> node values
    truth0: VehicleTruth              # the truth of step 0 (host and joints)
    truth1: VehicleTruth              # a truth after one step (the host's step rotation)
    moving: Any                       # a moving host: (lines, terms, starts) of its profile; None: static
    env: tuple                        # the NED frame's inertial rate (x, y, z) [rad/s], gravity [m/s²]
    q_earth: tuple                    # n's inertial rotation over one step (quaternion)
    base_last: np.ndarray             # the base torques' last outer-member rates (has one, a, q, p, r)
    suite: SensorSuite
    site: Any
    odometry: NavigatorOdometry
    dtg: tuple                        # the DTG pair's (state, parameters, mounts, q_earth), its Generator and
                                      # normals per step (dtg_kernels); empty arrays without DTGs


def _joint() -> np.ndarray:
    """The navigator node's joint sample, held command and stamps, before the first sample."""
    j = np.zeros(N_JOINT)
    j[J_NAV_LAST] = j[J_NAV_T0] = j[J_NEXT_T] = math.nan
    return j


#: the chain's constants (``_config``): step, platform, resolver and IMU decimations, the
#: resolvers' converter (quantum, noise, velocity gate, cyclic error and its four phases), the
#: navigator's joint age, the servo's source, the run's rate, steps and azimuth joint
(C_DT, C_SUBSTEPS, C_QUASI, C_RES_EVERY, C_IMU_EVERY, C_RES_QUANTUM, C_RES_NOISE, C_RES_GATE_STEPS,
 C_RES_GATE_TIME, C_MAX_AGE_NS, C_FOLLOWS, C_CONTROLLED, C_RATE, C_N, C_JOINT, C_RES_CYCLIC,
 C_RES_HARMONIC, C_RES_PHASES) = range(18)
#: and after the phases: the base motion into the loops, the azimuth from the servo's φz; the
#: servo on DTGs, its pickoff read decimation, the rotors' drift noise per step [rad/s] and the
#: pickoff read-out noise [rad], the torquer's nominal scale [rad/s/A] and range [A]
(C_BASE_MOTION, C_FROM_SERVO, C_DTG, C_DTG_EVERY, C_DTG_ARW, C_DTG_PICK, C_DTG_SCALE,
 C_DTG_IMAX) = range(C_RES_PHASES + 4, C_RES_PHASES + 12)
N_CONFIG = C_DTG_IMAX + 1


def _config(vehicle: VehicleCore, suite: SensorSuite, nav: dict, servo: dict, controlled: bool) -> np.ndarray:
    res = suite.resolvers
    c = np.zeros(N_CONFIG)
    c[:C_RES_CYCLIC] = (vehicle.config.dt, vehicle.config.platform_substeps, 1.0 if vehicle._platform_quasi_static else 0.0,
            suite._dec["resolver_rate_hz"], suite._dec["platform_imu_rate_hz"], res.quantum_rad, res._noise,
            res._gate_steps, res.gate_time_s,
            int(round(nav["max_joint_age_s"] * 1e9)), 1.0 if servo["command_source"] == "navigator" else 0.0,
            1.0 if controlled else 0.0, vehicle.config.sim_rate_hz, vehicle.config.n_steps,
            PLATFORM_JOINTS.index(nav["azimuth_joint"]))
    c[C_RES_CYCLIC], c[C_RES_HARMONIC] = res.cyclic_rad, res.cyclic_harmonic
    c[C_RES_PHASES:C_RES_PHASES + 4] = res.cyclic_phases
    c[C_BASE_MOTION] = 1.0 if vehicle.config.platform_base_motion else 0.0
    c[C_FROM_SERVO] = 1.0 if nav["azimuth_source"] == "servo" else 0.0
    if suite.dtg is not None:
        pair = suite.dtg.pair
        c[C_DTG], c[C_DTG_EVERY] = 1.0, steps_per_sample(servo, "imu_rate_hz")
        c[C_DTG_ARW] = pair._arw / math.sqrt(vehicle.config.dt) if pair._arw > 0.0 else 0.0
        c[C_DTG_PICK] = pair._pick_sigma
    return c


def _dtg(suite: SensorSuite, servo) -> tuple:
    """The DTG pair packed (:func:`.dtg_kernels.pack`), its Generator and normals per step."""
    if suite.dtg is None:
        empty = np.zeros(0)
        return (np.zeros(dtg_kernels.N_STATE), np.zeros((2, dtg_kernels.N_GYRO)), np.zeros((2, 3, 3)), empty), None, 0
    pair = suite.dtg.pair
    need = (4 if pair._arw > 0.0 else 0) + (4 if pair._pick_sigma > 0.0 else 0)
    return dtg_kernels.pack(pair, suite.dtg._q_earth, servo.torquer_current), pair.rng, need


def build_chain(scenario) -> PlatformChain:
    """The scenario's chain, built and packed (module docstring)."""
    by_exe = chain_values(node_values(scenario))
    if by_exe is None:
        raise ValueError(f"scenario {scenario.name!r} is not the platform chain")
    names = {exe: name for exe, (name, _) in by_exe.items()}
    values = {exe: v for exe, (_, v) in by_exe.items()}
    veh, nav, srv = values["vehicle_dynamics"], values["platform_navigator"], values["platform_servo"]
    vehicle = VehicleCore(VehicleConfig.from_values(veh), GIMBAL_MODELS[veh["gimbal_model"]])
    suite = SensorSuite(SensorSuiteConfig.from_values(values["sensor_models"]))
    navigator = PlatformNavigator(PlatformNavigatorParams.from_values(nav))
    servo = platform_servo_core(srv)
    odometry = NavigatorOdometry(OdometryModel.from_values(nav, heading_known=nav["azimuth_source"] != "servo"),
                                 UNMEASURED_VARIANCE)
    truth0 = vehicle.truth()
    scratch = VehicleCore(vehicle.config, GIMBAL_MODELS[veh["gimbal_model"]])
    scratch.step((0.0,) * 4)
    host = np.array([*truth0.euler, *truth0.omega_ib_b, *truth0.specific_force_b], dtype=float)
    acc, gyr = suite.platform_accel, suite.platform_gyro
    config = _config(vehicle, suite, nav, srv, veh["controlled"])
    if suite.dtg is not None:
        config[C_DTG_SCALE], config[C_DTG_IMAX] = servo.scale_rad_s_a, servo.max_current_a
    return PlatformChain(
        n_steps=vehicle.config.n_steps, rate_hz=vehicle.config.sim_rate_hz, dt=vehicle.config.dt,
        config=config, host=host, x=vehicle._platform_x.copy(),
        plant_params=vehicle._platform_params, res_every=suite._dec["resolver_rate_hz"],
        imu_every=suite._dec["platform_imu_rate_hz"], res_noise=suite.resolvers._noise,
        res_state=suite.resolvers._state.copy(), res_stream=suite.resolvers._normals, acc=acc.rows.copy(),
        acc_k=acc.K, acc_c=acc.constants, acc_need=acc._need, acc_stream=acc._normals, gyr=gyr.rows.copy(),
        gyr_k=gyr.K, gyr_c=gyr.constants, gyr_need=gyr._need,
        gyr_stream=gyr._normals, nav_state=navigator.state.copy(), nav_params=navigator.kernel_params.copy(), joint=_joint(),
        servo_state=servo.state.copy(), servo_params=servo.kernel_params, pid_state=servo._pid_state.copy(),
        pid_gains=servo._pid_gains.copy(), names=names, values=values, truth0=truth0, truth1=scratch.truth(),
        suite=suite, site=vehicle.profile.site, odometry=odometry,
        moving=None if vehicle.profile.constant else vehicle.profile.packed,
        env=(*(float(v) for v in vehicle.env.omega_in_n), float(vehicle.env.gravity_m_s2)), q_earth=vehicle._q_earth,
        base_last=np.zeros(5), dtg=_dtg(suite, servo))
