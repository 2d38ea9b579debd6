"""Engine stages of the estimator nodes that observe the run without commanding it (paper 5's
flexure estimator, ...): each does what its node does in lockstep with the step's samples,
from the node's parameter values, and records what the node publishes through the node's own
serialisation function (``gimbal_estimators.wire``).
"""
from __future__ import annotations

import math
from typing import Any, Callable

from gimbal_estimators.flexure_attitude_matching import AttitudeMatchingKf, AttitudeMatchingParams
from gimbal_estimators.flexure_kf import FlexureKf, FlexureKfParams
from gimbal_estimators.free_gyro_error_model import fix_predictor
from gimbal_estimators.free_gyro_positioning import FreeGyroPositioning, FreeGyroPositioningParams
from gimbal_estimators.rotation_alignment import RotationAlignmentParams, RotationAlignmentRls
from gimbal_estimators.wire import alignment_messages, flexure_messages, free_gyro_fix_messages
from gimbal_kinematics.maths.rotations import euler321_from_quat, euler321_to_quat
from gimbal_kinematics.params.table import steps_per_sample
from gimbal_kinematics.timing.sync import StampPairs

from .core_stages import Bus, joint_sample


def flexure_estimator_stage(values: dict[str, Any], name: str = "flexure_estimator") -> Callable[[Bus], None]:
    """``flexure_estimator`` (lockstep): each LGU pair of the step, LGU1 then LGU2, each
    increment as the node reads it from its message (the published rate Δα/Δt times the
    nominal interval 1/``lgu_rate_hz``); an estimate is recorded at most once per
    ``publish_period_s`` of stamps (0: each one)."""
    core = AttitudeMatchingKf(AttitudeMatchingParams.from_values(values)) if values["model"] == "original" \
        else FlexureKf(FlexureKfParams.from_values(values))
    pairs = StampPairs.feeding(core)
    period_s = 1.0 / values["lgu_rate_hz"]
    publish_ns = int(round(values["publish_period_s"] * 1e9))
    last_bin: list[int | None] = [None]

    def stage(bus: Bus) -> None:
        s = bus.lgu
        if s is None:
            return
        t = bus.t
        for unit, dalpha in enumerate((s.dalpha1, s.dalpha2)):
            # the message carries Δα/Δt (nodes.wire.sensor_messages); the node multiplies back by its Δt
            est = pairs.add(unit, t, tuple(d / s.dt * period_s for d in dalpha), period_s)
            if est is None or bus.record is None:
                continue
            if publish_ns > 0:
                b = bus.t_ns // publish_ns
                if b == last_bin[0]:
                    continue
                last_bin[0] = b
            bus.record(name, flexure_messages(bus.t_ns, est))
    return stage


def platform_alignment_stage(values: dict[str, Any], name: str = "platform_alignment") -> Callable[[Bus], None]:
    """``platform_alignment`` (lockstep): the step's azimuth joint sample (``joint_topic``: the
    resolvers or the true joint states; angle + ``base_heading_deg``) before its
    accelerometer sample, both at the step's time k / rate as the node's input policy gives
    them; each block's estimate recorded."""
    topic = values["joint_topic"]
    if topic not in ("/platform/resolvers", "/truth/platform/joint_states"):
        raise ValueError(f"parameter 'joint_topic' = {topic!r}: the engine reads the azimuth joint from "
                         f"/platform/resolvers or /truth/platform/joint_states")
    core = RotationAlignmentRls(RotationAlignmentParams.from_values(values))
    joint_name, heading, rate = values["azimuth_joint"], math.radians(values["base_heading_deg"]), values["sim_rate_hz"]
    every_joint = steps_per_sample(values, "joint_rate_hz")

    def stage(bus: Bus) -> None:
        t = bus.k / rate
        joint = joint_sample(bus, topic, every_joint, joint_name)
        if joint is not None:
            core.on_joint_state(t, joint[0] + heading, joint[1])
        if bus.platform_imu is None:
            return
        est = core.on_accel(t, bus.platform_imu.specific_force).output
        if est is not None and bus.record is not None:
            bus.record(name, alignment_messages(bus.t_ns, est))
    return stage


def free_gyro_positioning_stage(values: dict[str, Any], name: str = "free_gyro_positioning"
                                ) -> Callable[[Bus], None]:
    """``free_gyro_positioning`` (lockstep): each read-out of the free gyros (their spin axes,
    the vertical reference as its quaternion carries it, the triad's body rates, the
    velocity with ``velocity_input``), at its stamp in seconds, in the node's order; each
    window's fix recorded with the error model's prediction (``predict_error``) and the
    earth-rate heading when it is new, as the node publishes them."""
    core = FreeGyroPositioning(FreeGyroPositioningParams.from_values(values))
    predictor = fix_predictor(values, core.params)
    velocity = values["velocity_input"]
    er_t: list[float | None] = [None]

    def stage(bus: Bus) -> None:
        s = bus.free_gyro
        if s is None:
            return
        t = bus.t
        try:  # the node reads the level from the published quaternion (heading 0)
            roll, pitch, _ = euler321_from_quat(euler321_to_quat(s.roll, s.pitch, 0.0))
        except ValueError:
            roll = pitch = math.nan
        if velocity:
            core.on_velocity(t, tuple(s.velocity_n))
        core.on_level(t, roll, pitch)
        if predictor is not None:
            predictor.add_level(roll, pitch)
        core.on_body_rates(t, tuple(s.omega_ib_b))
        fix = core.on_spin_axes(t, tuple(s.spin_a_b), tuple(s.spin_b_b)).output
        if fix is None:
            return
        prediction = predictor.predict(fix.lat, fix.lon, fix.t, fix.heading, fix.n_samples) \
            if fix.valid and predictor is not None else None
        t_er = fix.heading_earth_rate_t
        earth_rate = math.isfinite(fix.heading_earth_rate) and (er_t[0] is None or t_er > er_t[0])
        if earth_rate:
            er_t[0] = t_er
        if bus.record is not None:
            bus.record(name, free_gyro_fix_messages(fix, t, values["height_m"], values["height_sigma_m"], prediction,
                                                    core.params.heading_window_s if earth_rate else None))
    return stage
