"""The ``operator`` node's parameters and --help text, declared once in :class:`OperatorNodeParams`.
The mapping to the core's parameters is
:meth:`..world.operator_model.OperatorModelParams.from_values`; the defaults are argued in
:mod:`..world.operator_model`.
"""
from __future__ import annotations

from dataclasses import dataclass

from gimbal_kinematics.params.table import SHARED, declaration, param, same_as

from ..world.operator_model import OperatorModelParams

_DEFAULT = OperatorModelParams()


@dataclass(frozen=True)
class OperatorNodeParams:
    """Simulated sight operator: watches the true angle between the LOS (/truth/gimbal/imu) and an inertially fixed
    target (the LOS captured capture_s after the start); beyond tolerance_mrad it reacts after reaction_time_s
    and slews the LOS back at a rate proportional to the error (gain_1_s, at most peak_rate_deg_s) until
    settle_band_mrad. Publishes /operator/los_rate (sight frame, rad/s, y = q, z = r) and ~/pointing_error (x =
    angle, y, z = its components about m-y, m-z) [rad] at rate_hz. script: step instead publishes a scripted stick:
    step_rate_deg_s (q, r) from step_start_s for step_duration_s, zero before and after (no target: the pointing
    error is NaN).
    """

    sim_rate_hz: float = param(1000.0, "lockstep rate (the truth's)", 1.0, 100000.0, unit="Hz")
    rate_hz: float = param(100.0, "the operator's decision and publish rate (divides sim_rate_hz; the controller's "
        "operator_rate_hz)", 1e-3, 100000.0, unit="Hz")
    tolerance_mrad: float = param(_DEFAULT.tolerance_mrad, "pointing error that starts a correction",
        1e-6, 1e6, unit="mrad")
    settle_band_mrad: float = param(_DEFAULT.settle_band_mrad, "error at which a correction stops (< tolerance)",
        1e-6, 1e6, unit="mrad")
    reaction_time_s: float = param(_DEFAULT.reaction_time_s, "delay from seeing the error to moving the stick",
        0.0, 10.0, unit="s")
    peak_rate_deg_s: float = param(_DEFAULT.peak_rate_deg_s, "largest commanded LOS rate", 1e-6, 1e3, unit="deg/s")
    gain_1_s: float = param(_DEFAULT.gain_1_s, "rate per unit error K", 1e-6, 1e3, unit="1/s")
    capture_s: float = param(1.0, "the target is the true LOS this long after the first step", 0.0, 1e5, unit="s")
    lat_deg: float = param(0.0, "site latitude (the earth rate that turns NED under the inertial target)",
        -89.999, 89.999, unit="deg")
    earth_rate: bool = param(True, "NED turns with the earth (vehicle_dynamics' earth_rate)")
    script: str = param("watch", "watch: the simulated operator above; step: a scripted step command (step_*)",
        choices=("watch", "step"))
    step_start_s: float = param(30.0, "script step: the command starts this long after the first step", 0.0, 1e6,
        unit="s")
    step_duration_s: float = param(10.0, "script step: and lasts this long", 0.0, 1e6, unit="s")
    step_rate_deg_s: tuple[float, ...] = param((2.0, 5.0), "script step: the LOS rate command (q: elevation, "
        "r: azimuth)", unit="deg/s")
    progress_every_steps: int = same_as(SHARED["progress_every_steps"])
    wait_for_subscribers: int = same_as(SHARED["wait_for_subscribers"])


PARAMS, DESCRIPTION = declaration(OperatorNodeParams)

