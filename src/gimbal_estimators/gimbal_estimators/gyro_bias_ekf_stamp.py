"""One stamp's samples into the gyro-bias EKF core, in the ``gyro_bias_ekf`` node's order.

Within one stamp the node takes the encoders and the INS before the gyro sample
(:class:`gimbal_kinematics.timing.sync.StampOrder`), so that the gyro's integration finds the
encoder angles and INS rates of its own stamp. :func:`feed_stamp` is that step, shared by
the engine's ``gyro_bias_ekf`` stage (``gimbal_sim.core.core_stages.ekf_stage``) and by the
replay of a recorded bag into the core (``gimbal_sim.bag.ekf_replay``): the engine and a
replay feed the core through the same code.
"""
from __future__ import annotations

import math
from typing import Callable, Sequence

from .gyro_bias_ekf import EkfOutput, Fed, GyroBiasEkf

#: (ψt, ψm, θm) [rad], (rates [rad/s] or None)
Encoders = tuple[Sequence[float], Sequence[float] | None]
#: Euler (φ, θ, ψ) [rad] as a reader of the INS quaternion gets them, body rates (p, q, r) [rad/s]
Ins = tuple[Sequence[float], Sequence[float]]


class EkfInput:
    """The three raw streams of :class:`.gyro_bias_ekf.GyroBiasEkf` (``core``), checked, then
    grouped by a ``grouping`` (:class:`gimbal_kinematics.timing.sync.RateSync`) built on the core's
    sync wait, gyro gap, ``integrate`` and ``fuse``; each call returns the core's
    :class:`.gyro_bias_ekf.Fed`. Reading any other attribute reads the core's (its estimate,
    counters, outputs)."""

    def __init__(self, core: GyroBiasEkf, grouping: Callable) -> None:
        p = core.params
        self.core = core
        self.sync = grouping(p.max_sync_wait_s, p.max_gyro_gap_s, core.integrate, core.fuse)

    def __getattr__(self, name: str):
        if name == "core":  # not set yet (e.g. while unpickling): no recursion
            raise AttributeError(name)
        return getattr(self.core, name)

    def on_gyro(self, t: float, q_m: float, r_m: float) -> Fed:
        """Gimbal gyro sample at ``t`` [s]: rates q_m, r_m [rad/s] about m-y, m-z."""
        s = self.core.check_gyro(t, q_m, r_m)
        return self.core.rejected() if s is None else self.core.fed(self.sync.gyro(*s))

    def on_encoders(self, t: float, angles: Sequence[float], rates: Sequence[float] | None = None) -> Fed:
        """Encoder sample at ``t`` [s]: angles (ψt, ψm, θm) [rad] (``rates`` checked, unused)."""
        s = self.core.check_encoders(t, angles, rates)
        return self.core.rejected() if s is None else self.core.fed(self.sync.angles(*s))

    def on_ins(self, t: float, euler: Sequence[float] | None, omega_b: Sequence[float]) -> Fed:
        """INS sample at ``t`` [s]: Euler (φ, θ, ψ) [rad] (None: unavailable, the filter
        propagates but has nothing to fuse, ``why`` says so) and body rates (p, q, r) [rad/s]."""
        s = self.core.check_ins(t, euler, omega_b)
        if s is None:
            return self.core.rejected()
        return self.core.fed(self.sync.reference(*s), None if s[1] is not None else "no attitude to fuse")

    def reset(self, reason: str, t: float = math.nan) -> None:
        """Forget everything, queued samples included (e.g. on a clock jump back); log ``reason``."""
        self.core.reset(reason, t)
        self.sync.clear()


def feed_stamp(ekf: EkfInput, t: float, encoders: Encoders | None = None, ins: Ins | None = None,
               gyro: tuple[float, float] | None = None,
               emit: Callable[[EkfOutput], None] | None = None) -> EkfOutput | None:
    """Give ``ekf`` the samples of stamp ``t`` [s] that are present (None: not due), the
    encoders, then the INS, then the gyro's (q_m, r_m) [rad/s]; after each call, every output
    it completed goes to ``emit`` (taken from the core in order, so that ``emit`` sees the
    core's state right after the call, e.g. its bias-corrected rate). Returns the last
    output a call completed (None when none did)."""
    out = None
    if encoders is not None:
        out = ekf.on_encoders(t, *encoders).output or out
        _emit(ekf, emit)
    if ins is not None:
        out = ekf.on_ins(t, *ins).output or out
        _emit(ekf, emit)
    if gyro is not None:
        out = ekf.on_gyro(t, *gyro).output or out
        _emit(ekf, emit)
    return out


def _emit(ekf: EkfInput, emit: Callable[[EkfOutput], None] | None) -> None:
    outputs = ekf.take_outputs()
    if emit is not None:
        for out in outputs:
            emit(out)
