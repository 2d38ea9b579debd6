"""Paper 3's four gimbal loops designed in discrete time at the control rate (§4.1: "the
control frequency of loop is set to 1 kHz and the initial scope of PID parameters can be
determined by the method of pole placement"), for the servo that closes them on the DTG
pickoff angles (:func:`.servo_kernels.servo_tick_pickoff`).

Plant, per Table 1 axis, from motor voltage V to gimbal angle θ (the armature, the inertia,
the viscous bearing friction and the back-EMF, linear; Coulomb friction left out)::

    G(s) = k_t / ( s [ (J s + B)(L s + R) + k_t k_e ] )

discretised with a zero-order hold at T = 1/rate (``scipy.signal.cont2discrete``): the
command computed from the pickoff at t_k is held over [t_k, t_{k+1}], the lockstep timing.

Controller: exactly the PID of :mod:`.control_kernels` on the angle error e = −θ with a
differenced, filtered derivative (the DTG gives no rate)::

    C(z) = k_p + k_i T / (z − 1) + (k_d/τ_d)(z − 1)/(z − a),   a = e^(−T/τ_d)

Pole placement: the characteristic polynomial χ(z) = den_G den_C + num_G num_C is linear in
(k_p, k_i, k_d), so asking for a triple root at z_p = e^(−ωT), ω = 2π ``bandwidth_hz``
(χ(z_p) = χ′(z_p) = χ″(z_p) = 0) is a 3×3 linear solve; the other two roots (of the
electrical pole and the derivative filter) fall where they fall and are reported. Margins
are those of L(z) = C(z)G(z), from ``scipy.signal.dfreqresp`` on a dense grid to Nyquist.

``python -m gimbal_control.platform_loop_design`` prints the design and margins of the four
loops at the default bandwidths.
"""
from __future__ import annotations

import argparse
import math
from typing import NamedTuple

import numpy as np
from scipy import signal

from .pid import PidParams
from .platform_servo import TABLE1, VOLTAGE_LIMIT_V

#: Not in Table 1 (as the plant's :mod:`gimbal_sim` model): armature inductance [H], viscous friction [N·m·s/rad]
INDUCTANCE_H = 0.03
VISCOUS_NM_S_RAD = 5e-4
#: The DTG loops' default bandwidths [Hz] (a, q, p, r) and derivative filter [s].
DEFAULT_BANDWIDTH_HZ = {"a": 12.0, "q": 12.0, "p": 12.0, "r": 4.0}
DEFAULT_DERIVATIVE_TAU_S = 0.002


class LoopDesign(NamedTuple):
    """One designed loop: gains, the discrete plant and controller (numerator, denominator in
    descending powers of z), the closed-loop poles and the margins."""

    axis: str
    rate_hz: float
    bandwidth_hz: float
    pid: PidParams
    plant: tuple[np.ndarray, np.ndarray]
    controller: tuple[np.ndarray, np.ndarray]
    poles: np.ndarray
    phase_margin_deg: float
    gain_margin_db: float
    crossover_hz: float


def plant_tf(axis: str, rate_hz: float) -> tuple[np.ndarray, np.ndarray]:
    """ZOH-discrete G(z) of a Table 1 axis (num, den; descending powers of z, den monic)."""
    j, kt, r = TABLE1[axis]
    den_s = np.polymul([1.0, 0.0], np.polyadd(np.polymul([j, VISCOUS_NM_S_RAD], [INDUCTANCE_H, r]), [kt * kt]))
    num, den, _ = signal.cont2discrete(([kt], den_s), 1.0 / rate_hz, method="zoh")
    num = np.trim_zeros(np.atleast_1d(np.squeeze(num)), "f")
    return num / den[0], den / den[0]


def _controller_parts(rate_hz: float, tau_s: float) -> tuple[np.ndarray, list[np.ndarray]]:
    """den_C and the numerator's part per unit of (k_p, k_i, k_d) (descending powers of z)."""
    t = 1.0 / rate_hz
    a = math.exp(-t / tau_s)
    zm1, zma = np.array([1.0, -1.0]), np.array([1.0, -a])
    den = np.polymul(zm1, zma)
    return den, [den, t * zma, np.polymul(zm1, zm1) / tau_s]


def place(axis: str, bandwidth_hz: float, rate_hz: float = 1000.0,
          derivative_tau_s: float = DEFAULT_DERIVATIVE_TAU_S) -> LoopDesign:
    """The PID of ``axis`` with a triple closed-loop pole at e^(−2π f T) (module docstring)."""
    if axis not in TABLE1:
        raise ValueError(f"axis must be one of {tuple(TABLE1)}, got {axis!r}")
    if not (0.0 < bandwidth_hz < rate_hz / 4.0):
        raise ValueError(f"bandwidth_hz must be in (0, rate_hz/4), got {bandwidth_hz}")
    num_g, den_g = plant_tf(axis, rate_hz)
    den_c, parts = _controller_parts(rate_hz, derivative_tau_s)
    base = np.polymul(den_g, den_c)
    cols = [np.polymul(num_g, part) for part in parts]
    zp = math.exp(-2.0 * math.pi * bandwidth_hz / rate_hz)
    # χ(z) = base + Σ g_k col_k; rows: χ, χ′, χ″ at z_p
    a_mat = np.array([[np.polyval(np.polyder(c, m) if m else c, zp) for c in cols] for m in range(3)])
    b_vec = -np.array([np.polyval(np.polyder(base, m) if m else base, zp) for m in range(3)])
    kp, ki, kd = np.linalg.solve(a_mat, b_vec)
    pid = PidParams(kp=float(kp), ki=float(ki), kd=float(kd), derivative_tau_s=derivative_tau_s,
                    output_limit=VOLTAGE_LIMIT_V)
    num_c = np.polyadd(np.polyadd(kp * parts[0], ki * parts[1]), kd * parts[2])
    chi = np.polyadd(base, np.polymul(num_g, num_c))
    pm, gm, wc = margins((num_g, den_g), (num_c, den_c), rate_hz)
    return LoopDesign(axis, rate_hz, bandwidth_hz, pid, (num_g, den_g), (num_c, den_c), np.roots(chi), pm, gm, wc)


def margins(plant: tuple[np.ndarray, np.ndarray], controller: tuple[np.ndarray, np.ndarray],
            rate_hz: float, n: int = 200000) -> tuple[float, float, float]:
    """(phase margin [°], gain margin [dB], gain crossover [Hz]) of L(z) = C(z)G(z), from
    ``scipy.signal.dfreqresp`` on a log grid to Nyquist (the worst crossover; inf without one)."""
    num = np.polymul(plant[0], controller[0])
    den = np.polymul(plant[1], controller[1])
    t = 1.0 / rate_hz
    w = np.logspace(math.log10(2.0 * math.pi * 1e-3), math.log10(math.pi / t * 0.9999), n)
    _, h = signal.dfreqresp(signal.dlti(num, den, dt=t), w * t)
    mag = np.abs(h)
    cross = np.nonzero(np.diff(np.sign(mag - 1.0)))[0]
    pm = wc = math.inf
    for i in cross:
        p = 180.0 + math.degrees(np.angle(h[i]))  # ∠L in (−180°, 180°]
        p = p - 360.0 if p > 180.0 else p
        if p < pm:
            pm, wc = p, w[i] / (2.0 * math.pi)
    gm = math.inf
    for i in np.nonzero(np.diff(np.sign(np.imag(h))))[0]:
        if np.real(h[i]) < 0.0 and mag[i] < 1.0:
            gm = min(gm, -20.0 * math.log10(mag[i]))
    return pm, gm, wc


def closed_loop(design: LoopDesign) -> signal.dlti:
    """θ/θ_ref of the designed loop (e = θ_ref − θ), for step and bandwidth checks."""
    num_g, den_g = design.plant
    num_c, den_c = design.controller
    num = np.polymul(num_g, num_c)
    den = np.polyadd(np.polymul(den_g, den_c), num)
    return signal.dlti(num, den, dt=1.0 / design.rate_hz)


def design_all(rate_hz: float = 1000.0, bandwidths_hz: dict | None = None,
               derivative_tau_s: float = DEFAULT_DERIVATIVE_TAU_S) -> list[LoopDesign]:
    """The four loops (a, q, p, r) at ``rate_hz``."""
    bw = dict(DEFAULT_BANDWIDTH_HZ, **(bandwidths_hz or {}))
    return [place(axis, bw[axis], rate_hz, derivative_tau_s) for axis in ("a", "q", "p", "r")]


def format_designs(designs: list[LoopDesign]) -> str:
    """A table of the designs: gains, the extra poles' radii, margins."""
    rows = [f"{'axis':4} {'f_bw Hz':>8} {'k_p V/rad':>10} {'k_i V/rad/s':>12} {'k_d V.s/rad':>11} "
            f"{'PM deg':>7} {'GM dB':>6} {'f_c Hz':>7}  closed-loop poles |z|"]
    for d in designs:
        radii = ", ".join(f"{r:.4f}" for r in sorted(np.abs(d.poles)))
        rows.append(f"{d.axis:4} {d.bandwidth_hz:8.2f} {d.pid.kp:10.1f} {d.pid.ki:12.1f} {d.pid.kd:11.3f} "
                    f"{d.phase_margin_deg:7.1f} {d.gain_margin_db:6.1f} {d.crossover_hz:7.2f}  {radii}")
    return "\n".join(rows)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m gimbal_control.platform_loop_design", description=__doc__.split("\n\n")[0])
    ap.add_argument("--rate-hz", type=float, default=1000.0, help="control rate [Hz] (paper 3: 1000)")
    ap.add_argument("--derivative-tau-s", type=float, default=DEFAULT_DERIVATIVE_TAU_S,
                    help="derivative filter time constant [s]")
    for axis, name in (("a", "azimuth"), ("q", "inner-roll"), ("p", "pitch"), ("r", "outer-roll")):
        ap.add_argument(f"--{name}-bandwidth-hz", type=float, default=DEFAULT_BANDWIDTH_HZ[axis], dest=axis,
                        help=f"{name} triple-pole bandwidth [Hz]")
    args = ap.parse_args(argv)
    try:
        designs = design_all(args.rate_hz, {k: getattr(args, k) for k in "aqpr"}, args.derivative_tau_s)
    except ValueError as exc:
        ap.error(str(exc))
    print(f"paper 3 gimbal loops on the DTG pickoffs at {args.rate_hz:g} Hz (ZOH plant, discrete pole placement)")
    print(format_designs(designs))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
