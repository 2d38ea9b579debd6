"""The ``operator`` node's parameter table and --help text, readable without ROS (the node
declares them; the config generator and the scenario checks read them). The mapping to the
core's parameters is :meth:`..world.operator_model.OperatorModelParams.from_values`; the
defaults are argued in :mod:`..world.operator_model`.
"""
from __future__ import annotations

from gimbal_kinematics.params import Param

from ..world.operator_model import OperatorModelParams

DESCRIPTION = (
    "Simulated sight operator: watches the true angle between the LOS (/truth/gimbal/imu) and an "
    "inertially fixed target (the LOS captured capture_s after the start); beyond tolerance_mrad it reacts after "
    "reaction_time_s and slews the LOS back at a rate proportional to the error (gain_1_s, at most "
    "peak_rate_deg_s) until settle_band_mrad. Publishes /operator/los_rate (sight frame, rad/s, y = q, z = r) "
    "and ~/pointing_error (x = angle, y, z = its components about m-y, m-z) [rad] at rate_hz. "
    "script: step instead publishes a scripted stick: step_rate_deg_s (q, r) from step_start_s for "
    "step_duration_s, zero before and after (no target: the pointing error is NaN)."
)
_DEFAULT = OperatorModelParams()
PARAMS = (
    Param("sim_rate_hz", 1000.0, "lockstep rate [Hz] (the truth's)", 1.0, 100000.0),
    Param("rate_hz", 100.0, "the operator's decision and publish rate [Hz] (divides sim_rate_hz; the controller's "
          "operator_rate_hz)", 1e-3, 100000.0),
    Param("tolerance_mrad", _DEFAULT.tolerance_mrad, "pointing error that starts a correction [mrad]", 1e-6, 1e6),
    Param("settle_band_mrad", _DEFAULT.settle_band_mrad, "error at which a correction stops [mrad] (< tolerance)",
          1e-6, 1e6),
    Param("reaction_time_s", _DEFAULT.reaction_time_s, "delay from seeing the error to moving the stick [s]",
          0.0, 10.0),
    Param("peak_rate_deg_s", _DEFAULT.peak_rate_deg_s, "largest commanded LOS rate [deg/s]", 1e-6, 1e3),
    Param("gain_1_s", _DEFAULT.gain_1_s, "rate per unit error K [1/s]", 1e-6, 1e3),
    Param("capture_s", 1.0, "the target is the true LOS this long after the first step [s]", 0.0, 1e5),
    Param("lat_deg", 0.0, "site latitude [deg] (the earth rate that turns NED under the inertial target)",
          -89.999, 89.999),
    Param("earth_rate", True, "NED turns with the earth (vehicle_dynamics' earth_rate)"),
    Param("script", "watch", "watch: the simulated operator above; step: a scripted step command (step_*)",
          choices=("watch", "step")),
    Param("step_start_s", 30.0, "script step: the command starts this long after the first step [s]", 0.0, 1e6),
    Param("step_duration_s", 10.0, "script step: and lasts this long [s]", 0.0, 1e6),
    Param("step_rate_deg_s", [2.0, 5.0], "script step: the LOS rate command (q: elevation, r: azimuth) [deg/s]"),
    Param("progress_every_steps", 10, "report on ~/progress (time of the next step needed) every N steps; "
          "vehicle_dynamics waits for and paces on it", 1, 10**6),
    Param("wait_for_subscribers", 0, "matched subscriptions each output needs before ~/progress reports ready",
          0, 1000),
)

