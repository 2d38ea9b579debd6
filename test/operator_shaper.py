"""The operator command as the LOS rate controller's node and the engine run it: the
timing room's :class:`~gimbal_kinematics.timing.control_policy.CommandStamps` judges the
stamps, :class:`gimbal_control.operator_command.OperatorCommand` the values and the
shaping. One object with the message-level calls, for the shaper's tests."""
from __future__ import annotations

from gimbal_control.los_rate_controller_params import CLOCK_JUMP_S
from gimbal_control.operator_command import OperatorCommand, OperatorCommandParams
from gimbal_kinematics.timing.control_policy import CommandStamps


class Shaper:
    """A shaper and its node's command policy; the shaper's attributes read through."""

    def __init__(self, params: OperatorCommandParams | None = None) -> None:
        self.core = OperatorCommand(params)
        self.stamps = CommandStamps(self.core.params.timeout_s, CLOCK_JUMP_S)

    def set_rate(self, stamp_ns: int, q: float, r: float) -> bool:
        return self.stamps.add(stamp_ns, self.core.check_rate(q, r).output)

    def set_joy(self, stamp_ns: int, axes) -> bool:
        return self.stamps.add(stamp_ns, self.core.check_joy(axes).output)

    def step(self, stamp_ns: int) -> tuple[float, float]:
        return self.core.step(self.stamps.step(stamp_ns))

    def counters(self) -> dict:
        return {**self.stamps.counters(), **self.core.counters()}

    def __getattr__(self, name: str):
        return getattr(self.core, name)
