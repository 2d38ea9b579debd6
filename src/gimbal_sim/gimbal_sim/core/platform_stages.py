"""Pure-core stages of paper 3's platform INS for :func:`.core_loop.run_stages` (no ROS).

The lockstep order of one step k (stamp t_k): the platform's sensors sample the truth of
step k (resolvers, then the stable element's IMU, as ``sensor_models`` publishes them), the
navigator integrates the step's specific force resolved through the step's azimuth resolver
angle and leaves its command rate ω_c^n on the bus, then the servo takes that command (held
over k → k+1, the navigator's zero-order hold), the step's resolvers and gyros, and makes
the motor voltages the plant holds over k → k+1. The servo's trapezoid of the held commands
then integrates the hand-off torquing pulse to exactly its angle (the pulse in N samples
covers N intervals). On steps without a new sample each core keeps what it has.
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


def navigator_stage(navigator: PlatformNavigator, rate_hz: float) -> Callable[[Bus], None]:
    """``platform_navigator``: one step on the IMU sample with the newest azimuth resolver
    angle (None until one came); its output (or None) on ``bus.nav``."""
    theta_a: list[float | None] = [None]

    def stage(bus: Bus) -> None:
        if bus.resolvers is not None:
            theta_a[0] = bus.resolvers.angles[0]
        bus.nav = None
        if bus.platform_imu is not None:
            bus.nav = navigator.step(step_stamp_ns(bus.k, rate_hz), bus.platform_imu.specific_force, theta_a[0])
    return stage


def servo_stage(servo: PlatformServo) -> Callable[[Bus], None]:
    """``platform_servo``: the navigator's command of the step (when there is one), then the
    resolvers and the gyro tick; ``bus.command`` is the servo's latest voltages (held
    between its ticks, as the node's last published command)."""

    def stage(bus: Bus) -> None:
        if bus.nav is not None:
            servo.on_command_rate(bus.t, bus.nav.command_rate_n)
        if bus.resolvers is not None:
            servo.on_resolvers(bus.t, bus.resolvers.angles)
        if bus.platform_imu is not None:
            servo.on_gyro(bus.t, bus.platform_imu.omega)
        bus.command = servo.command_voltages
    return stage
