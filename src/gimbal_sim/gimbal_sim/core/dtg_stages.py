"""Paper 3's platform on its two DTGs, as engine stages (:func:`.core_loop.run_stages`):
the gyros (world) and the servo closed on their pickoffs (processor). The paper runner's
stages (:func:`dtg_stage`, :func:`dtg_servo_stage`, on Python objects) and the scenario
node's (:func:`dtg_servo_node_stage`: ``platform_servo`` with ``gyro_source: dtg``, whose
gyros are ``sensor_models``' ``dtg``, :func:`.core_stages.sensor_stage`).

Per step k: :func:`dtg_stage` integrates the gyros over the step k−1 → k, through the
platform's exact inertial rotation (from the plant's attitudes of k−1 and k and the earth's
rotation over the step) under the torquer currents the servo commanded at k−1 (held over the
step, as the torquing electronics hold them), and puts the pickoffs of t_k on ``bus.dtg``;
:func:`dtg_servo_stage` then ticks the servo on them and the step's resolvers.
"""
from __future__ import annotations

from typing import Callable

from gimbal_control.dtg_servo import DtgPlatformServo
from gimbal_control.platform_servo import ServoCommand
from gimbal_kinematics.params.table import steps_per_sample

from .core_stages import Bus
from ..world.sensors.dtg import DtgOnPlatform, DtgPair


def dtg_stage(pair: DtgPair, servo: DtgPlatformServo, omega_in_n, dt: float) -> Callable[[Bus], None]:
    """The DTG pair's pickoffs of the step on ``bus.dtg`` (zero tilt at k = 0), under the
    servo's currents of the step before (:class:`..world.sensors.dtg.DtgOnPlatform`)."""
    gyros = DtgOnPlatform(pair, omega_in_n, dt)

    def stage(bus: Bus) -> None:
        bus.dtg = gyros.update(bus.truth.quat_nm, bus.truth.specific_force_m, servo.torquer_current)
    return stage


def dtg_servo_stage(servo: DtgPlatformServo) -> Callable[[Bus], None]:
    """The servo on the step's resolvers and pickoffs; ``bus.command`` its voltages,
    ``bus.modulation`` its last (t, φz, φ̇z)."""

    def stage(bus: Bus) -> None:
        if bus.resolvers is not None:
            servo.on_resolvers(bus.t, bus.resolvers.angles)
        if bus.dtg is not None:
            out = servo.on_pickoffs(bus.t, bus.dtg[:2], bus.dtg[2:])
            if out is not None:
                bus.modulation = (out.t, out.phi_z, out.phi_z_rate)
        bus.command = servo.command_voltages
    return stage


def dtg_servo_tick(servo: DtgPlatformServo, values: dict) -> Callable[[Bus], ServoCommand | None]:
    """The ``platform_servo`` node's tick with ``gyro_source: dtg`` (lockstep): on the steps its
    ``imu_rate_hz`` reads the pickoffs, the servo on the step's pickoffs at the node's step
    time k / rate; None on the others."""
    read_every = steps_per_sample(values, "imu_rate_hz")
    rate = values["sim_rate_hz"]

    def tick(bus: Bus) -> ServoCommand | None:
        if bus.dtg is None or bus.k % read_every != 0:
            return None
        return servo.on_pickoffs(bus.k / rate, bus.dtg[:2], bus.dtg[2:])
    return tick
