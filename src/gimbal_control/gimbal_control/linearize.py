"""Numerical linearisation of the two-axis gimbal at rest (paper 1 §5).

Paper 1 linearises its Newton–Euler gimbal model about the point where the host and the
turret are at rest, the host is level, both joints are at zero and all joint rates and
accelerations are zero, and writes

    ẋ = A_l x + B_l u,   y = C_l x,
    x = (ψm, θm, ψ̇m, θ̇m),  u = (τ_a, τ_e) [N·m],  y = (ψ̇m, θ̇m) [rad/s],

so that ẏ = A′x + B′u with A′ = C_l A_l (2×4) and B′ = C_l B_l (2×2).

Here A_l and B_l are *not* typed in: they are central differences of
``gimbal_kinematics.gimbal.gimbal_dynamics.TwoAxisGimbal.derivative`` evaluated on
``rest_base(g)``, i.e. of the very model the simulator integrates. ``derivative`` is affine
in the torque (below the limits), so B_l is exact up to rounding and its lower block is
M(0)⁻¹; A_l carries the viscous friction (−M⁻¹ b) and the gravity stiffness of the CG offsets.

Our gimbal has a few millimetres of mass imbalance (``GimbalParams``), so the rest point
is not an equilibrium at zero torque: f(0, 0) = (0, 0, ẏ₀) with ẏ₀ ≠ 0 (gravity pulls the
inner frame). The affine model is ẏ = ẏ₀ + A′x + B′u; the trim torque that holds the rest
point is u₀ = −B′⁻¹ẏ₀ (= the gravity torque from ``TwoAxisGimbal.inverse_dynamics``).
Paper 1 is silent about it (a balanced gimbal has ẏ₀ = 0); we keep it so the controller can
feed it forward instead of leaving it to the integrator.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from gimbal_kinematics.gimbal.gimbal_dynamics import TwoAxisGimbal
from gimbal_kinematics.gimbal.gimbal_params import GimbalParams
from gimbal_kinematics.gimbal.turret_base import rest_base
from gimbal_kinematics.maths.units import G0

#: Standard gravity [m/s²] (the default linearisation gravity; a site's normal gravity
#: differs by < 0.3 %, which only changes the small gravity-stiffness entries of A_l).

#: C_l: the rates are the last two states.
C_L = np.array([[0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]])


@dataclass(frozen=True)
class LinearGimbalModel:
    """Linearised gimbal at rest; see the module docstring. Arrays are read-only.

    Attributes:
        A_l: (4, 4) [1/s, 1/s²]; B_l: (4, 2) [1/(kg·m²)]; C_l: (2, 4).
        A_prime: C_l A_l, (2, 4); B_prime: C_l B_l, (2, 2); B_prime_inv: its inverse [kg·m²].
        f0: (4,) drift ẋ at the rest point with zero torque; y_dot0 = C_l f0, (2,) [rad/s²].
        u_trim: (2,) torque [N·m] holding the rest point, −B′⁻¹ ẏ₀.
        gravity_m_s2: gravity used for the rest base [m/s²].
    """

    A_l: np.ndarray
    B_l: np.ndarray
    C_l: np.ndarray
    f0: np.ndarray
    gravity_m_s2: float

    @property
    def A_prime(self) -> np.ndarray:
        return self.C_l @ self.A_l

    @property
    def B_prime(self) -> np.ndarray:
        return self.C_l @ self.B_l

    @property
    def B_prime_inv(self) -> np.ndarray:
        return np.linalg.inv(self.B_prime)

    @property
    def y_dot0(self) -> np.ndarray:
        return self.C_l @ self.f0

    @property
    def u_trim(self) -> np.ndarray:
        return -self.B_prime_inv @ self.y_dot0


def linearize_gimbal(
    params: GimbalParams | None = None,
    gravity_m_s2: float = G0,
    state_step: float = 1e-6,
    torque_step: float = 1e-3,
) -> LinearGimbalModel:
    """A_l, B_l, C_l of ``TwoAxisGimbal(params)`` at rest by central differences.

    ``state_step`` [rad, rad/s] and ``torque_step`` [N·m] are the perturbations; the
    torque step must stay below the torque limits (``derivative`` clips the torque).
    """
    if not (math.isfinite(gravity_m_s2) and gravity_m_s2 >= 0.0):
        raise ValueError(f"gravity_m_s2 must be finite and >= 0, got {gravity_m_s2}")
    if not (math.isfinite(state_step) and state_step > 0.0):
        raise ValueError(f"state_step must be > 0, got {state_step}")
    plant = TwoAxisGimbal(params)
    limit = min(plant.params.azimuth_torque_limit_nm, plant.params.elevation_torque_limit_nm)
    if not (math.isfinite(torque_step) and 0.0 < torque_step < limit):
        raise ValueError(f"torque_step must be in (0, {limit}) N·m (below the torque limits), got {torque_step}")
    base = rest_base(gravity_m_s2)
    zero_u = (0.0, 0.0)

    def f(x: np.ndarray, u) -> np.ndarray:
        return np.asarray(plant.derivative(tuple(float(v) for v in x), u, base), dtype=float)

    x0 = np.zeros(4)
    A = np.empty((4, 4))
    for j in range(4):
        dx = np.zeros(4)
        dx[j] = state_step
        A[:, j] = (f(x0 + dx, zero_u) - f(x0 - dx, zero_u)) / (2.0 * state_step)
    B = np.empty((4, 2))
    for j in range(2):
        du = [0.0, 0.0]
        du[j] = torque_step
        dm = [0.0, 0.0]
        dm[j] = -torque_step
        B[:, j] = (f(x0, du) - f(x0, dm)) / (2.0 * torque_step)
    f0 = f(x0, zero_u)
    out = []
    for arr in (A, B, C_L.copy(), f0):
        arr.flags.writeable = False
        out.append(arr)
    return LinearGimbalModel(A_l=out[0], B_l=out[1], C_l=out[2], f0=out[3], gravity_m_s2=float(gravity_m_s2))
