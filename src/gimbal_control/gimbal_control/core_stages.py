"""Pure-core stages of gimbal_control's nodes for :mod:`gimbal_sim.core_loop` (no ROS).

A stage is built from the node's parameter values and called once per lockstep step with
the loop's bus (what the step's messages carry); it does what the node does with them.
"""
from __future__ import annotations

from typing import Any, Callable

from .los_rate_controller import LosRateController, LosRateControllerParams


def los_rate_controller_stage(values: dict[str, Any]) -> Callable[[Any], None]:
    """``los_rate_controller``: the torque command of step k from the gyro, encoders and the
    latest INS rates (held between INS samples, as the node does), and the bias estimate of
    the step when the EKF made one (the node waits for it at INS steps)."""
    if values["mode"] != "rate":
        # its outer loop needs the EKF attitude, which the loop's bus does not carry
        raise ValueError(f"no core stage for los_rate_controller mode {values['mode']!r} (only 'rate')")
    core = LosRateController(LosRateControllerParams.from_values(values))
    rate = values["sim_rate_hz"]
    ins_rates: list[tuple[float, float, float] | None] = [None]

    def stage(bus) -> None:
        if bus.ins is not None:
            ins_rates[0] = bus.ins.omega_b
        if bus.bias is not None:
            core.set_bias_estimate(bus.t, bus.bias)
        enc = bus.encoders
        if bus.gyro is None or enc is None or ins_rates[0] is None:
            bus.command = core.command
            return
        bus.command = core.step(bus.k / rate, (bus.gyro.q_m, bus.gyro.r_m), enc.angles, enc.rates, ins_rates[0])
    return stage
