"""Kalman filter steps as pure functions (filterpy style), shared by every filter here.

States are shape (n,), covariances (n, n). The update is in Joseph form,
P+ = (I - K H) P (I - K H)^T + K R K^T, which keeps P symmetric positive semi-definite
whatever the rounding; each step re-symmetrises its output. Innovation gating uses the
Mahalanobis distance against a chi-square quantile.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np
from scipy.stats import chi2


def check_state(x: np.ndarray, P: np.ndarray, name: str = "filter") -> tuple[np.ndarray, np.ndarray]:
    """Return (x, P) as float arrays after checking shapes (n,), (n, n), finiteness and symmetry."""
    x = np.asarray(x, dtype=float)
    P = np.asarray(P, dtype=float)
    if x.ndim != 1:
        raise ValueError(f"{name}: state must have shape (n,), got {x.shape}")
    n = x.shape[0]
    if P.shape != (n, n):
        raise ValueError(f"{name}: covariance must have shape ({n}, {n}), got {P.shape}")
    if not (np.all(np.isfinite(x)) and np.all(np.isfinite(P))):
        raise ValueError(f"{name}: state or covariance contains NaN or inf")
    if np.max(np.abs(P - P.T)) > 1e-9 * max(1.0, float(np.max(np.abs(P)))):
        raise ValueError(f"{name}: covariance is not symmetric")
    return x, P


def symmetrize(P: np.ndarray) -> np.ndarray:
    return 0.5 * (P + P.T)


def predict(x: np.ndarray, P: np.ndarray, F: np.ndarray, Q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """x- = F x, P- = F P F^T + Q (discrete process noise ``Q``)."""
    return F @ x, symmetrize(F @ P @ F.T + Q)


class Update(NamedTuple):
    """Result of :func:`joseph_update`: new state and covariance, innovation ``y`` (m,),
    its covariance ``S`` (m, m), the squared Mahalanobis distance ``d2`` and whether the
    gate accepted it (when rejected, ``x`` and ``P`` are the inputs unchanged)."""

    x: np.ndarray
    P: np.ndarray
    y: np.ndarray
    S: np.ndarray
    d2: float
    accepted: bool


def joseph_update(x: np.ndarray, P: np.ndarray, z: np.ndarray, H: np.ndarray, R: np.ndarray,
                  gate_d2: float = np.inf, h_x: np.ndarray | None = None) -> Update:
    """Measurement update with ``z = H x + v``, v ~ N(0, R) (or ``z = h(x) + v`` linearised
    with ``h_x`` = h(x) and ``H`` its Jacobian), Joseph form.

    A measurement whose squared Mahalanobis distance exceeds ``gate_d2`` is rejected and
    the state is returned unchanged.
    """
    y = z - (H @ x if h_x is None else h_x)
    PHt = P @ H.T
    S = symmetrize(H @ PHt + R)
    S_inv = np.linalg.inv(S)
    d2 = float(y @ S_inv @ y)
    if not d2 <= gate_d2:  # also rejects NaN
        return Update(x, P, y, S, d2, False)
    K = PHt @ S_inv
    I_KH = np.eye(P.shape[0]) - K @ H
    P_new = symmetrize(I_KH @ P @ I_KH.T + K @ R @ K.T)
    return Update(x + K @ y, P_new, y, S, d2, True)


def chi2_gate(dof: int, probability: float = 0.9999) -> float:
    """Squared-Mahalanobis threshold that a consistent innovation exceeds with
    probability ``1 - probability``."""
    if not 0.0 < probability < 1.0:
        raise ValueError(f"gate probability must be in (0, 1), got {probability}")
    return float(chi2.ppf(probability, dof))


def nees(error: np.ndarray, P: np.ndarray) -> float:
    """Normalised estimation error squared e^T P^-1 e (chi-square with n dof if consistent)."""
    return float(error @ np.linalg.solve(P, error))


def van_loan(A: np.ndarray, G_Qc_Gt: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Exact discretisation of dx = A x dt + G dw with E[dw dw^T] = Qc dt: returns (F, Qd)
    for a step ``dt`` (Van Loan's matrix exponential)."""
    from scipy.linalg import expm

    n = A.shape[0]
    M = np.zeros((2 * n, 2 * n))
    M[:n, :n] = -A
    M[:n, n:] = G_Qc_Gt
    M[n:, n:] = A.T
    E = expm(M * dt)
    F = E[n:, n:].T
    return F, symmetrize(F @ E[:n, n:])
