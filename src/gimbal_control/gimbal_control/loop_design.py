"""Discrete-time loop analysis of the paper 1 inverse-dynamics PI rate loop.

Paper 1 designs ω_n = 100 Hz, ξ = 0.8 for a continuous loop. With perfect inversion the
per-axis loop is L(s) = (k_p s + k_i)/s², whose gain crossover is ω_c ≈ 1.70 ω_n with
70° of phase margin. A sampled loop loses phase to the zero-order hold (ω T/2) and to any
computation delay (d ω T), so ω_n must shrink with the loop rate.

Model analysed (exactly what :class:`.los_rate_controller.LosRateController` does, on the
plant linearised at rest, base at rest):

* plant: (A_l, B_l, C_l) from :func:`.linearize.linearize_gimbal`, ZOH-discretised with
  ``scipy.signal.cont2discrete`` at T = 1/rate: x_{k+1} = Φ x_k + Γ u_k;
* measurement used at step k: m_k = x_{k−d} (``delay_samples`` = d);
* controller: e_k = −C_l m_k (rate command 0), I_k = I_{k−1} + T (e_k + e_{k−1})/2
  (trapezoidal), v_k = k_p e_k + k_i I_k, u_k = B′⁻¹ (v_k − A′ m_k).

``delay_samples``: whole samples *in addition to* the ZOH plant's own step (u_k acts from
t_k, so it first shows in x_{k+1}). d = 0 is our lockstep graph exactly (the command
stamped k, computed from the sensors of t_k, is held over [t_k, t_{k+1}]). The acceptance asks to
treat the graph as adding a one-sample delay, so the design uses d = 1: this also covers a
command that misses its step in ``realtime`` mode, or a sensor reporting a step average.

The loop is broken at the plant input (loop-at-a-time: the other axis stays closed), so
L(z) = −(transfer from the injected torque to the controller's torque). Margins:

* phase margin PM = 180° + ∠L at |L| = 1 (the worst gain crossover);
* gain margin GM = 1/|L| where L crosses the negative real axis with |L| < 1 (the loop is
  type 2, so there is no lower gain margin: (k_p s + k_i) K/s² is stable for all K > 0).

Both are refined from a log-spaced grid up to Nyquist by root finding on the exact
frequency response C(zI − A)⁻¹B (a linear solve per frequency; the polynomial form loses
digits near z = 1 at high rates). ``test_loop_design.py`` checks it against
``scipy.signal.dbode``, an analytic integrator-plus-delay loop and a time-domain run that
goes unstable just past the gain margin.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from scipy.optimize import brentq
from scipy.signal import cont2discrete

from gimbal_kinematics.gimbal.gimbal_params import GimbalParams
from gimbal_kinematics.maths.units import G0

from .linearize import LinearGimbalModel, linearize_gimbal

#: Rates of the design table [Hz].
TABLE_RATES_HZ = (1000.0, 2000.0, 5000.0, 10000.0, 20000.0)
PAPER_OMEGA_N_HZ = 100.0
PAPER_ZETA = 0.8


def pi_gains(omega_n_hz: float, zeta: float) -> tuple[float, float]:
    """(k_p, k_i) = (2ξω_n, ω_n²) with ω_n = 2π·omega_n_hz; units 1/s, 1/s²."""
    w = 2.0 * math.pi * omega_n_hz
    return 2.0 * zeta * w, w * w


class StateSpaceLoop(NamedTuple):
    """Discrete state space (A, B, C) with sample time dt [s]; L(z) = −C (zI − A)⁻¹ B."""

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    dt: float


class Margins(NamedTuple):
    """Loop margins: GM [dB] (inf if the phase never reaches −180° below unity gain),
    PM [deg], gain-crossover frequency [Hz], closed-loop stability (spectral radius < 1)."""

    gain_margin_db: float
    phase_margin_deg: float
    crossover_hz: float
    stable: bool


def controller_loop(plant_A: np.ndarray, plant_B: np.ndarray, plant_C: np.ndarray, rate_hz: float,
                    kp: float, ki: float, delay_samples: int = 1,
                    B_prime_inv: np.ndarray | None = None, A_prime: np.ndarray | None = None) -> StateSpaceLoop:
    """Open loop broken at the plant input of the PI + inversion law around a continuous
    plant ẋ = A x + B u, y = C x (n states, p inputs = p outputs).

    ``B_prime_inv``/``A_prime`` default to (C B)⁻¹ and C A (the paper's inversion); pass
    zeros for ``A_prime`` and an identity for ``B_prime_inv`` to analyse a bare PI.
    Returns the p-input, p-output loop; state (x_k, x_{k−1} … x_{k−d}, I_{k−1}, e_{k−1}).
    """
    if not (math.isfinite(rate_hz) and rate_hz > 0.0):
        raise ValueError(f"rate_hz must be > 0, got {rate_hz}")
    if int(delay_samples) != delay_samples or delay_samples < 0:
        raise ValueError(f"delay_samples must be an int >= 0, got {delay_samples}")
    d = int(delay_samples)
    A = np.asarray(plant_A, dtype=float)
    B = np.asarray(plant_B, dtype=float)
    C = np.asarray(plant_C, dtype=float)
    n, p = B.shape
    T = 1.0 / rate_hz
    Ap = C @ A if A_prime is None else np.asarray(A_prime, dtype=float)
    Bpi = np.linalg.inv(C @ B) if B_prime_inv is None else np.asarray(B_prime_inv, dtype=float)
    Phi, Gam, _, _, _ = cont2discrete((A, B, C, np.zeros((p, p))), T, method="zoh")
    nz = n * (d + 1) + 2 * p
    Az = np.zeros((nz, nz))
    Bz = np.zeros((nz, p))
    Az[:n, :n] = Phi
    Bz[:n, :] = Gam
    for j in range(d):  # shift register of past states
        Az[n * (j + 1):n * (j + 2), n * j:n * (j + 1)] = np.eye(n)
    m0 = n * d  # where x_{k−d} sits
    iz = n * (d + 1)  # I_{k−1}
    ez = iz + p  # e_{k−1}
    h = 0.5 * T
    # e_k = −C m_k;  I_k = I_{k−1} + h (e_k + e_{k−1})
    Az[iz:ez, m0:m0 + n] = -h * C
    Az[iz:ez, iz:ez] = np.eye(p)
    Az[iz:ez, ez:] = h * np.eye(p)
    Az[ez:, m0:m0 + n] = -C
    # u_k = B′⁻¹((k_p + k_i h) e_k + k_i I_{k−1} + k_i h e_{k−1} − A′ m_k)
    Cu = np.zeros((p, nz))
    Cu[:, m0:m0 + n] = Bpi @ (-(kp + ki * h) * C - Ap)
    Cu[:, iz:ez] = ki * Bpi
    Cu[:, ez:] = ki * h * Bpi
    return StateSpaceLoop(Az, Bz, Cu, T)


def gimbal_loop(rate_hz: float, omega_n_hz: float, zeta: float = PAPER_ZETA, delay_samples: int = 1,
                model: LinearGimbalModel | None = None) -> StateSpaceLoop:
    """The paper 1 loop (2 inputs, 2 outputs) on the gimbal linearised at rest."""
    model = model if model is not None else _default_model()
    kp, ki = pi_gains(omega_n_hz, zeta)
    return controller_loop(model.A_l, model.B_l, model.C_l, rate_hz, kp, ki, delay_samples,
                           model.B_prime_inv, model.A_prime)


def close_other_channels(loop: StateSpaceLoop, channel: int) -> StateSpaceLoop:
    """SISO loop of ``channel`` with every other channel closed (w_j = u_j)."""
    p = loop.B.shape[1]
    A = loop.A.copy()
    for j in range(p):
        if j != channel:
            A += np.outer(loop.B[:, j], loop.C[j, :])
    return StateSpaceLoop(A, loop.B[:, [channel]], loop.C[[channel], :], loop.dt)


def closed_loop_matrix(loop: StateSpaceLoop, gain: float = 1.0) -> np.ndarray:
    """State matrix with every channel closed through an extra loop gain ``gain``."""
    return loop.A + gain * loop.B @ loop.C


#: |λ − 1| below which a closed-loop eigenvalue is one of the neutral angle modes.
NEUTRAL_MODE_TOL = 1e-9


def is_stable(A_closed: np.ndarray) -> bool:
    """Every closed-loop eigenvalue inside the unit circle, except the neutral modes at
    exactly z = 1. A rate loop does not hold the joint angles: with the inversion
    cancelling the gravity stiffness, every (ψm, θm) with zero rates and zero integrator
    is an equilibrium, which shows as eigenvalues at exactly 1 (one per axis, to rounding)."""
    ev = np.linalg.eigvals(A_closed)
    moving = ev[np.abs(ev - 1.0) > NEUTRAL_MODE_TOL]
    return bool(moving.size == 0 or np.max(np.abs(moving)) < 1.0)


def loop_response(loop: StateSpaceLoop, omega_rad_s: np.ndarray | float) -> np.ndarray:
    """L(e^{jωT}) of a SISO loop (shape of ``omega_rad_s``), complex."""
    w = np.atleast_1d(np.asarray(omega_rad_s, dtype=float))
    n = loop.A.shape[0]
    z = np.exp(1j * w * loop.dt)
    M = z[:, None, None] * np.eye(n)[None, :, :] - loop.A[None, :, :]
    rhs = np.broadcast_to(loop.B[:, :1], (w.size, n, 1)).astype(complex)
    X = np.linalg.solve(M, rhs)[:, :, 0]
    L = -(X @ loop.C[0, :])
    return L.reshape(np.shape(omega_rad_s)) if np.ndim(omega_rad_s) else L[0]


def siso_margins(loop: StateSpaceLoop, n_grid: int = 4000, w_min_rad_s: float | None = None) -> Margins:
    """GM, PM and crossover of a SISO loop (module docstring for the definitions)."""
    w_nyq = math.pi / loop.dt
    w_lo = w_min_rad_s if w_min_rad_s is not None else w_nyq * 1e-6
    w = np.geomspace(w_lo, w_nyq * (1.0 - 1e-9), n_grid)
    L = loop_response(loop, w)
    stable = is_stable(closed_loop_matrix(loop))

    def logmag(x: float) -> float:
        return math.log(abs(loop_response(loop, x)))

    def imag(x: float) -> float:
        return loop_response(loop, x).imag

    lm = np.log(np.abs(L))
    pm, wc = math.inf, math.nan
    for i in np.nonzero(np.sign(lm[:-1]) != np.sign(lm[1:]))[0]:
        x = brentq(logmag, w[i], w[i + 1], xtol=1e-12 * w[i + 1])
        phase = math.degrees(np.angle(loop_response(loop, x))) % 360.0 - 180.0
        if phase < pm:
            pm, wc = phase, x
    if not math.isfinite(pm):
        # |L| never crosses 1: all gain above (unstable for a type-2 loop) or below.
        pm = -180.0 if lm[-1] > 0.0 else math.inf
    gm = math.inf
    im = L.imag
    for i in np.nonzero(np.sign(im[:-1]) != np.sign(im[1:]))[0]:
        x = brentq(imag, w[i], w[i + 1], xtol=1e-12 * w[i + 1])
        val = loop_response(loop, x)
        if val.real < 0.0 and abs(val) < 1.0:
            gm = min(gm, -20.0 * math.log10(abs(val)))
    end = loop_response(loop, w_nyq)  # real at Nyquist
    if end.real < 0.0 and abs(end) < 1.0:
        gm = min(gm, -20.0 * math.log10(abs(end)))
    return Margins(gm, pm, wc / (2.0 * math.pi), stable)


def loop_margins(loop: StateSpaceLoop, n_grid: int = 4000) -> Margins:
    """Worst loop-at-a-time margins over the channels of a MIMO loop; ``stable`` is for
    all channels closed together."""
    p = loop.B.shape[1]
    per = [siso_margins(close_other_channels(loop, i), n_grid) for i in range(p)]
    worst_pm = min(per, key=lambda m: m.phase_margin_deg)
    stable = is_stable(closed_loop_matrix(loop))
    return Margins(min(m.gain_margin_db for m in per), worst_pm.phase_margin_deg, worst_pm.crossover_hz, stable)


_MODEL_CACHE: dict[tuple, LinearGimbalModel] = {}


def _default_model(params: GimbalParams | None = None, gravity_m_s2: float = G0) -> LinearGimbalModel:
    key = (params, gravity_m_s2)
    if key not in _MODEL_CACHE:
        _MODEL_CACHE[key] = linearize_gimbal(params, gravity_m_s2)
    return _MODEL_CACHE[key]


def margins(rate_hz: float, omega_n_hz: float, zeta: float = PAPER_ZETA, delay_samples: int = 1,
            plant_params: GimbalParams | None = None) -> tuple[float, float, float]:
    """(gain_margin_db, phase_margin_deg, crossover_hz) of the paper 1 loop at
    ``rate_hz`` with ω_n = ``omega_n_hz`` [Hz]; worst of the two axes. An unstable closed
    loop returns a phase margin ≤ 0 (or −180 when |L| > 1 up to Nyquist)."""
    m = margins_full(rate_hz, omega_n_hz, zeta, delay_samples, plant_params)
    return m.gain_margin_db, m.phase_margin_deg, m.crossover_hz


def margins_full(rate_hz: float, omega_n_hz: float, zeta: float = PAPER_ZETA, delay_samples: int = 1,
                 plant_params: GimbalParams | None = None) -> Margins:
    """:func:`margins` plus the closed-loop stability flag."""
    if not (math.isfinite(omega_n_hz) and omega_n_hz > 0.0):
        raise ValueError(f"omega_n_hz must be > 0, got {omega_n_hz}")
    if not (math.isfinite(zeta) and zeta > 0.0):
        raise ValueError(f"zeta must be > 0, got {zeta}")
    return loop_margins(gimbal_loop(rate_hz, omega_n_hz, zeta, delay_samples, _default_model(plant_params)))


def max_omega_n_hz(rate_hz: float, min_phase_margin_deg: float = 45.0, zeta: float = PAPER_ZETA,
                   delay_samples: int = 1, plant_params: GimbalParams | None = None,
                   tol_hz: float = 1e-3) -> float:
    """Highest ω_n [Hz] whose discrete loop keeps ``min_phase_margin_deg`` of phase margin
    and is closed-loop stable (PM falls monotonically with ω_n: the delay lag grows with
    the crossover while the continuous loop's PM does not depend on ω_n)."""
    if not (0.0 < min_phase_margin_deg < 90.0):
        raise ValueError(f"min_phase_margin_deg must be in (0, 90), got {min_phase_margin_deg}")

    def excess(f_hz: float) -> float:
        m = margins_full(rate_hz, f_hz, zeta, delay_samples, plant_params)
        return (m.phase_margin_deg if m.stable else -180.0) - min_phase_margin_deg

    # Below ~1 Hz the PI is slower than the inner frame's gravity pendulum (0.27 Hz) and the
    # margin at the plant input is set by the inversion's stiffness cancellation instead.
    lo, hi = 1.0, rate_hz * 0.5 / (1.0 + 2.0 * delay_samples)
    if excess(lo) < 0.0:
        raise ValueError(f"no ω_n reaches {min_phase_margin_deg}° phase margin at {rate_hz} Hz")
    while excess(hi) >= 0.0:
        lo, hi = hi, hi * 2.0
    return brentq(excess, lo, hi, xtol=tol_hz)


def design_table(rates_hz: tuple[float, ...] = TABLE_RATES_HZ, omega_n_hz: float = PAPER_OMEGA_N_HZ,
                 zeta: float = PAPER_ZETA, delay_samples: int = 1,
                 min_phase_margin_deg: float = 45.0) -> list[dict]:
    """Per rate: margins at ``omega_n_hz`` and the max ω_n for ``min_phase_margin_deg``."""
    rows = []
    for rate in rates_hz:
        m = margins_full(rate, omega_n_hz, zeta, delay_samples)
        wmax = max_omega_n_hz(rate, min_phase_margin_deg, zeta, delay_samples)
        gm_at_max, pm_at_max, fc_at_max = margins(rate, wmax, zeta, delay_samples)
        rows.append(dict(rate_hz=rate, delay_samples=delay_samples, omega_n_hz=omega_n_hz,
                         gain_margin_db=m.gain_margin_db, phase_margin_deg=m.phase_margin_deg,
                         crossover_hz=m.crossover_hz, stable=m.stable, max_omega_n_hz=wmax,
                         gain_margin_db_at_max=gm_at_max, crossover_hz_at_max=fc_at_max))
    return rows


def format_table(rows: list[dict]) -> str:
    """The design table as fixed-width text."""
    head = (f"{'rate Hz':>8} {'d':>2} {'PM@wn deg':>10} {'GM@wn dB':>9} {'fc Hz':>8} "
            f"{'max wn Hz':>10} {'GM@max dB':>10} {'fc@max Hz':>10}")
    lines = [head]
    for r in rows:
        lines.append(f"{r['rate_hz']:8.0f} {r['delay_samples']:2d} {r['phase_margin_deg']:10.1f} "
                     f"{r['gain_margin_db']:9.1f} {r['crossover_hz']:8.1f} {r['max_omega_n_hz']:10.1f} "
                     f"{r['gain_margin_db_at_max']:10.1f} {r['crossover_hz_at_max']:10.1f}")
    return "\n".join(lines)


if __name__ == "__main__":  # python -m gimbal_control.loop_design
    for d in (1, 0):
        print(f"delay_samples = {d}, omega_n = {PAPER_OMEGA_N_HZ} Hz, zeta = {PAPER_ZETA}")
        print(format_table(design_table(delay_samples=d)))
