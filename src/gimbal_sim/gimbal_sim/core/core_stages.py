"""Pure-core stages of the graph's nodes for :mod:`.core_loop` and ``gimbal-bench`` (no ROS).

A stage is called once per lockstep step with the loop's :class:`Bus` (what the step's
messages carry) and does what its node does with them, in the node's order. Each node has
two factories: one from the node's parameter values (what a scenario gives; each core's
``from_values``), one from the core object itself (what a paper runner that builds its
cores from Python objects passes, keeping the core to observe it).

When the run is recorded (``bus.record``, :class:`.recording.EngineBag`), each stage hands
it the messages its node publishes, made by the node's own serialisation function.
"""
from __future__ import annotations

import math
import time
from typing import Any, Callable

from gimbal_control.encoder_fusion import EncoderFusionController, EncoderFusionParams
from gimbal_control.geo_pointer import GeoPointer, GeoPointerParams
from gimbal_control.los_hold import LosHold, LosHoldParams
from gimbal_control.los_rate_controller import LosRateController, LosRateControllerParams
from gimbal_control.los_rate_controller_params import CLOCK_JUMP_S
from gimbal_control.operator_command import OperatorCommand, OperatorCommandParams
from gimbal_estimators.gyro_bias_ekf import GyroBiasEkf
from gimbal_estimators.gyro_bias_ekf_params import GyroBiasEkfParams
from gimbal_estimators.gyro_bias_ekf_stamp import EkfInput, feed_stamp
from gimbal_kinematics.maths.frames import GIMBAL_ENCODER_JOINTS
from gimbal_kinematics.params.table import steps_per_sample
from gimbal_kinematics.maths.rotations import euler321_from_quat, quat_canonical, quat_from_euler321, quat_to_dcm
from gimbal_kinematics.timing.control_policy import CommandStamps
from gimbal_kinematics.timing.stamps import step_stamp_ns
from gimbal_kinematics.timing.sync import RateSync
from gimbal_control.wire import encoder_fusion_messages, geo_pointer_messages, torque_command_messages
from gimbal_estimators.wire import ekf_messages

from ..nodes.wire import noise_covariances, operator_messages, sensor_messages, truth_messages
from ..world.operator_model import operator_core
from ..world.sensor_suite import (
    DtgSample, EncoderSample, GimbalGyroSample, InsSample, LguSample, PlatformImuSample, ResolverSample, SensorSuite,
    SensorSuiteConfig,
)
from ..world.sensors.free_gyro_sensor import FreeGyroSample



class Bus:
    """What one step's messages carry, as the nodes would read them: step k, its stamp t
    [s], the vehicle's truth, the sensor samples of the step (None when not due), the INS
    Euler angles as a reader of its quaternion gets them, the command and the bias
    estimate (None when not produced this step), with the estimator's whole output of the
    step (``ekf``: what the node publishes from, e.g. the bias sigma) for observers, and the
    operator's LOS rate command of the step (``operator``: (stamp [ns], q, r) [rad/s], what
    /operator/los_rate carries; None when none was published) with its true pointing error
    (``operator_error``: (ε, e_q, e_r) [rad], what ~/pointing_error carries), and the
    geo-pointer's budget when it stepped (``geo_budget``: (stamp [ns], 1σ RMS, semi-axes)
    [rad], what its ~/budget carries; None otherwise)."""

    __slots__ = ("k", "t", "t_ns", "record", "truth", "gyro", "encoders", "ins", "ins_euler", "command", "bias",
                 "ekf", "operator", "operator_error", "platform_imu", "resolvers", "nav", "nav_command", "modulation",
                 "modulation_next", "geo_budget", "lgu", "free_gyro", "dtg", "torquer_current")

    def __init__(self) -> None:
        self.k, self.t, self.t_ns = 0, 0.0, 0
        #: the run's recording, ``record(node name, [(topic, type, bytes)])``; None: not recorded
        self.record = None
        self.truth = self.gyro = self.encoders = self.ins = self.ins_euler = self.command = self.bias = None
        self.ekf = self.operator = self.operator_error = self.geo_budget = None
        # paper 3's platform (:mod:`.platform_stages`): its IMU and resolver samples, the navigator's output
        self.platform_imu = self.resolvers = self.nav = None
        # the platform_navigator node's command rate of the step (what ~/command_rate carries)
        self.nav_command = None
        # paper 5's LGU pair and paper 4's free-gyro samples of the step (None when not due)
        self.lgu = self.free_gyro = None
        # the servo's last (t [s], φz [rad], φ̇z [rad/s]), what its ~/modulation carries
        self.modulation = None
        # the servo's (stamp [ns], φz, φ̇z) of its next gyro step, what its ~/modulation_next carries
        self.modulation_next = None
        # paper 3's DTG pickoffs of the step (lower θ_x, θ_y, upper θ_x, θ_y) [rad] (:mod:`.dtg_stages`)
        self.dtg = None
        # the DTG servo's torquer currents (x_s, y_s, z_s) [A] of its last step (what its ~/torquer_current
        # carries); the sensors of the next step integrate the gyros under them
        self.torquer_current = None


def truth_stage(plant: str, position_every: int = 0, site=None, name: str = "vehicle_dynamics"
                ) -> Callable[[Bus], None]:
    """``vehicle_dynamics``'s messages of the step's truth, when the run is recorded (the host's
    true position every ``position_every`` steps, at ``site``, as the node's
    ``position_truth_every_steps``); the engine steps the vehicle itself."""

    def stage(bus: Bus) -> None:
        if bus.record is not None:
            due = position_every and bus.k % position_every == 0
            bus.record(name, truth_messages(bus.t_ns, bus.truth, plant, site if due else None))
    return stage


def joint_sample(bus: Bus, topic: str, every: int, joint: str) -> tuple[float, float | None] | None:
    """(position, velocity) of ``joint`` in the step's sample of ``topic`` (the resolvers, or
    the true joint states every ``every`` steps), as a node reads it from the JointState;
    None when the step has no sample or the sample lacks the joint."""
    if topic == "/platform/resolvers":
        s = bus.resolvers
        if s is None or joint not in s.names:
            return None
        i = s.names.index(joint)
        return s.angles[i], (s.rates[i] if i < len(s.rates) else None)
    tr = bus.truth
    if bus.k % every or joint not in tr.joint_names:
        return None
    i = tr.joint_names.index(joint)
    return tr.joint_position[i], (tr.joint_velocity[i] if i < len(tr.joint_velocity) else None)


def sensor_stage(values: dict[str, Any], name: str = "sensor_models") -> Callable[[Bus], None]:
    """``sensor_models``: the suite's samples of step k from the vehicle's truth."""
    return suite_stage(SensorSuite(SensorSuiteConfig.from_values(values)), name,
                       values.get("free_gyro_publish_velocity", False))


#: The bus field of each sensor sample type.
_BUS_FIELD = {LguSample: "lgu", FreeGyroSample: "free_gyro", ResolverSample: "resolvers",
              PlatformImuSample: "platform_imu", GimbalGyroSample: "gyro", EncoderSample: "encoders", InsSample: "ins",
              DtgSample: "dtg"}


def suite_stage(suite: SensorSuite, name: str = "sensor_models",
                free_gyro_velocity: bool = False) -> Callable[[Bus], None]:
    """What ``sensor_models`` does with ``suite`` (the stage of :func:`sensor_stage`)."""
    cov = noise_covariances(suite.config)

    def stage(bus: Bus) -> None:
        truth = bus.truth
        # sensor_models reads the host attitude from the Imu quaternion (truth_from_group)
        truth = truth._replace(euler=euler321_from_quat(tuple(truth.quat_nb)))
        bus.gyro = bus.encoders = bus.ins = bus.resolvers = bus.platform_imu = bus.lgu = bus.free_gyro = None
        bus.dtg = None
        record = bus.record
        for s in suite.update(truth, bus.torquer_current):
            if record is not None:
                record(name, sensor_messages(bus.t_ns, s, cov, free_gyro_velocity))
            # the pickoffs as the servo reads them from the JointState: (lower x, y, upper x, y) [rad]
            setattr(bus, _BUS_FIELD[type(s)], s.angles if type(s) is DtgSample else s)
            if type(s) is InsSample:
                # published as a quaternion; readers turn it back into Euler angles
                bus.ins_euler = euler321_from_quat(quat_canonical(quat_from_euler321(*s.euler)))
    return stage


def gyro_bias_ekf_stage(values: dict[str, Any], name: str = "gyro_bias_ekf") -> Callable[[Bus], None]:
    """``gyro_bias_ekf``: the stage of :func:`ekf_stage` on the node's core."""
    return ekf_stage(EkfInput(GyroBiasEkf(GyroBiasEkfParams.from_values(values)), RateSync), name)


def ekf_stage(ekf: EkfInput, name: str = "gyro_bias_ekf") -> Callable[[Bus], None]:
    """What ``gyro_bias_ekf`` does with ``ekf``: INS (Euler angles from its quaternion), gyro
    and encoders of step k, encoders and INS before the gyro sample of the same stamp (the
    node's :class:`gimbal_kinematics.timing.sync.StampOrder`, :func:`gimbal_estimators.gyro_bias_ekf_stamp.feed_stamp`,
    which a bag's replay shares); leaves the bias estimate on the bus when an update
    completed, and the whole output (bias, σ, attitude) in ``bus.ekf``. Recorded: each
    output the core completed, with its bias-corrected rate at that moment (the node's ``_after``)."""
    publish = [None]

    def record(out) -> None:
        publish[0](name, ekf_messages(int(round(out.t * 1e9)), out.bias, out.bias_sigma, out.quat_nm,
                                      out.attitude_cov, ekf.corrected_rate))

    def stage(bus: Bus) -> None:
        enc, ins, gyro = bus.encoders, bus.ins, bus.gyro
        publish[0] = bus.record
        out = feed_stamp(ekf, bus.t, None if enc is None else (enc.angles, enc.rates),
                         None if ins is None else (bus.ins_euler, ins.omega_b),
                         None if gyro is None else (gyro.q_m, gyro.r_m), None if bus.record is None else record)
        bus.bias = None if out is None else tuple(out.bias.tolist())
        bus.ekf = out
    return stage


def operator_stage(values: dict[str, Any], name: str = "operator") -> Callable[[Bus], None]:
    """``operator``: at each of its steps (``rate_hz``) the command and pointing error from the
    true sight attitude of the step, or its scripted step (``script: step``) (the node's
    ``_on_truth``); None on the bus between."""
    core = operator_core(values)
    rate = values["sim_rate_hz"]
    every = steps_per_sample(values, "rate_hz")

    def stage(bus: Bus) -> None:
        if bus.k % every:
            bus.operator = bus.operator_error = None
            return
        stamp = step_stamp_ns(bus.k, rate)
        q, r = core.step(stamp, bus.truth.quat_nm)
        bus.operator = (stamp, q, r)
        bus.operator_error = core.pointing_error()
        if bus.record is not None:
            bus.record(name, operator_messages(stamp, q, r, bus.operator_error))
    return stage


def geo_pointer_stage(values: dict[str, Any], name: str = "geo_pointer") -> Callable[[Bus], None]:
    """``geo_pointer``: at each step with an EKF output (an INS step), the pointer's core on
    the EKF's attitude, the INS attitude as its quaternion carries it and the turret angle;
    leaves the LOS rate command in ``bus.operator`` for the controller (the last one again
    when the EKF has no attitude yet, as the node holds it), None between INS steps."""
    core = GeoPointer(GeoPointerParams.from_values(values))
    rate = values["sim_rate_hz"]
    topic = values["operator_topic"]
    held = [(0.0, 0.0)]
    aim: list = [None]  # the LOS of the step's pointer output (what ~/aim carries)

    def stage(bus: Bus) -> None:
        bus.geo_budget = None
        if bus.ekf is None or bus.ins is None:
            bus.operator = None
            return
        stamp = step_stamp_ns(bus.k, rate)
        if bus.ekf.quat_nm is not None and bus.encoders is not None:
            q_nb = quat_canonical(quat_from_euler321(*bus.ins.euler))
            out = core.step(tuple(bus.ekf.quat_nm), quat_to_dcm(q_nb), bus.encoders.angles[0])
            held[0], aim[0] = out.command, tuple(out.aim_n)
            bus.geo_budget = (stamp, out.budget.total_rad, *out.budget.principal_sigmas_rad)
        bus.operator = (stamp, *held[0])
        if bus.record is not None:
            budget = None if bus.geo_budget is None else bus.geo_budget[1:]
            bus.record(name, geo_pointer_messages(stamp, topic, held[0], budget, None if budget is None else aim[0]))
    return stage


def los_rate_controller_stage(values: dict[str, Any], name: str = "los_rate_controller") -> Callable[[Bus], None]:
    """``los_rate_controller``: the stage of :func:`controller_stage` on the node's core, with
    the LOS-hold outer loop in ``mode: los_hold`` and the operator's shaper when
    ``operator_topic`` is set."""
    hold = LosHold(LosHoldParams.from_values(values)) if values["mode"] == "los_hold" else None
    operator = OperatorCommand(OperatorCommandParams.from_values(values)) if values["operator_topic"] else None
    core = LosRateController(LosRateControllerParams.from_values(values), operator=operator)
    return controller_stage(core, values["sim_rate_hz"], hold, name=name)


def controller_stage(core: LosRateController, rate_hz: float, hold: LosHold | None = None,
                     sample_time: Callable[[Bus], float] | None = None,
                     name: str = "los_rate_controller") -> Callable[[Bus], None]:
    """What ``los_rate_controller`` does with ``core``: the torque command of step k from the
    gyro, encoders and the latest INS rates (held between INS samples, as the node does),
    and the bias estimate of the step when the EKF made one (the node waits for it at INS
    steps). With ``hold`` (``mode: los_hold``) the EKF's attitude of the step (``bus.ekf``,
    what ``~/attitude`` carries) drives the outer loop, after the bias is taken, as in the
    node's ``_step``. The operator's command of the step (``bus.operator``) goes to
    the core's shaper, whose output joins the reference (the node's waited-for ``op``). The
    controller's sample time is the node's k / rate, or
    ``sample_time(bus)`` [s] when given (``experiments.closed_loop`` keeps the vehicle's k·dt,
    which its recorded figures were computed with; the two differ in the last bits)."""
    ins_rates: list[tuple[float, float, float] | None] = [None]
    # the operator's stamp rule, as the node chooses it (gimbal_kinematics.timing.control_policy)
    commands = CommandStamps(core.operator.params.timeout_s, CLOCK_JUMP_S) if core.operator is not None else None
    if sample_time is None:
        def sample_time(bus: Bus) -> float:
            return bus.k / rate_hz

    def stage(bus: Bus) -> None:
        if bus.ins is not None:
            ins_rates[0] = bus.ins.omega_b
        if bus.bias is not None:
            core.set_bias_estimate(bus.t, bus.bias)
            if hold is not None:
                core.set_rate_command(*hold.update(bus.t, tuple(bus.ekf.quat_nm), core.bias_estimate_qr))
        if bus.operator is not None and commands is not None:
            commands.add(bus.operator[0], core.operator.check_rate(*bus.operator[1:]).output)
        enc = bus.encoders
        if bus.gyro is None or enc is None or ins_rates[0] is None:
            bus.command = core.command
        else:
            bus.command = core.step(sample_time(bus), (bus.gyro.q_m, bus.gyro.r_m), enc.angles, enc.rates,
                                    ins_rates[0],
                                    core.reference(None if commands is None else commands.step(step_stamp_ns(bus.k, rate_hz))))
        if bus.record is not None:
            bus.record(name, torque_command_messages(bus.t_ns, bus.command))
    return stage


def timed(stage: Callable[[Bus], None]) -> tuple[Callable[[Bus], None], list[float]]:
    """``stage`` with its wall time summed into the returned one-element list [s]."""
    spent = [0.0]
    clock = time.perf_counter

    def timed_stage(bus: Bus) -> None:
        t0 = clock()
        stage(bus)
        spent[0] += clock() - t0
    return timed_stage, spent


def encoder_fusion_stage(values: dict[str, Any], name: str = "encoder_fusion_controller") -> Callable[[Bus], None]:
    """``encoder_fusion_controller`` (lockstep): a tick on each step's gyro sample, at the
    step's stamp in seconds, with the newest encoder angles (ψm, θm) and host body rates held
    to the step's time, as the node's input policy gives them (the command held until both
    came); the step's command, the fed-back velocity and, after a Kalman update, the drift
    corrections recorded (``gimbal_control.wire.encoder_fusion_messages``)."""
    core = EncoderFusionController(EncoderFusionParams.from_values(values))
    every_enc, every_base = steps_per_sample(values, "encoder_rate_hz"), steps_per_sample(values, "base_rate_hz")
    held: list = [None, None, 0]  # (ψm, θm), host body rates, Kalman updates seen

    def stage(bus: Bus) -> None:
        t = bus.t
        if bus.encoders is not None and bus.k % every_enc == 0:
            names = bus.encoders.names
            held[0] = tuple(bus.encoders.angles[names.index(j)] for j in GIMBAL_ENCODER_JOINTS[1:])
        if bus.k % every_base == 0:
            held[1] = tuple(bus.truth.omega_ib_b)
        feedback = None
        if bus.gyro is None or held[0] is None or held[1] is None:
            tau = core.command
        else:
            out = core.tick(t, bus.gyro.q_m, bus.gyro.r_m, (t, held[1]), (t, *held[0]))
            if out is None or out.held:
                tau = core.command
            else:
                tau = (out.torque_azimuth, out.torque_elevation)
                feedback = (out.velocity_q, out.velocity_r)
        bus.command = tau
        correction = None
        if core.kf_q.updates != held[2]:
            held[2] = core.kf_q.updates
            correction = core.corrections
        if bus.record is not None:
            bus.record(name, encoder_fusion_messages(bus.t_ns, tau, feedback, correction))
    return stage
