"""Pure-core stages of paper 3's platform INS for :func:`.core_loop.run_stages` (no ROS).

The lockstep order of one step k (stamp t_k): the platform's sensors sample the truth of
step k (resolvers, then the stable element's IMU, as ``sensor_models`` publishes them), the
navigator integrates the step's specific force resolved through the step's azimuth angle
and leaves its command rate ω_c^n on the bus, then the servo takes that command (held
over k → k+1, the navigator's zero-order hold), the step's resolvers and gyros, and makes
the motor voltages the plant holds over k → k+1. The servo's trapezoid of the held commands
then integrates the hand-off torquing pulse to exactly its angle (the pulse in N samples
covers N intervals). On steps without a new sample each core keeps what it has.

Azimuth angle: the resolver's θ_a of the step, or (navigator ``azimuth_source: servo``) the
servo's rotation angle φz, which the servo makes after the navigator in a step: its last
(φz, φ̇z) (``bus.modulation``, what the node's ``~/modulation`` carries) extrapolated to the
step, as the node extrapolates its newest joint sample; exact except across a reversal
(≤ φ̇z Δt, 11″ at 400 Hz).

Multi-rate (``every`` > 1): the navigator steps on every ``every``-th IMU sample with the mean
specific force of the samples since its last step (the IMU's velocity increment over the
interval, so the accelerometer noise per navigation interval is that of all the samples),
while the servo and the plant run at every sample. The servo holds the navigator's command
between its steps (its ``command_max_age_s`` must cover ``every`` samples).
"""
from __future__ import annotations

from typing import Callable

from gimbal_control.platform_servo import PlatformServo
from gimbal_estimators.platform_navigator import PlatformNavigator
from gimbal_kinematics.stamps import step_stamp_ns

from .core_stages import Bus
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
            bus.nav = navigator.step(step_stamp_ns(bus.k, rate_hz), imu.specific_force, theta_a[0])
            return
        f = imu.specific_force
        acc[0] += f[0]
        acc[1] += f[1]
        acc[2] += f[2]
        acc[3] += 1
        if navigator.accepted == 0 or acc[3] >= every:
            n = acc[3]
            bus.nav = navigator.step(step_stamp_ns(bus.k, rate_hz), (acc[0] / n, acc[1] / n, acc[2] / n), theta_a[0])
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
            out = servo.on_gyro(bus.t, bus.platform_imu.omega)
            if out is not None:
                bus.modulation = (out.t, out.phi_z, out.phi_z_rate)
        bus.command = servo.command_voltages
    return stage
