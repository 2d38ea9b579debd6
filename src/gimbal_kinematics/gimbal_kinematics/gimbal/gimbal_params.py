"""Mass properties, friction and torque limits of the two-axis gimbal (paper 1 §4).

Paper 1 gives no numbers; the defaults describe a plausible ~10 kg electro-optical payload:

=============================  ==========================================  ================
field                          default                                     why
=============================  ==========================================  ================
outer_mass_kg                  4.0                                         azimuth yoke + motor
outer_inertia_kg_m2            (0.060, 0.050, 0.040, 5e-4, −4e-4, 3e-4)    ~0.3 m yoke
outer_cg_m                     (0.001, 0.002, −0.004)                      few mm imbalance
inner_mass_kg                  6.0                                         elevation frame + camera
inner_inertia_kg_m2            (0.045, 0.060, 0.070, 8e-4, −1.2e-3, 5e-4)  ~0.2 m camera box
inner_cg_m                     (0.002, −0.001, 0.003)                      few mm imbalance
azimuth_friction_nm_s_rad      0.03                                        b_a, bearings + seals
elevation_friction_nm_s_rad    0.02                                        b_e
azimuth_torque_limit_nm        3.0                                         direct-drive torquer
elevation_torque_limit_nm      2.0
=============================  ==========================================  ================

Conventions: the outer frame's quantities are resolved in frame a, the inner frame's in m.
An inertia is given about the body's own centre of gravity as the six tensor elements
``(Jxx, Jyy, Jzz, Jxy, Jxz, Jyz)``; the off-diagonal entries are the *tensor* elements,
i.e. ``Jxy = −∫xy dm``. A CG offset is the vector from the gimbal pivot P (where the
azimuth and elevation axes intersect) to the body's CG [m]. A non-zero offset couples
gravity and pivot acceleration into the joint torques (mass imbalance).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


def inertia_matrix(elements: tuple[float, float, float, float, float, float]) -> np.ndarray:
    """(Jxx, Jyy, Jzz, Jxy, Jxz, Jyz) -> symmetric (3, 3) inertia tensor [kg·m²]."""
    xx, yy, zz, xy, xz, yz = elements
    return np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]], dtype=float)


def _check_inertia(name: str, elements: tuple) -> None:
    if len(elements) != 6:
        raise ValueError(f"{name} must have 6 elements (Jxx, Jyy, Jzz, Jxy, Jxz, Jyz), got {len(elements)}")
    if not all(math.isfinite(float(v)) for v in elements):
        raise ValueError(f"{name} must be finite, got {elements}")
    eig = np.linalg.eigvalsh(inertia_matrix(elements))
    if eig[0] <= 0.0:
        raise ValueError(f"{name} must be positive definite, principal moments {eig.tolist()}")
    # A real mass distribution has principal moments obeying the triangle inequality.
    if eig[0] + eig[1] < eig[2] * (1.0 - 1e-12):
        raise ValueError(f"{name} violates the triangle inequality, principal moments {eig.tolist()}")


def _check_vector(name: str, vec: tuple, limit: float) -> None:
    if len(vec) != 3 or not all(math.isfinite(float(v)) for v in vec):
        raise ValueError(f"{name} must be 3 finite numbers, got {vec}")
    if max(abs(float(v)) for v in vec) > limit:
        raise ValueError(f"{name} components must be within ±{limit} m, got {vec}")


@dataclass(frozen=True)
class GimbalParams:
    """Two-axis gimbal parameters (module docstring for units, frames and defaults)."""

    outer_mass_kg: float = 4.0
    outer_inertia_kg_m2: tuple[float, float, float, float, float, float] = (0.060, 0.050, 0.040, 5e-4, -4e-4, 3e-4)
    outer_cg_m: tuple[float, float, float] = (0.001, 0.002, -0.004)
    inner_mass_kg: float = 6.0
    inner_inertia_kg_m2: tuple[float, float, float, float, float, float] = (0.045, 0.060, 0.070, 8e-4, -1.2e-3, 5e-4)
    inner_cg_m: tuple[float, float, float] = (0.002, -0.001, 0.003)
    azimuth_friction_nm_s_rad: float = 0.03
    elevation_friction_nm_s_rad: float = 0.02
    azimuth_torque_limit_nm: float = 3.0
    elevation_torque_limit_nm: float = 2.0

    def __post_init__(self) -> None:
        # YAML gives lists: store tuples so the params stay immutable and hashable.
        for name in ("outer_inertia_kg_m2", "outer_cg_m", "inner_inertia_kg_m2", "inner_cg_m"):
            value = getattr(self, name)
            if isinstance(value, str) or not hasattr(value, "__len__"):
                raise ValueError(f"{name} must be a sequence of numbers, got {value!r}")
            try:
                object.__setattr__(self, name, tuple(float(v) for v in value))
            except (TypeError, ValueError):
                raise ValueError(f"{name} must be a sequence of numbers, got {value!r}") from None
        for name in ("outer_mass_kg", "inner_mass_kg"):
            value = getattr(self, name)
            if not math.isfinite(value) or value <= 0.0:
                raise ValueError(f"{name} must be > 0, got {value}")
        for name in ("outer_inertia_kg_m2", "inner_inertia_kg_m2"):
            _check_inertia(name, tuple(getattr(self, name)))
        for name in ("outer_cg_m", "inner_cg_m"):
            _check_vector(name, tuple(getattr(self, name)), 1.0)
        for name in ("azimuth_friction_nm_s_rad", "elevation_friction_nm_s_rad"):
            value = getattr(self, name)
            if not math.isfinite(value) or value < 0.0:
                raise ValueError(f"{name} must be >= 0, got {value}")
        for name in ("azimuth_torque_limit_nm", "elevation_torque_limit_nm"):
            value = getattr(self, name)
            if math.isnan(value) or value <= 0.0:
                raise ValueError(f"{name} must be > 0 (inf for no limit), got {value}")


#: Paper 2's small UAV gimbal, ~1 kg ("a small weight gimbal (up to 2 kg)"): a 0.35 kg
#: azimuth yoke with its motor and a 0.65 kg camera ball on the elevation axis, ~6 cm
#: across; CG offsets of about 1 mm (a hand-balanced camera); bearing friction and torque
#: limits (0.5 N·m) of a small direct-drive brushless gimbal motor.
UAV_SMALL_GIMBAL = GimbalParams(
    outer_mass_kg=0.35,
    outer_inertia_kg_m2=(8e-4, 6e-4, 5e-4, 1e-5, -1e-5, 5e-6),
    outer_cg_m=(0.0005, 0.0005, -0.001),
    inner_mass_kg=0.65,
    inner_inertia_kg_m2=(6e-4, 8e-4, 9e-4, 1e-5, -2e-5, 1e-5),
    inner_cg_m=(0.0005, -0.0003, 0.001),
    azimuth_friction_nm_s_rad=1e-3,
    elevation_friction_nm_s_rad=8e-4,
    azimuth_torque_limit_nm=0.5,
    elevation_torque_limit_nm=0.5,
)

#: Named gimbal presets (the ``gimbal_model`` parameter of ``vehicle_dynamics``):
#: ``paper1`` is the ~10 kg payload of the table above, ``uav_small`` paper 2's UAV gimbal.
GIMBAL_MODELS: dict[str, GimbalParams] = {"paper1": GimbalParams(), "uav_small": UAV_SMALL_GIMBAL}
