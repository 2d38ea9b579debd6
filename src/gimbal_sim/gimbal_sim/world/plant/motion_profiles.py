"""Host motion profiles: exact (analytic) attitude, rates and accelerations versus time.

Every profile is a :class:`SinusoidProfile`: each of the four angle channels (roll φ,
pitch θ, yaw ψ of b w.r.t. NED, turret ψt about b-z) and each of the three pivot linear
acceleration channels (in b, relative to the earth) is

    x(t) = offset + rate·t + Σ_k A_k sin(ω_k t + φ_k),

differentiated term by term, so ``sample(t)`` is exact to rounding. Body rates and
accelerations come from :func:`gimbal_kinematics.gimbal.host_kernels.host_fields`.

Profiles (``make_profile(name, params)``; every ``params`` key is optional):

``paper1_land_vehicle`` (paper 1 §6, docs/spec.md §3.1), degrees with t in s::

    φ  =  1.5 sin(0.6t) + 1.0 sin(0.3t)
    θ  = −1.5 sin(0.6t) + 1.0 sin(0.3t)
    ψ  =  1.5 sin(0.6t + π/3) + 1.0 sin(0.3t + π/3)
    ψt =  0.1 sin(60t + π/4)

  plus structural modes 0.01 sin(101t) + 0.0001 sin(258t) on every one of φ, θ, ψ, ψt;
  pivot accelerations zero. Keys: ``lat_deg``, ``lon_deg``, ``height_m``,
  ``structural_modes`` (bool, default true).

``paper5_ship`` (paper 5 §5.1, docs/spec.md §3.5): heading/pitch/roll sinusoids of amplitude
  3°, 3°, 5°. The paper gives no periods; the defaults (heading 15 s, pitch 6 s, roll 10 s)
  are typical of a medium ship in a moderate sea. Keys: ``heading_amplitude_deg``,
  ``pitch_amplitude_deg``, ``roll_amplitude_deg``, ``heading_period_s``,
  ``pitch_period_s``, ``roll_period_s``, ``heading_phase_rad``, ``pitch_phase_rad``,
  ``roll_phase_rad``, ``mean_heading_deg``, ``lat_deg``, ``lon_deg``, ``height_m``.

``static``: fixed attitude at a site, zero rates. Keys: ``lat_deg``, ``lon_deg``,
  ``height_m``, ``roll_deg``, ``pitch_deg``, ``yaw_deg``, ``psi_t_deg``.

``sinusoids``: user-defined. Keys ``lat_deg``, ``lon_deg``, ``height_m`` and the channels
  ``roll``, ``pitch``, ``yaw``, ``psi_t`` (degrees) and ``accel_x_m_s2``,
  ``accel_y_m_s2``, ``accel_z_m_s2`` (m/s²). A channel is either a list of terms or a
  mapping ``{offset_deg, rate_deg_s, terms}`` (``offset_m_s2``, ``rate_m_s3`` for the
  acceleration channels). A term is a list ``[amplitude, frequency_rad_s, phase_rad]`` or a
  mapping with ``amplitude_deg`` (``amplitude_m_s2``), exactly one of ``frequency_rad_s``
  and ``period_s``, and optional ``phase_rad``. Example (YAML)::

      roll: [[1.5, 0.6, 0.0], [1.0, 0.3, 0.0]]
      yaw: {offset_deg: 30, terms: [{amplitude_deg: 3, period_s: 15}]}
"""
from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from gimbal_kinematics.gimbal.host_state import HostState
from gimbal_kinematics.maths.units import DEG

from . import profile_kernels


@dataclass(frozen=True)
class Site:
    """Geodetic position of the host: ``lat_deg``, ``lon_deg`` [deg], ``height_m`` [m]."""

    lat_deg: float = 0.0
    lon_deg: float = 0.0
    height_m: float = 0.0

    def __post_init__(self) -> None:
        if not math.isfinite(self.lat_deg) or abs(self.lat_deg) > 90.0:
            raise ValueError(f"lat_deg must be within [-90, 90], got {self.lat_deg}")
        if not math.isfinite(self.lon_deg) or abs(self.lon_deg) > 360.0:
            raise ValueError(f"lon_deg must be within [-360, 360], got {self.lon_deg}")
        if not math.isfinite(self.height_m) or abs(self.height_m) > 1e5:
            raise ValueError(f"height_m must be finite and |height_m| <= 1e5, got {self.height_m}")

    @property
    def lat_rad(self) -> float:
        return self.lat_deg * DEG

    @property
    def lon_rad(self) -> float:
        return self.lon_deg * DEG


@dataclass(frozen=True)
class SinusoidChannel:
    """x(t) = offset + rate·t + Σ amplitude_k sin(frequency_k t + phase_k), in SI units.

    ``amplitudes`` [rad or m/s²], ``frequencies_rad_s`` (>= 0) and ``phases_rad`` are
    equal-length tuples. ``name`` appears in error messages.
    """

    offset: float = 0.0
    rate: float = 0.0
    amplitudes: tuple[float, ...] = ()
    frequencies_rad_s: tuple[float, ...] = ()
    phases_rad: tuple[float, ...] = ()
    name: str = "channel"
    _terms: tuple = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        n = len(self.amplitudes)
        if len(self.frequencies_rad_s) != n or len(self.phases_rad) != n:
            raise ValueError(
                f"{self.name}: amplitudes, frequencies_rad_s and phases_rad must have equal "
                f"lengths, got {n}, {len(self.frequencies_rad_s)}, {len(self.phases_rad)}"
            )
        for label, value in (("offset", self.offset), ("rate", self.rate)):
            if not math.isfinite(value):
                raise ValueError(f"{self.name}.{label} must be finite, got {value}")
        for k, (a, w, ph) in enumerate(zip(self.amplitudes, self.frequencies_rad_s, self.phases_rad)):
            if not math.isfinite(a):
                raise ValueError(f"{self.name}[{k}].amplitude must be finite, got {a}")
            if not math.isfinite(w) or w < 0.0:
                raise ValueError(f"{self.name}[{k}].frequency_rad_s must be finite and >= 0, got {w}")
            if not math.isfinite(ph):
                raise ValueError(f"{self.name}[{k}].phase_rad must be finite, got {ph}")
        # (ω, φ, A, Aω, Aω²) precomputed once: sample() runs in the lockstep hot path.
        terms = tuple(
            (float(w), float(ph), float(a), float(a * w), float(a * w * w))
            for a, w, ph in zip(self.amplitudes, self.frequencies_rad_s, self.phases_rad)
            if a != 0.0
        )
        object.__setattr__(self, "_terms", terms)


_ZERO = SinusoidChannel(name="zero")


@dataclass(frozen=True)
class SinusoidProfile:
    """Host motion built from sinusoid channels (module docstring); angles in rad.

    ``roll``, ``pitch``, ``yaw``: 3-2-1 Euler angles of b w.r.t. NED; ``psi_t``: turret
    azimuth about b-z; ``accel_x/y/z``: pivot acceleration relative to the earth in b
    [m/s²]. ``site`` gives latitude/height for gravity and earth rate.
    """

    name: str
    site: Site = Site()
    roll: SinusoidChannel = _ZERO
    pitch: SinusoidChannel = _ZERO
    yaw: SinusoidChannel = _ZERO
    psi_t: SinusoidChannel = _ZERO
    accel_x: SinusoidChannel = _ZERO
    accel_y: SinusoidChannel = _ZERO
    accel_z: SinusoidChannel = _ZERO
    _packed: tuple = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        for label in ("roll", "pitch", "yaw", "psi_t", "accel_x", "accel_y", "accel_z"):
            if not isinstance(getattr(self, label), SinusoidChannel):
                raise ValueError(f"{self.name}: {label} must be a SinusoidChannel")
        if not isinstance(self.site, Site):
            raise ValueError(f"{self.name}: site must be a Site")
        # Pitch near ±90° makes the Euler-rate map singular.
        bound = abs(self.pitch.offset) + sum(abs(a) for a in self.pitch.amplitudes)
        if self.pitch.rate != 0.0 or bound >= math.radians(89.0):
            raise ValueError(
                f"{self.name}: pitch must stay within ±89° (no drift rate), bound is "
                f"{math.degrees(bound):.3f}° with rate {self.pitch.rate}"
            )
        object.__setattr__(self, "_packed", profile_kernels.pack(
            (self.roll, self.pitch, self.yaw, self.psi_t, self.accel_x, self.accel_y, self.accel_z)))

    @property
    def constant(self) -> bool:
        """Whether the host never moves relative to NED (every channel a constant)."""
        lines, terms, _ = self._packed
        return terms.shape[0] == 0 and not lines[:, 1].any()

    @property
    def packed(self) -> tuple:
        """(lines, terms, starts): the profile as the arrays of :mod:`.profile_kernels`."""
        return self._packed

    def sample(self, t: float) -> HostState:
        """Exact host state at time ``t`` [s] (the compiled :func:`.profile_kernels.sample`)."""
        lines, terms, starts = self._packed
        return HostState(*profile_kernels.sample(lines, terms, starts, float(t)))


# ---------------------------------------------------------------- the named profiles

_PAPER1_MODES = ((0.01, 101.0, 0.0), (0.0001, 258.0, 0.0))


def _deg_channel(name: str, terms: Sequence[tuple[float, float, float]], offset_deg: float = 0.0,
                 rate_deg_s: float = 0.0) -> SinusoidChannel:
    """Channel from (amplitude_deg, frequency_rad_s, phase_rad) terms."""
    return SinusoidChannel(
        offset=offset_deg * DEG,
        rate=rate_deg_s * DEG,
        amplitudes=tuple(a * DEG for a, _, _ in terms),
        frequencies_rad_s=tuple(float(w) for _, w, _ in terms),
        phases_rad=tuple(float(ph) for _, _, ph in terms),
        name=name,
    )


def paper1_land_vehicle(site: Site = Site(), structural_modes: bool = True) -> SinusoidProfile:
    """Paper 1 §6 rough-terrain land vehicle with its revolving turret (module docstring)."""
    modes = _PAPER1_MODES if structural_modes else ()
    third = math.pi / 3.0
    return SinusoidProfile(
        name="paper1_land_vehicle",
        site=site,
        roll=_deg_channel("roll", ((1.5, 0.6, 0.0), (1.0, 0.3, 0.0)) + modes),
        pitch=_deg_channel("pitch", ((-1.5, 0.6, 0.0), (1.0, 0.3, 0.0)) + modes),
        yaw=_deg_channel("yaw", ((1.5, 0.6, third), (1.0, 0.3, third)) + modes),
        psi_t=_deg_channel("psi_t", ((0.1, 60.0, math.pi / 4.0),) + modes),
    )


def paper5_ship(
    site: Site = Site(),
    heading_amplitude_deg: float = 3.0,
    pitch_amplitude_deg: float = 3.0,
    roll_amplitude_deg: float = 5.0,
    heading_period_s: float = 15.0,
    pitch_period_s: float = 6.0,
    roll_period_s: float = 10.0,
    heading_phase_rad: float = 0.0,
    pitch_phase_rad: float = 0.0,
    roll_phase_rad: float = 0.0,
    mean_heading_deg: float = 0.0,
) -> SinusoidProfile:
    """Paper 5 §5.1 ship: one sinusoid per axis (module docstring for the defaults)."""
    for label, period in (("heading_period_s", heading_period_s), ("pitch_period_s", pitch_period_s),
                          ("roll_period_s", roll_period_s)):
        if not math.isfinite(period) or period <= 0.0:
            raise ValueError(f"paper5_ship: {label} must be > 0, got {period}")
    two_pi = 2.0 * math.pi
    return SinusoidProfile(
        name="paper5_ship",
        site=site,
        roll=_deg_channel("roll", ((roll_amplitude_deg, two_pi / roll_period_s, roll_phase_rad),)),
        pitch=_deg_channel("pitch", ((pitch_amplitude_deg, two_pi / pitch_period_s, pitch_phase_rad),)),
        yaw=_deg_channel("yaw", ((heading_amplitude_deg, two_pi / heading_period_s, heading_phase_rad),),
                         offset_deg=mean_heading_deg),
    )


def static_base(site: Site = Site(), roll_deg: float = 0.0, pitch_deg: float = 0.0,
                yaw_deg: float = 0.0, psi_t_deg: float = 0.0) -> SinusoidProfile:
    """Host at rest relative to the earth at ``site`` with a fixed attitude."""
    return SinusoidProfile(
        name="static",
        site=site,
        roll=_deg_channel("roll", (), roll_deg),
        pitch=_deg_channel("pitch", (), pitch_deg),
        yaw=_deg_channel("yaw", (), yaw_deg),
        psi_t=_deg_channel("psi_t", (), psi_t_deg),
    )


# ---------------------------------------------------------------- dict (YAML) front end

_ANGLE_CHANNELS = ("roll", "pitch", "yaw", "psi_t")
_ACCEL_CHANNELS = {"accel_x_m_s2": "accel_x", "accel_y_m_s2": "accel_y", "accel_z_m_s2": "accel_z"}
_SITE_KEYS = ("lat_deg", "lon_deg", "height_m")


def _number(profile: str, key: str, value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ValueError(f"{profile}: {key} must be a number, got {value!r}")
    value = float(value)
    if not math.isfinite(value):
        raise ValueError(f"{profile}: {key} must be finite, got {value}")
    return value


def _check_keys(profile: str, params: Mapping[str, Any], allowed: Sequence[str]) -> None:
    unknown = sorted(set(params) - set(allowed))
    if unknown:
        raise ValueError(
            f"{profile}: unknown parameter(s) {', '.join(map(str, unknown))}; "
            f"allowed: {', '.join(allowed)}"
        )


def _site(profile: str, params: Mapping[str, Any]) -> Site:
    values = {k: _number(profile, k, params[k]) for k in _SITE_KEYS if k in params}
    try:
        return Site(**values)
    except ValueError as exc:
        raise ValueError(f"{profile}: {exc}") from None


def _term(profile: str, where: str, term: Any, amp_key: str, scale: float) -> tuple[float, float, float]:
    if isinstance(term, Mapping):
        _check_keys(f"{profile}: {where}", term, (amp_key, "frequency_rad_s", "period_s", "phase_rad"))
        if amp_key not in term:
            raise ValueError(f"{profile}: {where} needs {amp_key}")
        amp = _number(profile, f"{where}.{amp_key}", term[amp_key])
        has_f, has_p = "frequency_rad_s" in term, "period_s" in term
        if has_f == has_p:
            raise ValueError(f"{profile}: {where} needs exactly one of frequency_rad_s and period_s")
        if has_p:
            period = _number(profile, f"{where}.period_s", term["period_s"])
            if period <= 0.0:
                raise ValueError(f"{profile}: {where}.period_s must be > 0, got {period}")
            freq = 2.0 * math.pi / period
        else:
            freq = _number(profile, f"{where}.frequency_rad_s", term["frequency_rad_s"])
        phase = _number(profile, f"{where}.phase_rad", term.get("phase_rad", 0.0))
    elif isinstance(term, Sequence) and not isinstance(term, str) and len(term) == 3:
        amp = _number(profile, f"{where}[0] ({amp_key})", term[0])
        freq = _number(profile, f"{where}[1] (frequency_rad_s)", term[1])
        phase = _number(profile, f"{where}[2] (phase_rad)", term[2])
    else:
        raise ValueError(
            f"{profile}: {where} must be [{amp_key}, frequency_rad_s, phase_rad] or a mapping, got {term!r}"
        )
    if freq < 0.0:
        raise ValueError(f"{profile}: {where} frequency_rad_s must be >= 0, got {freq}")
    return amp * scale, freq, phase


def _channel(profile: str, key: str, spec: Any, unit: str, rate_unit: str, scale: float,
             name: str) -> SinusoidChannel:
    offset = rate = 0.0
    if isinstance(spec, Mapping):
        off_key, rate_key = f"offset_{unit}", f"rate_{rate_unit}"
        _check_keys(f"{profile}: {key}", spec, (off_key, rate_key, "terms"))
        offset = _number(profile, f"{key}.{off_key}", spec.get(off_key, 0.0)) * scale
        rate = _number(profile, f"{key}.{rate_key}", spec.get(rate_key, 0.0)) * scale
        terms = spec.get("terms", [])
    else:
        terms = spec
    if isinstance(terms, (str, Mapping)) or not isinstance(terms, Sequence):
        raise ValueError(f"{profile}: {key} terms must be a list, got {terms!r}")
    parsed = [_term(profile, f"{key}[{k}]", term, f"amplitude_{unit}", scale) for k, term in enumerate(terms)]
    try:
        return SinusoidChannel(
            offset=offset, rate=rate,
            amplitudes=tuple(t[0] for t in parsed),
            frequencies_rad_s=tuple(t[1] for t in parsed),
            phases_rad=tuple(t[2] for t in parsed),
            name=name,
        )
    except ValueError as exc:
        raise ValueError(f"{profile}: {exc}") from None


def _make_sinusoids(params: Mapping[str, Any]) -> SinusoidProfile:
    profile = "sinusoids"
    _check_keys(profile, params, _SITE_KEYS + _ANGLE_CHANNELS + tuple(_ACCEL_CHANNELS))
    kwargs: dict[str, SinusoidChannel] = {}
    for key in _ANGLE_CHANNELS:
        if key in params:
            kwargs[key] = _channel(profile, key, params[key], "deg", "deg_s", DEG, key)
    for key, attr in _ACCEL_CHANNELS.items():
        if key in params:
            kwargs[attr] = _channel(profile, key, params[key], "m_s2", "m_s3", 1.0, key)
    # SinusoidProfile prefixes its own errors with the profile name.
    return SinusoidProfile(name=profile, site=_site(profile, params), **kwargs)


def _make_paper1(params: Mapping[str, Any]) -> SinusoidProfile:
    profile = "paper1_land_vehicle"
    _check_keys(profile, params, _SITE_KEYS + ("structural_modes",))
    modes = params.get("structural_modes", True)
    if not isinstance(modes, bool):
        raise ValueError(f"{profile}: structural_modes must be true or false, got {modes!r}")
    return paper1_land_vehicle(_site(profile, params), modes)


_SHIP_KEYS = (
    "heading_amplitude_deg", "pitch_amplitude_deg", "roll_amplitude_deg",
    "heading_period_s", "pitch_period_s", "roll_period_s",
    "heading_phase_rad", "pitch_phase_rad", "roll_phase_rad", "mean_heading_deg",
)


def _make_ship(params: Mapping[str, Any]) -> SinusoidProfile:
    profile = "paper5_ship"
    _check_keys(profile, params, _SITE_KEYS + _SHIP_KEYS)
    kwargs = {k: _number(profile, k, params[k]) for k in _SHIP_KEYS if k in params}
    return paper5_ship(_site(profile, params), **kwargs)


_STATIC_KEYS = ("roll_deg", "pitch_deg", "yaw_deg", "psi_t_deg")


def _make_static(params: Mapping[str, Any]) -> SinusoidProfile:
    profile = "static"
    _check_keys(profile, params, _SITE_KEYS + _STATIC_KEYS)
    kwargs = {k: _number(profile, k, params[k]) for k in _STATIC_KEYS if k in params}
    return static_base(_site(profile, params), **kwargs)


_FACTORIES = {
    "paper1_land_vehicle": _make_paper1,
    "paper5_ship": _make_ship,
    "static": _make_static,
    "sinusoids": _make_sinusoids,
}

#: Names accepted by :func:`make_profile`.
PROFILE_NAMES: tuple[str, ...] = tuple(_FACTORIES)


def make_profile(name: str, params: Mapping[str, Any] | None = None) -> SinusoidProfile:
    """Build a profile from its name and a plain dict (as loaded from YAML).

    Raises ``ValueError`` naming an unknown profile, an unknown key, or a bad value.
    """
    if name not in _FACTORIES:
        raise ValueError(f"unknown motion profile {name!r}; known: {', '.join(PROFILE_NAMES)}")
    if params is None:
        params = {}
    if not isinstance(params, Mapping):
        raise ValueError(f"{name}: params must be a mapping, got {type(params).__name__}")
    return _FACTORIES[name](params)
