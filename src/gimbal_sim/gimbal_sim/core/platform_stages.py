"""Pure-core stages of paper 3's platform INS for :func:`.core_loop.run_stages` (no ROS).

Two sets of stages: the paper runners' (:func:`servo_stage`, :func:`navigator_stage`, with
their multi-rate navigator), and the scenario nodes' (:func:`platform_servo_node_stage`,
:func:`platform_navigator_node_stage`), which do what the nodes do in lockstep and record
their messages.

The lockstep order of one step k (stamp t_k): the platform's sensors sample the truth of
step k (resolvers, then the stable element's IMU, as ``sensor_models`` publishes them), the
navigator integrates the step's specific force resolved through the step's azimuth angle
and leaves its command rate ω_c^n on the bus, then the servo takes that command (held
over k → k+1, the navigator's zero-order hold), the step's resolvers and gyros, and makes
the motor voltages the plant holds over k → k+1. The servo's trapezoid of the held commands
then integrates the hand-off torquing pulse to exactly its angle (the pulse in N samples
covers N intervals). On steps without a new sample each core keeps what it has.

Azimuth angle: the resolver's θ_a of the step, or (navigator ``azimuth_source: servo``) the
servo's rotation angle φz, which the servo makes after the navigator in a step. The paper
stages take its last (φz, φ̇z) (``bus.modulation``, what the node's ``~/modulation``
carries) extrapolated to the step, as the node extrapolates its newest joint sample; exact
except across a reversal (≤ φ̇z Δt, 11″ at 400 Hz). The node stages do what the lockstep
graph does: the servo (``modulation_next: true``) makes at each gyro step the φz of its next
one from its schedule, stamped with it (``bus.modulation_next``, its ``~/modulation_next``),
and the navigator takes that at the step it is stamped for (exact; none at the first step,
whose sample is refused, counted).

Multi-rate (``every`` > 1): the navigator steps on every ``every``-th IMU sample with the mean
specific force of the samples since its last step (the IMU's velocity increment over the
interval, so the accelerometer noise per navigation interval is that of all the samples),
while the servo and the plant run at every sample. The servo holds the navigator's command
between its steps (its ``command_max_age_s`` must cover ``every`` samples).
"""
from __future__ import annotations

from typing import Callable

from gimbal_control.dtg_servo import dtg_servo_from_values
from gimbal_control.platform_servo import PlatformServo, PlatformServoParams, ServoCommand
from gimbal_control.wire import modulation_next, platform_servo_messages
from gimbal_estimators.navigator_odometry import NavigatorOdometry, OdometryModel
from gimbal_estimators.platform_navigator import PlatformNavigator
from gimbal_estimators.platform_navigator_params import PlatformNavigatorParams
from gimbal_estimators.wire import navigator_messages
from gimbal_kinematics.params.table import steps_per_sample
from gimbal_kinematics.ros.wire import UNMEASURED_VARIANCE
from gimbal_kinematics.timing.stamps import step_stamp_ns

from .core_stages import Bus, joint_sample
from .dtg_stages import dtg_servo_tick
from ..world.sensor_suite import PlatformImuSample, ResolverSample, SensorSuite


def platform_sensor_stage(suite: SensorSuite) -> Callable[[Bus], None]:
    """``sensor_models`` with ``platform_imu`` and ``resolvers``: the step's samples (None
    when not due) on ``bus.resolvers`` and ``bus.platform_imu``."""

    def stage(bus: Bus) -> None:
        bus.resolvers = bus.platform_imu = None
        for s in suite.update(bus.truth):
            if type(s) is ResolverSample:
                bus.resolvers = s
            elif type(s) is PlatformImuSample:
                bus.platform_imu = s
    return stage


def navigator_stage(navigator: PlatformNavigator, rate_hz: float, every: int = 1) -> Callable[[Bus], None]:
    """``platform_navigator``: one step on every ``every``-th IMU sample (the mean specific
    force since the last step, module docstring) with the azimuth angle of its
    ``azimuth_source`` (None until one came); its output (or None) on ``bus.nav``."""
    if int(every) != every or every < 1:
        raise ValueError(f"every must be an integer >= 1, got {every!r}")
    from_servo = navigator.params.azimuth_source == "servo"
    theta_a: list[float | None] = [None]
    acc = [0.0, 0.0, 0.0, 0]  # sum of f (x, y, z), samples since the last step

    def stage(bus: Bus) -> None:
        if from_servo:
            mod = bus.modulation  # the servo's of an earlier step: it runs after this stage
            theta_a[0] = None if mod is None else mod[1] + mod[2] * (bus.t - mod[0])
        elif bus.resolvers is not None:
            theta_a[0] = bus.resolvers.angles[0]
        bus.nav = None
        imu = bus.platform_imu
        if imu is None:
            return
        if every == 1:
            bus.nav = navigator.step(step_stamp_ns(bus.k, rate_hz), imu.specific_force, theta_a[0]).output
            return
        f = imu.specific_force
        acc[0] += f[0]
        acc[1] += f[1]
        acc[2] += f[2]
        acc[3] += 1
        if navigator.accepted == 0 or acc[3] >= every:
            n = acc[3]
            bus.nav = navigator.step(step_stamp_ns(bus.k, rate_hz), (acc[0] / n, acc[1] / n, acc[2] / n),
                                     theta_a[0]).output
            acc[:] = [0.0, 0.0, 0.0, 0]
    return stage


def servo_stage(servo: PlatformServo) -> Callable[[Bus], None]:
    """``platform_servo``: the navigator's command of the step (when there is one), then the
    resolvers and the gyro tick; ``bus.command`` is the servo's latest voltages (held
    between its ticks, as the node's last published command) and ``bus.modulation`` its
    last (t, φz, φ̇z) (what ``~/modulation`` carries)."""

    def stage(bus: Bus) -> None:
        if bus.nav is not None:
            servo.on_command_rate(bus.t, bus.nav.command_rate_n)
        if bus.resolvers is not None:
            servo.on_resolvers(bus.t, bus.resolvers.angles)
        if bus.platform_imu is not None:
            out = servo.on_gyro(bus.t, bus.platform_imu.omega).output
            if out is not None:
                bus.modulation = (out.t, out.phi_z, out.phi_z_rate)
        bus.command = servo.command_voltages
    return stage


def platform_servo_node_stage(values: dict, name: str = "platform_servo") -> Callable[[Bus], None]:
    """The ``platform_servo`` node of a scenario (lockstep): per step the resolvers, the
    navigator's command rate of the step (``command_source: navigator``), then the tick on
    the step's gyro sample (``gyro_source: dtg``: on its DTG pickoffs,
    :func:`.dtg_stages.dtg_servo_tick`, its torquer currents on ``bus.torquer_current``, which
    the next step's gyros are held under); the step's voltages on ``bus.command`` (held
    between ticks) and every ``diagnostics_every_steps``-th tick's control error and
    modulation, as the node publishes them (``gimbal_control.wire.platform_servo_messages``);
    with ``modulation_next``, at each gyro step φz of the next on ``bus.modulation_next``."""
    dtg = values["gyro_source"] == "dtg"
    servo = dtg_servo_from_values(values) if dtg else PlatformServo(PlatformServoParams.from_values(values))
    tick = dtg_servo_tick(servo, values) if dtg else _gyro_tick(servo, values["sim_rate_hz"])
    follows = values["command_source"] == "navigator"
    every = values["diagnostics_every_steps"]
    rate, imu_every, ahead = values["sim_rate_hz"], steps_per_sample(values, "imu_rate_hz"), values["modulation_next"]
    ticks = [0]

    def stage(bus: Bus) -> None:
        if bus.resolvers is not None:
            servo.on_resolvers(bus.t, bus.resolvers.angles)
        if follows and bus.nav_command is not None:
            servo.on_command_rate(bus.t, bus.nav_command)
        out = tick(bus)
        volts = out.voltages if out is not None else servo.command_voltages
        bus.command = volts
        torquer = servo.torquer_current if dtg else None
        if dtg:
            bus.torquer_current = torquer
        if out is not None:
            ticks[0] += 1
            bus.modulation = (out.t, out.phi_z, out.phi_z_rate)
        nxt = modulation_next(servo, bus.k / rate, imu_every, rate) if ahead else None
        if nxt is not None:
            bus.modulation_next = nxt
        if bus.record is not None:
            due = out is not None and (ticks[0] - 1) % every == 0
            bus.record(name, platform_servo_messages(bus.t_ns, volts, out if due else None, torquer, nxt))
    return stage


def _gyro_tick(servo: PlatformServo, rate: float) -> Callable[[Bus], ServoCommand | None]:
    """The rate-gyro servo's tick on the step's platform IMU sample, at the node's step time k / rate."""

    def tick(bus: Bus) -> ServoCommand | None:
        if bus.platform_imu is None:
            return None
        return servo.on_gyro(bus.k / rate, bus.platform_imu.omega).output
    return tick


def platform_navigator_node_stage(values: dict, name: str = "platform_navigator") -> Callable[[Bus], None]:
    """The ``platform_navigator`` node of a scenario (lockstep): the newest azimuth joint
    sample (``joint_topic``: the resolvers or the true joint states; ``azimuth_source: servo``:
    the servo's φz of the step, made by its previous step, ``bus.modulation_next``)
    extrapolated with its rate to each accelerometer sample, no older than
    ``max_joint_age_s``; one navigator step per sample, its fix every ``fix_every_samples``
    accepted samples and its command rate (the last one again when a sample is refused) on
    ``bus.nav_command``, as the node publishes them (``gimbal_estimators.wire``)."""
    from_servo = values["azimuth_source"] == "servo"
    topic = values["joint_topic"]
    if not from_servo and topic not in ("/platform/resolvers", "/truth/platform/joint_states"):
        raise ValueError(f"parameter 'joint_topic' = {topic!r}: the engine reads the azimuth joint from "
                         f"/platform/resolvers or /truth/platform/joint_states")
    navigator = PlatformNavigator(PlatformNavigatorParams.from_values(values))
    frames = (values["odom_frame_id"], values["odom_child_frame_id"])
    odometry = NavigatorOdometry(OdometryModel.from_values(values, heading_known=not from_servo), UNMEASURED_VARIANCE)
    joint_name, max_age_ns, fix_every = values["azimuth_joint"], int(round(values["max_joint_age_s"] * 1e9)), \
        values["fix_every_samples"]
    joint: list = [None, None]  # (stamp ns, θ, rate) of the newest joint sample; the last command
    every_joint = steps_per_sample(values, "joint_rate_hz")

    def stage(bus: Bus) -> None:
        sample = _servo_sample(bus, every_joint) if from_servo else joint_sample(bus, topic, every_joint, joint_name)
        if sample is not None:
            joint[0] = (bus.t_ns, sample[0], sample[1] or 0.0)
        bus.nav_command = None
        imu = bus.platform_imu
        if imu is None:
            return
        theta = None
        if joint[0] is not None and 0 <= bus.t_ns - joint[0][0] <= max_age_ns:
            age = bus.t_ns - joint[0][0]
            theta = joint[0][1] + joint[0][2] * age * 1e-9 if age else joint[0][1]
        out = navigator.step(bus.t_ns, imu.specific_force, theta).output
        if out is not None:
            joint[1] = out.command_rate_n
        bus.nav_command = joint[1]
        fix = out if out is not None and (navigator.accepted - 1) % fix_every == 0 else None
        odom = None if fix is None else (*frames, *odometry(fix))  # the node's odometry, at each fix
        if bus.record is not None:
            bus.record(name, navigator_messages(bus.t_ns, fix, joint[1], odom))
    return stage


def _servo_sample(bus: Bus, every: int) -> tuple[float, float] | None:
    """(φz, φ̇z) of the servo's ``~/modulation_next`` stamped with the step (joint
    ``modulation_angle``), at the steps the navigator's joint grid samples; None otherwise."""
    nxt = bus.modulation_next
    if bus.k % every or nxt is None or nxt[0] != bus.t_ns:
        return None
    return nxt[1], nxt[2]
