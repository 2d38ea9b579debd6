"""Dynamic ship flexure from a hull-structure model driven by a sea (``flexure_dynamic_model: hull``).

The second-order Markov band (:class:`.markov.SecondOrderGaussMarkov`) is the dynamic-flexure
model the paper 5 filter assumes. This module makes the dynamic flexure between LGU1 and LGU2
from a model the filter does not contain: a frigate-sized hull girder bent by the waves of a
sea spectrum, met at the ship's speed and heading, through its first structural modes.

Sea. Long-crested, Bretschneider (two-parameter Pierson–Moskowitz, ITTC 1978) spectrum of
significant wave height H_s and modal (peak) period T_p, ω_p = 2π/T_p::

    S(ω) = (5/16) H_s² ω_p⁴ ω⁻⁵ exp(−(5/4)(ω_p/ω)⁴)   [m² s/rad],   ∫ S dω = H_s²/16

Sea states are the NATO sea-state numerals for the open ocean North Atlantic (STANAG 4194;
Lee & Bales 1980, "Environmental data for design of marine vehicles"): most probable modal
period and mean significant height, :data:`NATO_SEA_STATES` (SS3 0.88 m at 7.5 s, SS4 1.88 m
at 8.8 s, SS5 3.25 m at 9.7 s). The sea is synthesised as ``N`` components of random phase,
one at a random frequency in each frequency bin (seeded; no exact repeat period), amplitude
a_i = √(2 S(ω_i) Δω_i).

Encounter. A wave of frequency ω (deep water, k = ω²/g) met at ship speed U and wave heading
μ (180°: head seas, 90°: beam seas from starboard, 0°: following) is felt at
ω_e = ω − k U cos μ (negative ω_e, overtaking following seas: folded to |ω_e|).

Loads. Froude–Krylov pressure of each wave on a box hull (length L, beam B, draft T) with the
Smith depth decay e^{kz}: per unit length the vertical force (bottom), the lateral force
(sides) and the torque about the hull's longitudinal axis at mid-depth, each ∝ e^{−i k cos μ x}.
The hull floats freely: its rigid-body heave/pitch (sway/yaw, roll) take the load's mean and
first moment along the length (uniform mass and waterplane), so the girder carries the rest.
Integrated twice (shear, bending moment M(x)) or once (torque T(x)), the relative rotation of
the stations x1 (LGU1, near the master INS) and x2 (LGU2, at the peripheral device) is
``∫_{x1}^{x2} M/EI dx`` (pitch: vertical bending; yaw: horizontal bending) and
``∫_{x1}^{x2} T/GJ dx`` (roll: torsion): the quasi-static flexure u_j(t) per axis j.

Modes. Each axis' flexure goes through its first mode (2-node vertical, 2-node horizontal,
1st torsion) as a second-order system of natural frequency ω_n and damping ratio ζ, with unit
static gain::

    q̈ + 2ζω_n q̇ + ω_n² q = ω_n² u(t),    H(jω) = ω_n² / (ω_n² − ω² + 2jζω_n ω)

stepped exactly for an input linear over the step (first-order hold, matrix exponential) from
its steady state at t = 0; the hold itself passes a sampled sinusoid with gain sinc²(ωΔt/2)
(0.953 at the 1.2 Hz mode at 10 Hz, 1.000 at the 1 rad/s wave band). Below resonance H ≈ 1
(wave-frequency bending, the bulk); near ω_n it is springing. Slamming and whipping
(transients at ω_n), short-crested seas and higher hull modes are not modelled.

Hull. A 125 m frigate-sized hull (:class:`HullParams`): B 15 m, T 4.5 m, 3600 t. The girder
stiffnesses come from the mode frequencies through the uniform free-free beam, ω_1 =
4.730² √(EI/(m L⁴)) (bending) and ω_1 = (π/L) √(GJ/I_x) (torsion), with virtual masses:
vertical, Kumai's Δ_i = Δ (1.2 + B/(3T)) (so EI_v is what Kumai's formula
N_2v = 3.07·10⁶ √(I/(Δ_i L³)) cpm gives for the same 2-node frequency); horizontal, the
structure plus the Lewis/flat-plate sway added mass ρπT²/2; torsion, the roll gyradius 0.4 B
with 20 % added inertia. The mode figures are typical of a frigate hull and are assumptions,
not a particular ship's measurements: 2-node vertical 1.2 Hz, 2-node horizontal 1.8 Hz, first
torsion 2.4 Hz, 2 % of critical damping each.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.linalg import expm

from gimbal_kinematics.maths import validate as v

G = 9.80665
RHO_SEA = 1025.0

#: NATO sea state -> (mean significant wave height H_s [m], most probable modal period T_p [s]),
#: open ocean North Atlantic (STANAG 4194; Lee & Bales 1980).
NATO_SEA_STATES: dict[int, tuple[float, float]] = {
    3: (0.88, 7.5),
    4: (1.88, 8.8),
    5: (3.25, 9.7),
    6: (5.0, 12.4),
}

#: First free-free bending eigenvalue (β L)² of a uniform beam.
_BEAM_EIG = 4.730040745 ** 2


def bretschneider_psd(omega: np.ndarray | float, hs_m: float, tp_s: float) -> np.ndarray:
    """One-sided Bretschneider wave-elevation spectrum S(ω) [m² s/rad] at ω [rad/s] (> 0)."""
    w = np.asarray(omega, dtype=float)
    wp = 2.0 * math.pi / tp_s
    with np.errstate(divide="ignore", over="ignore", invalid="ignore"):
        s = (5.0 / 16.0) * hs_m ** 2 * wp ** 4 / w ** 5 * np.exp(-1.25 * (wp / w) ** 4)
    return np.where(w > 0.0, s, 0.0)


def encounter_frequency(omega: np.ndarray | float, speed_m_s: float, heading_rad: float) -> np.ndarray:
    """ω_e = ω − (ω²/g) U cos μ [rad/s] (deep water; μ = π: head seas); may be negative."""
    w = np.asarray(omega, dtype=float)
    return w - w * w / G * speed_m_s * math.cos(heading_rad)


def mode_response(omega: np.ndarray | float, freq_hz: float, damping: float) -> np.ndarray:
    """H(jω) = ω_n²/(ω_n² − ω² + 2jζω_nω) of one mode (unit static gain), complex."""
    wn = 2.0 * math.pi * freq_hz
    w = np.asarray(omega, dtype=float)
    return wn * wn / (wn * wn - w * w + 2j * damping * wn * w)


def sea_state(number: int, hs_m: float = 0.0, tp_s: float = 0.0) -> tuple[float, float]:
    """(H_s, T_p) of NATO sea state ``number``, each replaced by ``hs_m``/``tp_s`` when > 0."""
    if number not in NATO_SEA_STATES:
        raise ValueError(f"sea_state must be one of {sorted(NATO_SEA_STATES)}, got {number}")
    h, t = NATO_SEA_STATES[number]
    return (hs_m if hs_m > 0.0 else h), (tp_s if tp_s > 0.0 else t)


@dataclass(frozen=True)
class HullParams:
    """Hull, sea and route of the hull flexure model (module docstring; SI inside).

    Attributes:
        sea_state: NATO sea state (3..6) giving H_s and T_p.
        wave_height_m, wave_period_s: override H_s, T_p when > 0.
        speed_m_s: ship speed U [m/s] (default 7.72 m/s = 15 kn).
        wave_heading_rad: wave heading μ [rad] (π: head seas; default 150°, bow seas).
        mode_freq_hz: first mode per axis (roll: torsion, pitch: vertical, yaw: horizontal) [Hz].
        damping_ratio: modal damping ratio per axis.
        stations_m: LGU1 and LGU2 positions along the hull from amidships, forward positive [m].
        length_m, beam_m, draft_m, displacement_t: the hull.
        n_waves: wave components; omega_range_rad_s: their frequency range [rad/s].
    """

    sea_state: int = 4
    wave_height_m: float = 0.0
    wave_period_s: float = 0.0
    speed_m_s: float = 7.72
    wave_heading_rad: float = math.radians(150.0)
    mode_freq_hz: tuple[float, float, float] = (2.4, 1.2, 1.8)
    damping_ratio: tuple[float, float, float] = (0.02, 0.02, 0.02)
    stations_m: tuple[float, float] = (0.0, 30.0)
    length_m: float = 125.0
    beam_m: float = 15.0
    draft_m: float = 4.5
    displacement_t: float = 3600.0
    n_waves: int = 256
    omega_range_rad_s: tuple[float, float] = (0.2, 3.0)

    def __post_init__(self) -> None:
        sea_state(self.sea_state, self.wave_height_m, self.wave_period_s)
        for name in ("speed_m_s", "wave_height_m", "wave_period_s"):
            v.nonneg(name, getattr(self, name))
        v.finite("wave_heading_rad", self.wave_heading_rad)
        for name in ("mode_freq_hz", "damping_ratio"):
            vals = v.per_axis(name, getattr(self, name), 3)
            object.__setattr__(self, name, tuple(vals))
            for x in vals:
                v.positive(name, x)
        for name in ("length_m", "beam_m", "draft_m", "displacement_t"):
            v.positive(name, getattr(self, name))
        if len(self.stations_m) != 2:
            raise ValueError(f"stations_m must be (LGU1, LGU2) [m], got {self.stations_m}")
        x1, x2 = (float(x) for x in self.stations_m)
        half = 0.5 * self.length_m
        if not (-half <= x1 <= half and -half <= x2 <= half and x1 != x2):
            raise ValueError(f"stations_m must be two different positions within ±{half} m, got {self.stations_m}")
        if self.n_waves < 1:
            raise ValueError(f"n_waves must be >= 1, got {self.n_waves}")
        lo, hi = self.omega_range_rad_s
        if not 0.0 < lo < hi:
            raise ValueError(f"omega_range_rad_s must be 0 < low < high, got {self.omega_range_rad_s}")

    @property
    def sea(self) -> tuple[float, float]:
        """(H_s [m], T_p [s])."""
        return sea_state(self.sea_state, self.wave_height_m, self.wave_period_s)

    def stiffness(self) -> tuple[float, float, float]:
        """(GJ, EI_v, EI_h) [N m²] from the mode frequencies (module docstring)."""
        L, B, T = self.length_m, self.beam_m, self.draft_m
        m_s = self.displacement_t * 1e3 / L
        m_v = m_s * (1.2 + B / (3.0 * T))  # Kumai's virtual mass
        m_h = m_s + RHO_SEA * math.pi * T * T / 2.0
        i_x = 1.2 * m_s * (0.4 * B) ** 2
        wt, wv, wh = (2.0 * math.pi * f for f in self.mode_freq_hz)
        gj = (wt * L / math.pi) ** 2 * i_x
        ei_v = (wv / _BEAM_EIG) ** 2 * m_v * L ** 4
        ei_h = (wh / _BEAM_EIG) ** 2 * m_h * L ** 4
        return gj, ei_v, ei_h

    def flexure_rao(self, omega: np.ndarray) -> np.ndarray:
        """Quasi-static relative rotation of the LGU stations per metre of wave amplitude,
        complex, (3, n) for (roll, pitch, yaw) at wave frequencies ``omega`` (n,) [rad/s]."""
        L, B, T = self.length_m, self.beam_m, self.draft_m
        w = np.asarray(omega, float)
        k = w * w / G
        mu = self.wave_heading_rad
        kx, ky = k * math.cos(mu), k * math.sin(mu)
        ny, nz, nx = 15, 15, 161
        y = np.linspace(-B / 2, B / 2, ny)
        z = np.linspace(-T, 0.0, nz)
        x = np.linspace(-L / 2, L / 2, nx)
        z_s = -T + 0.5 * (T + 5.5)  # torsion axis at mid-depth (depth = draft + 5.5 m freeboard)
        rg = RHO_SEA * G
        # Per unit length, a wave crest at x = 0: bottom pressure p(-T, y), side pressures p(z, ±B/2).
        pb = rg * np.exp(-k * T)[:, None] * np.exp(-1j * ky[:, None] * y[None, :])           # (n, ny)
        side = rg * np.exp(k[:, None] * z[None, :])                                          # (n, nz)
        ps_port = side * np.exp(-1j * ky * B / 2)[:, None]
        ps_stbd = side * np.exp(+1j * ky * B / 2)[:, None]
        fz = np.trapezoid(pb, y, axis=1)
        fy = np.trapezoid(ps_stbd - ps_port, z, axis=1)
        mx = np.trapezoid(pb * y[None, :], y, axis=1) - np.trapezoid((z[None, :] - z_s) * (ps_stbd - ps_port), z, axis=1)
        phase = np.exp(-1j * kx[:, None] * x[None, :])                                       # (n, nx)
        gj, ei_v, ei_h = self.stiffness()
        x1, x2 = (float(s) for s in self.stations_m)
        sel = (x >= min(x1, x2)) & (x <= max(x1, x2))
        sign = 1.0 if x2 > x1 else -1.0
        out = np.empty((3, w.size), complex)
        # Bending: remove the rigid-body reaction (mean and first moment), integrate twice.
        basis = np.vstack([np.ones(nx), x])                                                  # (2, nx)
        proj = np.linalg.lstsq(basis.T, phase.T, rcond=None)[0]                              # (2, n)
        free = phase - (basis.T @ proj).T                                                    # (n, nx)
        shear = _cumtrapz(free, x)
        moment = _cumtrapz(shear, x)
        for row, f, ei in ((1, fz, ei_v), (2, fy, ei_h)):
            curv = f[:, None] * moment / ei
            out[row] = sign * _trapz_sel(curv, x, sel)
        # Torsion: remove the mean torque (rigid roll), integrate once.
        tfree = phase - phase.mean(axis=1, keepdims=True)
        torque = _cumtrapz(tfree, x) * mx[:, None]
        out[0] = sign * _trapz_sel(torque / gj, x, sel)
        return out


def _cumtrapz(f: np.ndarray, x: np.ndarray) -> np.ndarray:
    dx = np.diff(x)
    inc = 0.5 * (f[:, 1:] + f[:, :-1]) * dx[None, :]
    return np.concatenate([np.zeros((f.shape[0], 1), f.dtype), np.cumsum(inc, axis=1)], axis=1)


def _trapz_sel(f: np.ndarray, x: np.ndarray, sel: np.ndarray) -> np.ndarray:
    return np.trapezoid(f[:, sel], x[sel], axis=1)


def mode_discrete(freq_hz: float, damping: float, dt: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(Φ, Γ0, Γ1) of the exact first-order-hold step of ``q̈ + 2ζω_n q̇ + ω_n² q = ω_n² u``
    for state (q, q̇): ``x' = Φ x + Γ0 u_k + Γ1 (u_{k+1} − u_k)/dt``."""
    wn = 2.0 * math.pi * freq_hz
    M = np.zeros((4, 4))
    M[:2, :2] = [[0.0, 1.0], [-wn * wn, -2.0 * damping * wn]]
    M[1, 2] = wn * wn
    M[2, 3] = 1.0
    E = expm(M * dt)
    return E[:2, :2], E[:2, 2], E[:2, 3]  # Γ1 multiplies the slope [1/s]


class HullFlexure:
    """Dynamic hull flexure θ (roll, pitch, yaw) [rad] between LGU1 and LGU2 (module docstring),
    with the :class:`.markov.SecondOrderGaussMarkov` interface (``value``, ``rate``, ``step``).

    Args:
        params: hull, sea and route.
        rng: the run's seeded Generator (wave frequencies and phases).
        dt: default step [s].
    """

    def __init__(self, params: HullParams, rng: np.random.Generator, dt: float) -> None:
        v.of_type("params", params, HullParams)
        v.positive("dt", dt)
        self.params = p = params
        hs, tp = p.sea
        lo, hi = p.omega_range_rad_s
        edges = np.linspace(lo, hi, p.n_waves + 1)
        dw = np.diff(edges)
        omega = edges[:-1] + rng.uniform(0.0, 1.0, p.n_waves) * dw
        phase = rng.uniform(0.0, 2.0 * math.pi, p.n_waves)
        amp = np.sqrt(2.0 * bretschneider_psd(omega, hs, tp) * dw)
        we = encounter_frequency(omega, p.speed_m_s, p.wave_heading_rad)
        rao = p.flexure_rao(omega)                                 # (3, n)
        coef = amp[None, :] * rao * np.exp(1j * phase)[None, :]    # complex amplitude of e^{i ω_e t}
        neg = we < 0.0
        coef[:, neg] = np.conj(coef[:, neg])
        we = np.abs(we)
        #: Wave components: frequency, encounter frequency [rad/s], amplitude [m].
        self.omega, self.omega_e, self.amplitude = omega, we, amp
        self._coef = coef
        self._ajw = 1j * we
        self.t = 0.0
        self._u = self.quasi_static(0.0)
        # Steady state at t = 0: each component through H(jω_e).
        x = np.empty((3, 2))
        for j in range(3):
            h = mode_response(we, p.mode_freq_hz[j], p.damping_ratio[j])
            c = coef[j] * h
            x[j] = (float(np.sum(c).real), float(np.sum(c * self._ajw).real))
        self._x = x
        self._dt = -1.0
        self._set_dt(dt)

    def quasi_static(self, t: float) -> np.ndarray:
        """The wave-frequency flexure u(t) the modes are driven by (unit static gain) [rad], (3,)."""
        return np.real(self._coef @ np.exp(self._ajw * t))

    def steady_state(self, t: float) -> np.ndarray:
        """The closed-form response q(t) = Σ Re{H(jω_e) c e^{jω_e t}} [rad], (3,) (no stepping)."""
        e = np.exp(self._ajw * t)
        p = self.params
        return np.array([float(np.real(np.sum(self._coef[j] * mode_response(self.omega_e, p.mode_freq_hz[j],
                                                                             p.damping_ratio[j]) * e)))
                         for j in range(3)])

    def _set_dt(self, dt: float) -> None:
        self._disc = [mode_discrete(f, z, dt) for f, z in zip(self.params.mode_freq_hz, self.params.damping_ratio)]
        self._dt = dt

    def step(self, dt: float | None = None) -> None:
        """Advance by ``dt`` [s] (default: the constructor's)."""
        h = self._dt if dt is None else dt
        if h != self._dt:
            self._set_dt(h)
        self.t += h
        u1 = self.quasi_static(self.t)
        slope = (u1 - self._u) / h
        for j, (Phi, g0, g1) in enumerate(self._disc):
            self._x[j] = Phi @ self._x[j] + g0 * self._u[j] + g1 * slope[j]
        self._u = u1

    @property
    def value(self) -> list[float]:
        """Current θ per axis (3,), a copy."""
        return [float(a) for a in self._x[:, 0]]

    @property
    def rate(self) -> list[float]:
        """Current θ̇ per axis (3,), a copy."""
        return [float(a) for a in self._x[:, 1]]

    def rms(self) -> np.ndarray:
        """Stationary RMS of θ per axis [rad], (3,), from the components (Σ |H c|²/2)."""
        p = self.params
        return np.sqrt(np.array([0.5 * np.sum(np.abs(self._coef[j] * mode_response(
            self.omega_e, p.mode_freq_hz[j], p.damping_ratio[j])) ** 2) for j in range(3)]))
