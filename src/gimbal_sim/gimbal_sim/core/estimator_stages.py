"""Engine stages of the estimator nodes that observe the run without commanding it (paper 5's
flexure estimator, ...): each does what its node does in lockstep with the step's samples,
from the node's parameter values, and records what the node publishes through the node's own
serialisation function (``gimbal_estimators.wire``).
"""
from __future__ import annotations

from typing import Any, Callable

from gimbal_estimators.flexure_attitude_matching import AttitudeMatchingKf, AttitudeMatchingParams
from gimbal_estimators.flexure_kf import FlexureKf, FlexureKfParams
from gimbal_estimators.wire import flexure_messages

from .core_stages import Bus


def flexure_estimator_stage(values: dict[str, Any], name: str = "flexure_estimator") -> Callable[[Bus], None]:
    """``flexure_estimator`` (lockstep): each LGU pair of the step, LGU1 then LGU2, each
    increment as the node reads it from its message (the published rate Δα/Δt times the
    nominal interval 1/``lgu_rate_hz``); an estimate is recorded at most once per
    ``publish_period_s`` of stamps (0: each one)."""
    core = AttitudeMatchingKf(AttitudeMatchingParams.from_values(values)) if values["model"] == "original" \
        else FlexureKf(FlexureKfParams.from_values(values))
    period_s = 1.0 / values["lgu_rate_hz"]
    publish_ns = int(round(values["publish_period_s"] * 1e9))
    last_bin: list[int | None] = [None]

    def stage(bus: Bus) -> None:
        s = bus.lgu
        if s is None:
            return
        t = bus.t
        for feed, dalpha in ((core.on_lgu1, s.dalpha1), (core.on_lgu2, s.dalpha2)):
            # the message carries Δα/Δt (nodes.wire.sensor_messages); the node multiplies back by its Δt
            est = feed(t, tuple(d / s.dt * period_s for d in dalpha), period_s)
            if est is None or bus.record is None:
                continue
            if publish_ns > 0:
                b = bus.t_ns // publish_ns
                if b == last_bin[0]:
                    continue
                last_bin[0] = b
            bus.record(name, flexure_messages(bus.t_ns, est))
    return stage
