"""Joint-angle encoders: readout noise (paper 1), line quantisation and pulse-count
velocity (paper 2).

Position. An incremental encoder with N lines/rev and ×q edge decoding counts
``N q`` edges per revolution, quantum ``δ = 2π/(N q)``. We use a mid-tread count
``c = floor(θ/δ + 1/2)`` (error uniform in ±δ/2, zero mean, RMS δ/√12) and report
``c δ`` plus white readout noise (paper 1's 0.05° "noise level", which models resolver /
interpolation electronics; the edge counter itself sees the true edges). ``lines_per_rev
= 0`` means an unquantised sensor. Angles are multi-turn (not wrapped).

Velocity (paper 2, eq. 1, re-derived). Over a gate window T_g the counter collects
Δc edges, i.e. a pulse frequency ``f = Δc/T_g``; the shaft turns ``f/(N q)`` rev/s, so
``ω = 60 f/(N q)`` rpm ``= 2π Δc/(N q T_g)`` rad/s (paper 2 writes 60 f/N with q = 1).
Δc is an integer, so the resolution is ``2π/(N q T_g)`` and any speed below it reads as
zero or one count. For paper 2's 1024 lines, q = 1 and our chosen T_g = 0.2 s this is
360°/(1024 × 0.2 s) = 1.76 °/s — the paper's "≈ 2 deg/sec". (×4 decoding with a 50 ms
gate gives the same figure.) The gate is a whole number of simulation steps,
``round(T_g/Δt)``, and the reading is the average over the last completed gate, held
until the next one (so it lags by about T_g/2).
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from gimbal_kinematics.maths import validate as v
from gimbal_kinematics.maths.units import DEG
from ._normals import NormalStream
from .sensor_kernels import cyclic_error, encoder_step


@dataclass(frozen=True)
class EncoderParams:
    """Encoder parameters (validated, immutable).

    Attributes:
        noise_deg: RMS white readout noise on the angle [°].
        lines_per_rev: optical lines per revolution (0 = no quantisation).
        quadrature: edges counted per line: 1, 2 or 4.
        velocity_gate_s: pulse-counting gate time T_g [s].
        cyclic_error_arcsec: peak of the converter's cyclic error [″] (module docstring).
        cyclic_harmonic: its harmonic of the shaft angle (1 to 8).
    """

    noise_deg: float = 0.0
    lines_per_rev: int = 0
    quadrature: int = 1
    velocity_gate_s: float = 0.01
    cyclic_error_arcsec: float = 0.0
    cyclic_harmonic: int = 2

    def __post_init__(self) -> None:
        v.nonneg_finite("noise_deg", self.noise_deg)
        if not isinstance(self.lines_per_rev, int) or isinstance(self.lines_per_rev, bool) or self.lines_per_rev < 0:
            raise ValueError(f"lines_per_rev must be an int >= 0, got {self.lines_per_rev!r}")
        if self.quadrature not in (1, 2, 4):
            raise ValueError(f"quadrature must be 1, 2 or 4, got {self.quadrature!r}")
        v.positive("velocity_gate_s", self.velocity_gate_s)
        v.nonneg_finite("cyclic_error_arcsec", self.cyclic_error_arcsec)
        if not isinstance(self.cyclic_harmonic, int) or isinstance(self.cyclic_harmonic, bool) \
                or not 1 <= self.cyclic_harmonic <= 8:
            raise ValueError(f"cyclic_harmonic must be an int in [1, 8], got {self.cyclic_harmonic!r}")

    @property
    def counts_per_rev(self) -> int:
        return self.lines_per_rev * self.quadrature


class EncoderModel:
    """n encoders sampled every step: angle and pulse-count velocity.

    Args:
        params: encoder parameters (shared by the n axes).
        n_axes: number of encoders (3 in paper 1: turret, azimuth, elevation).
        rng: the run's seeded Generator (readout noise).
        dt: fixed sample period [s]; the velocity gate is a whole number of these.
    """

    def __init__(self, params: EncoderParams, n_axes: int, rng: np.random.Generator, dt: float) -> None:
        v.of_type("params", params, EncoderParams)
        if not isinstance(n_axes, int) or n_axes < 1:
            raise ValueError(f"n_axes must be an int >= 1, got {n_axes!r}")
        v.positive("dt", dt)
        self.params = params
        self.n_axes = n_axes
        self.dt = dt
        self._normals = NormalStream(rng)
        self._noise = params.noise_deg * DEG
        cpr = params.counts_per_rev
        #: Angle quantum δ [rad] (0 when unquantised).
        self.quantum_rad = 2.0 * math.pi / cpr if cpr > 0 else 0.0
        self._gate_steps = max(1, round(params.velocity_gate_s / dt))
        #: Gate actually used, a whole number of steps [s].
        self.gate_time_s = self._gate_steps * dt
        # the kernel's state (has a reference, gate step, reference counts, held rates)
        self._state = np.zeros(2 + 2 * n_axes)
        self._angles = np.zeros(n_axes)
        self._rates = np.zeros(n_axes)
        self._no_noise = np.zeros(n_axes)
        #: Cyclic error: peak [rad], harmonic and the unit's phase per axis [rad] (drawn from a
        #: stream of its own, so the readout noise is the same draws with and without it)
        self.cyclic_rad = params.cyclic_error_arcsec * DEG / 3600.0
        self.cyclic_harmonic = float(params.cyclic_harmonic)
        self.cyclic_phases = (rng.spawn(1)[0].uniform(0.0, 2.0 * math.pi, n_axes) if self.cyclic_rad > 0.0
                              else np.zeros(n_axes))
        self._read = np.zeros(n_axes)

    @property
    def velocity_resolution_rad_s(self) -> float:
        """One count per gate, ``δ/T_g`` [rad/s] (0 when unquantised)."""
        return self.quantum_rad / self.gate_time_s

    def step(self, angles_true: Sequence[float]) -> tuple[list[float], list[float]]:
        """Sample the true joint angles (n,) [rad]; returns ``(angles_meas, rates_meas)``.

        ``angles_meas`` (n,) [rad]: quantised angle plus readout noise. ``rates_meas`` (n,)
        [rad/s]: count difference over the last completed gate / T_g (0 until the first
        gate completes).
        """
        n = self.n_axes
        if len(angles_true) != n:
            raise ValueError(f"angles_true must have {n} elements, got {len(angles_true)}")
        z = self._no_noise
        if self._noise > 0.0:
            buf, j = self._normals.take(n)
            z = np.array(buf[j:j + n], dtype=float)
        angles = np.asarray(angles_true, dtype=float)
        if self.cyclic_rad > 0.0:
            cyclic_error(angles, n, self.cyclic_rad, self.cyclic_harmonic, self.cyclic_phases, self._read)
            angles = self._read
        encoder_step(self._state, n, angles, self.quantum_rad, self._noise,
                     self._gate_steps, self.gate_time_s, z, self._angles, self._rates)
        return self._angles.tolist(), self._rates.tolist()


#: Paper 1 encoders (turret, azimuth, elevation): 0.05° readout noise, unquantised.
PAPER1_ENCODER = EncoderParams(noise_deg=0.05)

#: Paper 2 encoders: 1024 lines/rev, ×1, 0.2 s gate -> 1.76 °/s velocity resolution.
PAPER2_ENCODER = EncoderParams(lines_per_rev=1024, quadrature=1, velocity_gate_s=0.2)
