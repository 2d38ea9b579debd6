"""Generic fixed-step classical Runge–Kutta (RK4) step on tuples of floats.

The plants use specialised copies of this scheme in their hot paths (no closures, inputs
sampled at t, t + dt/2, t + dt); this generic form serves everything else.
"""
from __future__ import annotations

from collections.abc import Callable, Sequence


def rk4_step(
    f: Callable[[float, tuple[float, ...]], Sequence[float]],
    t: float,
    x: Sequence[float],
    dt: float,
) -> tuple[float, ...]:
    """x(t + dt) from ẋ = f(t, x) by one classical RK4 step; ``x`` shape (n,), returns a tuple."""
    x = tuple(float(v) for v in x)
    h = 0.5 * dt
    k1 = f(t, x)
    k2 = f(t + h, tuple(xi + h * ki for xi, ki in zip(x, k1)))
    k3 = f(t + h, tuple(xi + h * ki for xi, ki in zip(x, k2)))
    k4 = f(t + dt, tuple(xi + dt * ki for xi, ki in zip(x, k3)))
    w = dt / 6.0
    return tuple(xi + w * (a + 2.0 * b + 2.0 * c + d) for xi, a, b, c, d in zip(x, k1, k2, k3, k4))
