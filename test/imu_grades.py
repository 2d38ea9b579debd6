"""The papers' IMU grades are scenario defaults (docs/spec.md §3 IMUs: scale factor, asymmetry
and misalignment drawn per run). A test that compares a scenario run with a hand-built loop
that has no such errors, or with a closed form of a sensor without them, turns them off with
these ``--set`` values (``--set`` pairs for the CLIs, assignments for ``apply_set``)."""
from __future__ import annotations

GRADE_SIGMAS = ("scale_factor_sigma_ppm", "scale_asymmetry_sigma_ppm", "misalignment_sigma_urad")


def no_grade(*imus: str) -> list[str]:
    """``sensor_models.<imu>_<sigma>=0.0`` for each of ``imus`` (e.g. ``gimbal_gyro``)."""
    return [f"sensor_models.{imu}_{sigma}=0.0" for imu in imus for sigma in GRADE_SIGMAS]


def no_grade_args(*imus: str) -> list[str]:
    """:func:`no_grade` as ``--set`` arguments of ``gimbal-run`` or ``gimbal-campaign``."""
    return [arg for item in no_grade(*imus) for arg in ("--set", item)]
