"""Single-axis DC-motor gimbal loops of the four-gimbal platform (paper 3 §2.1, Table 1).

Each gimbal axis (azimuth a, inner roll q, pitch p, outer roll r) is a direct-drive DC
torque motor between the gimbal and its outer member::

    L di/dt = V − R i − k_e ω_rel                  (armature)
    J dω/dt = k_t i − T_f(ω_rel) + T_d              (gimbal about its axis)
    dθ/dt   = ω

State ``x = (θ, ω, i)``: inertial angle [rad] and rate [rad/s] of the gimbal about its axis
and armature current [A]. Inputs: voltage V [V] (clipped at ±``voltage_limit_v``), the
inertial rate ω_A of the outer member about the same axis [rad/s] (the host motion that the
bearings and the motor's back-EMF couple in; ω_rel = ω − ω_A) and a disturbance torque T_d
[N·m] (imbalance, cable drag, ...).

Bearing friction: T_f(w) = T_c tanh(w / w_s) + B w. The tanh replaces sign(w) so that the
right-hand side is smooth: a true Coulomb step makes RK4 chatter about w = 0. Its slope at
zero, T_c / w_s, acts as a stiff viscous term; with the defaults (T_c = 0.01 N·m,
w_s = 0.01 rad/s) the largest rate pole T_c/(w_s J) ≈ 385 s⁻¹ (axis a) stays well inside
RK4's stability bound (|λ dt| < 2.78) at 1 kHz. Above ~3 w_s the friction is Coulomb +
viscous to within 0.5 %.

Table 1 gives J, k_t, R_a. Not given, and chosen here:

* L = 30 mH for every axis (electrical time constant L/R ≈ 0.85–1.05 ms, typical of
  high-resistance direct-drive torquers); at 1 kHz the loop step is ≈ L/R, use
  ``substeps`` in :meth:`PlatformAxis.step` for accurate current transients;
* k_e = k_t [V·s/rad] (equal in SI units for an ideal motor);
* B = 5e-4 N·m·s/rad, T_c = 0.01 N·m, w_s = 0.01 rad/s; voltage limit 27 V (28 V bus).
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from . import platform_kernels as kernels

#: Paper 3 Table 1: axis -> (J [kg·m²], k_t [N·m/A], R_a [Ω]).
PAPER3_TABLE1: dict[str, tuple[float, float, float]] = {
    "a": (0.0026, 0.21, 31.2),
    "q": (0.0066, 0.21, 35.5),
    "p": (0.0093, 0.21, 28.7),
    "r": (0.0115, 0.29, 34.3),
}


@dataclass(frozen=True)
class PlatformAxisParams:
    """One gimbal loop (module docstring). ``back_emf_v_s_rad=None`` means k_e = k_t."""

    inertia_kg_m2: float
    torque_constant_nm_a: float
    resistance_ohm: float
    inductance_h: float = 0.03
    back_emf_v_s_rad: float | None = None
    viscous_friction_nm_s_rad: float = 5e-4
    coulomb_friction_nm: float = 0.01
    friction_smoothing_rad_s: float = 0.01
    voltage_limit_v: float = 27.0
    name: str = "axis"

    def __post_init__(self) -> None:
        positive = ("inertia_kg_m2", "torque_constant_nm_a", "resistance_ohm", "inductance_h",
                    "friction_smoothing_rad_s")
        for field_name in positive:
            value = getattr(self, field_name)
            if not math.isfinite(value) or value <= 0.0:
                raise ValueError(f"{self.name}: {field_name} must be > 0, got {value}")
        for field_name in ("viscous_friction_nm_s_rad", "coulomb_friction_nm"):
            value = getattr(self, field_name)
            if not math.isfinite(value) or value < 0.0:
                raise ValueError(f"{self.name}: {field_name} must be >= 0, got {value}")
        if self.back_emf_v_s_rad is not None and (
            not math.isfinite(self.back_emf_v_s_rad) or self.back_emf_v_s_rad <= 0.0
        ):
            raise ValueError(f"{self.name}: back_emf_v_s_rad must be > 0, got {self.back_emf_v_s_rad}")
        if math.isnan(self.voltage_limit_v) or self.voltage_limit_v <= 0.0:
            raise ValueError(f"{self.name}: voltage_limit_v must be > 0 (inf for none), got {self.voltage_limit_v}")

    @property
    def back_emf(self) -> float:
        """k_e [V·s/rad]."""
        return self.torque_constant_nm_a if self.back_emf_v_s_rad is None else self.back_emf_v_s_rad


def paper3_axis_params(axis: str, **overrides: float) -> PlatformAxisParams:
    """Parameters of paper 3's axis ``'a'``, ``'q'``, ``'p'`` or ``'r'`` (Table 1 plus the
    module defaults); ``overrides`` replace any field by name."""
    if axis not in PAPER3_TABLE1:
        raise ValueError(f"unknown paper 3 axis {axis!r}; known: {', '.join(PAPER3_TABLE1)}")
    j, kt, r = PAPER3_TABLE1[axis]
    base = PlatformAxisParams(inertia_kg_m2=j, torque_constant_nm_a=kt, resistance_ohm=r, name=axis)
    try:
        return replace(base, **overrides)
    except TypeError as exc:
        raise ValueError(f"paper 3 axis {axis}: {exc}") from None


def _triple(name: str, value: float | Sequence[float]) -> tuple[float, float, float]:
    """A held input (float) or its samples at (t, t + dt/2, t + dt)."""
    if isinstance(value, (int, float)):
        v = float(value)
        return v, v, v
    if len(value) != 3:
        raise ValueError(f"{name}: expected a float or 3 samples (t, t+dt/2, t+dt), got {value}")
    return float(value[0]), float(value[1]), float(value[2])


class PlatformAxis:
    """DC-motor gimbal loop: derivative and RK4 step (module docstring); the arithmetic is
    the compiled kernels' of :mod:`.platform_kernels`, over :attr:`kernel_params`."""

    def __init__(self, params: PlatformAxisParams) -> None:
        if not isinstance(params, PlatformAxisParams):
            raise ValueError("params must be a PlatformAxisParams")
        self.params = params
        self.kernel_params = kernel_params(params)
        self._tc = params.coulomb_friction_nm
        self._inv_ws = 1.0 / params.friction_smoothing_rad_s
        self._b = params.viscous_friction_nm_s_rad
        self._vmax = params.voltage_limit_v

    def saturate(self, voltage: float) -> float:
        """Voltage actually applied [V]."""
        v, lim = float(voltage), self._vmax
        return lim if v > lim else -lim if v < -lim else v

    def friction_torque(self, omega_rel: float) -> float:
        """Bearing friction T_f [N·m] opposing the relative rate ``omega_rel`` [rad/s]."""
        return self._tc * math.tanh(omega_rel * self._inv_ws) + self._b * omega_rel

    def derivative(self, x: Sequence[float], voltage: float, base_rate: float = 0.0,
                   disturbance_nm: float = 0.0) -> tuple[float, float, float]:
        """ẋ = (ω, dω/dt, di/dt) for state ``x`` = (θ, ω, i); ``voltage`` is clipped."""
        return kernels.axis_derivative(float(x[1]), float(x[2]), self.saturate(voltage), float(base_rate),
                                       float(disturbance_nm), self.kernel_params)

    def step(self, x: Sequence[float], voltage: float, dt: float,
             base_rate: float | Sequence[float] = 0.0,
             disturbance_nm: float | Sequence[float] = 0.0,
             substeps: int = 1) -> tuple[float, float, float]:
        """Advance ``dt`` [s] by ``substeps`` RK4 steps with the voltage held (zero-order hold).

        ``base_rate`` and ``disturbance_nm`` are held floats or their samples at
        (t, t + dt/2, t + dt); with substeps they are interpolated quadratically through
        those samples.
        """
        if substeps < 1:
            raise ValueError(f"substeps must be >= 1, got {substeps}")
        return kernels.axis_rk4(float(x[0]), float(x[1]), float(x[2]), float(voltage),
                                _triple("base_rate", base_rate), _triple("disturbance_nm", disturbance_nm),
                                float(dt), int(substeps), self.kernel_params)

    def step_quasi_static(self, x: Sequence[float], voltage: float, dt: float, base_rate: float = 0.0,
                          disturbance_nm: float = 0.0) -> tuple[float, float, float]:
        """Advance ``dt`` [s] in one step for control rates far below the electrical pole.

        The armature current is taken at its quasi-static value i = (V − k_e ω_rel)/R (L/R
        ≈ 1 ms is below any step this is meant for), and the rate is implicit (backward
        Euler): J (ω₁ − ω₀)/dt = k_t i(ω₁) − T_f(ω₁ − ω_A) + T_d, solved by safeguarded
        Newton (the left side minus the right is increasing in ω₁, so the root is unique);
        θ by the trapezoid. Stable at any step against the friction's stiff slope near zero
        relative rate (T_c/(ω_s J) ≈ 385 s⁻¹ on axis a), which explicit RK4 needs ≤ 7 ms
        steps for, and 2.3 ms with the armature. ``base_rate``, ``disturbance_nm``: their
        values at the end of the step (held inputs).
        """
        return kernels.axis_quasi_static(float(x[0]), float(x[1]), float(voltage), float(base_rate),
                                         float(disturbance_nm), float(dt), self.kernel_params)


def kernel_params(params: PlatformAxisParams) -> np.ndarray:
    """The kernels' parameter vector of one axis (:mod:`.platform_kernels`, ``P_*`` order)."""
    p = np.empty(kernels.N_PARAMS)
    p[kernels.P_J] = params.inertia_kg_m2
    p[kernels.P_INV_J] = 1.0 / params.inertia_kg_m2
    p[kernels.P_INV_L] = 1.0 / params.inductance_h
    p[kernels.P_R] = params.resistance_ohm
    p[kernels.P_KT] = params.torque_constant_nm_a
    p[kernels.P_KE] = params.back_emf
    p[kernels.P_B] = params.viscous_friction_nm_s_rad
    p[kernels.P_TC] = params.coulomb_friction_nm
    p[kernels.P_INV_WS] = 1.0 / params.friction_smoothing_rad_s
    p[kernels.P_VMAX] = params.voltage_limit_v
    return p
