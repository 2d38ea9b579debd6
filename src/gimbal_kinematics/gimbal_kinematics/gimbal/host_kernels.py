"""Compiled per-sample kernel of the host's motion (numba ``njit``): a plain function over
floats, no state. :func:`.host_state.host_state_from_euler` and the motion profiles' sample
kernel both call :func:`host_fields`, so every host sample is computed by the same code."""
from __future__ import annotations

import math

from numba import njit


@njit(cache=True)
def host_fields(t: float, phi: float, theta: float, psi: float, dphi: float, dtheta: float, dpsi: float,
                ddphi: float, ddtheta: float, ddpsi: float, psi_t: float, psi_t_dot: float, psi_t_ddot: float,
                ax: float, ay: float, az: float) -> tuple:
    """The 22 fields of a :class:`.host_state.HostState`, in its order, from the 3-2-1 Euler
    angles and their first and second derivatives, the turret (ψt, ψ̇t, ψ̈t) and the pivot
    acceleration in b. Body rates ω_nb^b = E(φ, θ) ė::

        p = φ̇ − sθ ψ̇,   q = cφ θ̇ + sφ cθ ψ̇,   r = −sφ θ̇ + cφ cθ ψ̇

    and α_nb^b their time derivatives (each sine and cosine contributes its own rate term)."""
    cf, sf = math.cos(phi), math.sin(phi)
    ct, st = math.cos(theta), math.sin(theta)
    p = dphi - st * dpsi
    q = cf * dtheta + sf * ct * dpsi
    r = -sf * dtheta + cf * ct * dpsi
    p_dot = ddphi - ct * dtheta * dpsi - st * ddpsi
    q_dot = (
        -sf * dphi * dtheta + cf * ddtheta
        + (cf * dphi * ct - sf * st * dtheta) * dpsi + sf * ct * ddpsi
    )
    r_dot = (
        -cf * dphi * dtheta - sf * ddtheta
        - (sf * dphi * ct + cf * st * dtheta) * dpsi + cf * ct * ddpsi
    )
    return (t, phi, theta, psi, dphi, dtheta, dpsi, ddphi, ddtheta, ddpsi, p, q, r, p_dot, q_dot, r_dot,
            psi_t, psi_t_dot, psi_t_ddot, ax, ay, az)
