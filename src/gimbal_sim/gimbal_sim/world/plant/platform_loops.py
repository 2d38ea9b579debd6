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
    """DC-motor gimbal loop: derivative and RK4 step (module docstring)."""

    def __init__(self, params: PlatformAxisParams) -> None:
        if not isinstance(params, PlatformAxisParams):
            raise ValueError("params must be a PlatformAxisParams")
        self.params = params
        self._inv_j = 1.0 / params.inertia_kg_m2
        self._inv_l = 1.0 / params.inductance_h
        self._r = params.resistance_ohm
        self._kt = params.torque_constant_nm_a
        self._ke = params.back_emf
        self._b = params.viscous_friction_nm_s_rad
        self._tc = params.coulomb_friction_nm
        self._inv_ws = 1.0 / params.friction_smoothing_rad_s
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
        return self._f(x[1], x[2], self.saturate(voltage), base_rate, disturbance_nm)

    def _f(self, w: float, i: float, v: float, wa: float, td: float) -> tuple[float, float, float]:
        rel = w - wa
        torque = self._kt * i - self._tc * math.tanh(rel * self._inv_ws) - self._b * rel + td
        return w, torque * self._inv_j, (v - self._r * i - self._ke * rel) * self._inv_l

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
        v = self.saturate(voltage)
        wa = _triple("base_rate", base_rate)
        td = _triple("disturbance_nm", disturbance_nm)
        th, w, i = (float(c) for c in x)
        h = dt / substeps
        for k in range(substeps):
            s0 = k / substeps
            if substeps == 1:
                wa0, wam, wa1 = wa
                td0, tdm, td1 = td
            else:
                wa0, wam, wa1 = (_quad(wa, s0), _quad(wa, s0 + 0.5 / substeps), _quad(wa, s0 + 1.0 / substeps))
                td0, tdm, td1 = (_quad(td, s0), _quad(td, s0 + 0.5 / substeps), _quad(td, s0 + 1.0 / substeps))
            th, w, i = self._rk4(th, w, i, v, wa0, wam, wa1, td0, tdm, td1, h)
        return th, w, i

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
        v = self.saturate(voltage)
        th, w0 = float(x[0]), float(x[1])
        wa, td = float(base_rate), float(disturbance_nm)
        jdt = self.params.inertia_kg_m2 / dt
        lin = jdt + self._kt * self._ke / self._r + self._b  # slope of the linear part in ω₁
        rhs = jdt * w0 + self._kt * v / self._r + (self._kt * self._ke / self._r + self._b) * wa + td
        # root of g(ω) = lin ω − rhs + T_c tanh((ω − ω_A)/ω_s); tanh ∈ [−1, 1] brackets it
        lo, hi = (rhs - self._tc) / lin, (rhs + self._tc) / lin
        w = min(max(w0, lo), hi)
        for _ in range(60):
            th_rel = math.tanh((w - wa) * self._inv_ws)
            g = lin * w - rhs + self._tc * th_rel
            if g > 0.0:
                hi = w
            else:
                lo = w
            w_new = w - g / (lin + self._tc * self._inv_ws * (1.0 - th_rel * th_rel))
            if not lo <= w_new <= hi:
                w_new = 0.5 * (lo + hi)
            if abs(w_new - w) <= 1e-15 + 1e-13 * abs(w):
                w = w_new
                break
            w = w_new
        return th + 0.5 * dt * (w0 + w), w, (v - self._ke * (w - wa)) / self._r

    def _rk4(self, th: float, w: float, i: float, v: float, wa0: float, wam: float, wa1: float,
             td0: float, tdm: float, td1: float, dt: float) -> tuple[float, float, float]:
        f = self._f
        h = 0.5 * dt
        a1, b1, c1 = f(w, i, v, wa0, td0)
        a2, b2, c2 = f(w + h * b1, i + h * c1, v, wam, tdm)
        a3, b3, c3 = f(w + h * b2, i + h * c2, v, wam, tdm)
        a4, b4, c4 = f(w + dt * b3, i + dt * c3, v, wa1, td1)
        k = dt / 6.0
        return (th + k * (a1 + 2.0 * a2 + 2.0 * a3 + a4),
                w + k * (b1 + 2.0 * b2 + 2.0 * b3 + b4),
                i + k * (c1 + 2.0 * c2 + 2.0 * c3 + c4))


def _quad(samples: tuple[float, float, float], s: float) -> float:
    """Quadratic through samples at s = 0, 1/2, 1, evaluated at ``s``."""
    y0, ym, y1 = samples
    return y0 * (1.0 - s) * (1.0 - 2.0 * s) + ym * 4.0 * s * (1.0 - s) + y1 * s * (2.0 * s - 1.0)
