"""One stamp's samples into the gyro-bias EKF core, in the ``gyro_bias_ekf`` node's order.

Within one stamp the node takes the encoders and the INS before the gyro sample
(:class:`gimbal_kinematics.sync.StampOrder`), so that the gyro's integration finds the
encoder angles and INS rates of its own stamp. :func:`feed_stamp` is that step, shared by
the engine's ``gyro_bias_ekf`` stage (``gimbal_sim.core.core_stages.ekf_stage``) and by the
replay of a recorded bag into the core (``gimbal_sim.bag.ekf_replay``): the engine and a
replay feed the core through the same code.
"""
from __future__ import annotations

from typing import Callable, Sequence

from .gyro_bias_ekf import EkfOutput, GyroBiasEkf

#: (ψt, ψm, θm) [rad], (rates [rad/s] or None)
Encoders = tuple[Sequence[float], Sequence[float] | None]
#: Euler (φ, θ, ψ) [rad] as a reader of the INS quaternion gets them, body rates (p, q, r) [rad/s]
Ins = tuple[Sequence[float], Sequence[float]]


def feed_stamp(ekf: GyroBiasEkf, t: float, encoders: Encoders | None = None, ins: Ins | None = None,
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


def _emit(ekf: GyroBiasEkf, emit: Callable[[EkfOutput], None] | None) -> None:
    outputs = ekf.take_outputs()
    if emit is not None:
        for out in outputs:
            emit(out)
