"""Paper 3's platform servo as the paper builds it: loops closed on the DTG pickoffs, the
command rate put into the gyros as torquer currents (§2.1.1, Fig. 2).

The processor computes the command ω_c (drift, earth rate, rotation rate: eq. 2, as
:class:`.platform_servo.PlatformServo` does, internal or from the navigator) and turns it into
the currents i = ω_c / S_nom that precess the gyros (S_nom the torquer's nominal scale factor,
:mod:`gimbal_kinematics.maths.dtg`): the lower gyro takes i_x, i_y, the upper i_z (and i_x on
its redundant axis). The pickoff angles Δθ that follow, the platform's tilt from the
precessed references, drive the motor loops through eq. 1
(:func:`.servo_kernels.servo_tick_pickoff`). There is no rate gyro, so each PID differences
its error through its derivative filter; the gains are placed in discrete time at the control
rate (:mod:`.platform_loop_design`).

Each tick's currents are held until the next tick (the torquing electronics' zero-order hold);
:attr:`DtgPlatformServo.torquer_current` is the last one, (x_s, y_s, z_s) [A].
"""
from __future__ import annotations

from dataclasses import replace
from typing import Sequence

from gimbal_kinematics.maths import dtg
from gimbal_kinematics.params.table import ParameterError

from . import servo_kernels as sk
from .platform_loop_design import DEFAULT_BANDWIDTH_HZ, DEFAULT_DERIVATIVE_TAU_S, design_all
from .platform_servo import PlatformServo, PlatformServoParams, ServoCommand


def dtg_servo_params(base: PlatformServoParams | None = None, rate_hz: float = 1000.0,
                     bandwidths_hz: dict | None = None,
                     derivative_tau_s: float = DEFAULT_DERIVATIVE_TAU_S) -> PlatformServoParams:
    """``base`` (default parameters if None) with the four loops' gains placed in discrete
    time at ``rate_hz`` (:func:`.platform_loop_design.design_all`)."""
    a, q, p, r = (d.pid for d in design_all(rate_hz, dict(DEFAULT_BANDWIDTH_HZ, **(bandwidths_hz or {})),
                                            derivative_tau_s))
    return replace(base or PlatformServoParams(), azimuth_pid=a, inner_roll_pid=q, pitch_pid=p, outer_roll_pid=r)


class DtgPlatformServo(PlatformServo):
    """The servo on DTG pickoffs with torquer currents out (module docstring).

    ``scale_deg_h_ma``: the torquer's nominal scale factor the processor uses [(°/h)/mA];
    ``max_current_ma``: the torquing electronics' range [mA].
    """

    def __init__(self, params: PlatformServoParams | None = None,
                 scale_deg_h_ma: float = dtg.PAPER_TORQUER_SCALE_DEG_H_MA, max_current_ma: float = 200.0) -> None:
        super().__init__(params if params is not None else dtg_servo_params())
        if not (scale_deg_h_ma > 0.0 and max_current_ma > 0.0):
            raise ValueError(f"scale_deg_h_ma and max_current_ma must be > 0, got {scale_deg_h_ma}, {max_current_ma}")
        self.scale_rad_s_a = scale_deg_h_ma * dtg.DEG_H_PER_MA
        self.max_current_a = max_current_ma * 1e-3
        self.torquer_current = (0.0, 0.0, 0.0)

    def on_pickoffs(self, t: float, lower: Sequence[float], upper: Sequence[float]) -> ServoCommand | None:
        """Control tick on the pickoffs (θ_x, θ_y) of the lower and upper gyros [rad] at
        ``t`` [s]; None until resolver angles have arrived. Sets :attr:`torquer_current`."""
        dx, dy, dz, _ = dtg.platform_deviation(lower, upper)
        result, ix, iy, iz = sk.servo_tick_pickoff(self.state, self.kernel_params, self._pid_state, self._pid_gains,
                                                   float(t), float(dx), float(dy), float(dz), self.scale_rad_s_a,
                                                   self.max_current_a)
        if result == sk.TICK_NONE:
            return None
        self.torquer_current = (ix, iy, iz)
        return self._output(t, result == sk.TICK_HELD)


def dtg_servo_from_values(v: dict) -> DtgPlatformServo:
    """The servo of a ``platform_servo`` node with ``gyro_source: dtg`` (its values, as
    declared in :mod:`.platform_servo_params`): :meth:`.PlatformServoParams.from_values` with
    the four loops placed in discrete time at ``imu_rate_hz`` (the pickoffs' read rate, the
    control rate) at the node's bandwidths, and the torquer's nominal scale factor and
    range; :class:`ParameterError` names the parameter refused."""
    base = PlatformServoParams.from_values(v)
    level = v["level_bandwidth_hz"]
    params = dtg_servo_params(base, v["imu_rate_hz"], {"a": v["azimuth_bandwidth_hz"], "q": level, "p": level,
                                                       "r": v["outer_roll_bandwidth_hz"]})
    for name in ("dtg_torquer_scale_deg_h_ma", "dtg_max_current_ma"):
        if not v[name] > 0.0:
            raise ParameterError(f"parameter {name!r} must be > 0, got {v[name]!r}")
    return DtgPlatformServo(params, scale_deg_h_ma=v["dtg_torquer_scale_deg_h_ma"],
                            max_current_ma=v["dtg_max_current_ma"])


def platform_servo_core(v: dict) -> PlatformServo:
    """The core of a ``platform_servo`` node from its values: on its gyro triad, or
    (``gyro_source: dtg``) on the DTGs (:func:`dtg_servo_from_values`); :class:`ParameterError`
    names the parameter refused."""
    return dtg_servo_from_values(v) if v["gyro_source"] == "dtg" else PlatformServo(PlatformServoParams.from_values(v))
