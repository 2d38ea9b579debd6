"""Paper 3: four-gimbal platform servo with bidirectional rotation modulation (docs/spec.md §3.3).

Four PID loops at 1 kHz: azimuth a, inner roll q, pitch p, outer roll r. Each one outputs
the voltage of its gimbal's DC torque motor.

Gyro pickoffs. Paper 3's dynamically tuned gyros are torqued at the command rate ω_c, and
their pickoffs read the small rotation δ of the platform s away from the gyro reference.
This core emulates that rate-integrating behaviour from a rate-gyro triad on the platform
(ω_meas, resolved in s). With C_sg = I − [δ×] the rate of s relative to the reference is
ω_meas − C_sg ω_c, so to first order::

    δ̇ = ω_meas − ω_c − ω_c × δ

(a misalignment that is fixed in the turning reference stays constant).

The command is paper 3 eq. 2 (:func:`gimbal_kinematics.maths.four_gimbal.command_rate_s`):
ω_c = rot3(φz) ω_ie^n + φ̇z e3 − ε̂. φz(t) is the modulation schedule
(:class:`~gimbal_kinematics.maths.four_gimbal.BidirectionalRotation`, ±1.2 °/s through one turn
and back), ω_ie^n the earth rate at ``lat_deg``, and ε̂ an optional gyro-drift estimate.
The per-tick increment of δ takes φz's change exactly, so a reversal inside a tick is not
smeared; the rest of ω_c is integrated by trapezoids.

Following a navigator (``command_source="navigator"``, paper 3 §4.3). A platform INS torques
its gyros at the rate its navigator computes: earth rate at the navigated latitude, transport
rate from the navigated velocity, drift compensation and the hand-off torquing pulse, all in
ω_c^n (NED, :mod:`gimbal_estimators.platform_navigator`). :meth:`PlatformServo.on_command_rate`
takes it, and each tick commands ω_c = rot3(φz) ω_c^n + φ̇z e3
(:func:`~gimbal_kinematics.maths.four_gimbal.command_rate_from_n`): the servo's own earth rate at
``lat_deg`` and its ``drift_deg_h`` give way, the modulation schedule stays the servo's. Each
tick uses the newest command received, a zero-order hold, whatever its stamp relative to the
tick (the navigator's output for a sample is the rate to hold until its next one).

* Before the first command (the navigator has not produced one yet): the internal command,
  earth rate at ``lat_deg`` minus ``drift_deg_h``, which is what a static, aligned navigator
  starts with; ``ticks_without_command`` counts these ticks.
* A command older than ``command_max_age_s`` at a tick (the navigator stopped): the servo
  falls back to the internal command, so a dead navigator leaves the platform on the earth
  rate rather than on a held transport rate or torquing pulse; ``stale_command_ticks``
  counts them. A younger command is held: the rate changes on the Schuler time scale.
* A command with a non-finite value is rejected and counted (``rejected_nonfinite``) and
  the previous command is kept.

Control signals, paper 3 eq. 1. :func:`~gimbal_kinematics.maths.four_gimbal.inner_gimbal_control_signals`
resolves δ through the azimuth angle θ_a (and θ_q) onto the inner-roll, pitch and azimuth
gimbal axes, giving (Δθ_qm, Δθ_pm, Δθ_am). The outer roll keeps the inner roll at null with
Δθ_rm = θ_q sec θ_p (:func:`~gimbal_kinematics.maths.four_gimbal.outer_roll_control_signal`).
The angles θ are the gimbal resolver readings.

Loops. Each inner loop drives its gimbal by −Δθ through a PID: u = PID(−Δθ), with the D
term taken from the pickoff rate −(ω_meas − ω_c) resolved the same way. The outer roll
uses u = PID(+Δθ_rm), with a differenced and filtered D. The gains come from pole
placement on the Table 1 plant (:func:`platform_pid_gains`); paper 3 tuned its gains by
trial and error after pole placement.

Integrator preset (paper 3 §4.1: "at the time of reversal, the initial value of integrator
needs to be set based on the influence of friction torque"). When the commanded rotation
rate changes sign, and at the start from rest, the azimuth integrator is preset to the
voltage the new direction needs in steady rotation:

    V = R_a/k_t · (T_c tanh(ω/ω_s) + B ω) + k_e ω

where ω is the new commanded rate and (T_c, B, ω_s, k_t, R_a, k_e) are the known or
identified bearing friction and motor constants (:class:`FrictionModel`).

Message-driven API (stamps [s], SI units)::

    servo.on_resolvers(t, angles)    # gimbal angles (θ_a, θ_q, θ_p, θ_r) [rad]
    fed = servo.on_gyro(t, omega_s)  # platform gyro triad (3,) [rad/s] -> Fed, its output a ServoCommand

The gyro sample is the control tick; feed the resolver sample of a stamp first. The
schedule starts (φz = 0) at the first tick. Stamps come checked and in order from the
node's input policy (:mod:`gimbal_kinematics.timing.control_policy`: duplicates and late stamps
dropped, a clock jump back a :meth:`PlatformServo.reset`). Bad input:

* NaN/inf gyro sample, or resolvers within 1° of gimbal lock (eq. 1 singular): the last
  command is held and the event counted.
* NaN/inf resolver sample: rejected and counted.
* Gap longer than ``max_gap_s``: the pickoff integration restarts from the held state.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import NamedTuple, Sequence

import numpy as np

from gimbal_kinematics.maths.validate import positive
from gimbal_kinematics.params.table import ParameterError
from gimbal_kinematics.maths.four_gimbal import GIMBAL_LOCK_MARGIN, BidirectionalRotation
from gimbal_kinematics.maths.outcome import Fed, refused
from gimbal_kinematics.maths.attribute_views import slot
from gimbal_kinematics.maths.units import DEG, DEG_H
from gimbal_kinematics.maths.wgs84 import OMEGA_IE

from . import control_kernels as ck
from . import servo_kernels as sk
from .pid import Pid, PidParams, pole_placement_gains

_LOCK_COS = math.sin(GIMBAL_LOCK_MARGIN)

#: Paper 3 Table 1: axis -> (J [kg·m²], k_t [N·m/A], R_a [Ω]); used for the default gains.
TABLE1 = {"a": (0.0026, 0.21, 31.2), "q": (0.0066, 0.21, 35.5), "p": (0.0093, 0.21, 28.7),
          "r": (0.0115, 0.29, 34.3)}
VOLTAGE_LIMIT_V = 27.0
#: A loop's triple pole must stay below the control rate / this (at 1 kHz: 25 Hz, where the
#: Table 1 loops keep 33° of phase margin; the 12 Hz default keeps 51°, test_platform_servo).
BANDWIDTH_RATE_DIVISOR = 40.0
#: Where the level command rate comes from (module docstring).
COMMAND_SOURCES = ("internal", "navigator")


def platform_pid_gains(axis: str, bandwidth_hz: float, derivative_tau_s: float = 0.0) -> PidParams:
    """Pole-placement PID [V/rad, V/(rad·s), V·s/rad] for a Table 1 axis driven in voltage.

    Torque per volt is k_t/R_a (back-EMF damping k_t k_e/R_a is < 1 % of the loop gain at
    these bandwidths); :func:`.pid.pole_placement_gains` puts a triple pole at
    ``bandwidth_hz``.
    """
    if axis not in TABLE1:
        raise ValueError(f"axis must be one of {tuple(TABLE1)}, got {axis!r}")
    j, kt, r = TABLE1[axis]
    return pole_placement_gains(j, bandwidth_hz, gain_per_torque=kt / r, output_limit=VOLTAGE_LIMIT_V,
                                derivative_tau_s=derivative_tau_s)


@dataclass(frozen=True)
class FrictionModel:
    """Known or identified azimuth bearing friction and motor constants for the preset.

    Defaults: the Table 1 azimuth motor (k_t, R_a, k_e = k_t) and the bearing model of the
    simulated plant (T_c = 0.01 N·m, B = 5e-4 N·m·s/rad, ω_s = 0.01 rad/s).
    """

    coulomb_nm: float = 0.01
    viscous_nm_s_rad: float = 5e-4
    smoothing_rad_s: float = 0.01
    torque_constant_nm_a: float = 0.21
    resistance_ohm: float = 31.2
    back_emf_v_s_rad: float = 0.21

    def __post_init__(self) -> None:
        for name in ("coulomb_nm", "viscous_nm_s_rad", "back_emf_v_s_rad"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v < 0.0:
                raise ValueError(f"{name} must be >= 0, got {v!r}")
        for name in ("smoothing_rad_s", "torque_constant_nm_a", "resistance_ohm"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v <= 0.0:
                raise ValueError(f"{name} must be > 0, got {v!r}")

    def voltage(self, omega: float) -> float:
        """Steady voltage [V] that turns the gimbal at ``omega`` [rad/s] against friction."""
        torque = self.coulomb_nm * math.tanh(omega / self.smoothing_rad_s) + self.viscous_nm_s_rad * omega
        return self.resistance_ohm / self.torque_constant_nm_a * torque + self.back_emf_v_s_rad * omega


@dataclass(frozen=True)
class PlatformServoParams:
    """Servo parameters (validated, immutable); angles and rates in the named units.

    Attributes:
        lat_deg: site latitude for the earth-rate part of the command [deg].
        rate_deg_s, sweep_deg, reversal_time_s: the modulation schedule
            (:class:`~gimbal_kinematics.maths.four_gimbal.BidirectionalRotation`).
        rotate: run the modulation schedule; False holds the platform at φz = 0 (the
            non-rotating case of paper 3 eq. 9).
        azimuth_pid, inner_roll_pid, pitch_pid, outer_roll_pid: loop gains (volts out).
        preset_integrator: preset the azimuth integrator at reversals (paper 3).
        friction: the friction model behind the preset.
        drift_deg_h: gyro drift estimate ε̂ (x, y, z in s) subtracted from the command [°/h].
        command_source: ``"internal"`` (the servo's earth rate and drift, eq. 2) or
            ``"navigator"`` (the NED rate of :meth:`PlatformServo.on_command_rate`).
        command_max_age_s: with the navigator, an older command gives way to the internal
            one [s].
        max_gap_s: a longer gap between ticks restarts the pickoff integration [s].
    """

    lat_deg: float = 45.0
    rate_deg_s: float = 1.2
    sweep_deg: float = 360.0
    reversal_time_s: float = 0.0
    rotate: bool = True
    azimuth_pid: PidParams = field(default_factory=lambda: platform_pid_gains("a", 12.0))
    inner_roll_pid: PidParams = field(default_factory=lambda: platform_pid_gains("q", 12.0))
    pitch_pid: PidParams = field(default_factory=lambda: platform_pid_gains("p", 12.0))
    outer_roll_pid: PidParams = field(default_factory=lambda: platform_pid_gains("r", 4.0, 0.005))
    preset_integrator: bool = True
    friction: FrictionModel = field(default_factory=FrictionModel)
    drift_deg_h: tuple[float, float, float] = (0.0, 0.0, 0.0)
    max_gap_s: float = 0.05
    command_source: str = "internal"
    command_max_age_s: float = 0.5

    def __post_init__(self) -> None:
        if (isinstance(self.lat_deg, bool) or not isinstance(self.lat_deg, (int, float))
                or not math.isfinite(self.lat_deg) or abs(self.lat_deg) >= 90.0):
            raise ValueError(f"lat_deg must be within (-90, 90), got {self.lat_deg!r}")
        try:
            self.schedule()
        except ValueError as exc:
            raise ValueError(f"modulation schedule: {exc}") from None
        for name in ("azimuth_pid", "inner_roll_pid", "pitch_pid", "outer_roll_pid"):
            if not isinstance(getattr(self, name), PidParams):
                raise ValueError(f"{name} must be a PidParams")
        if not isinstance(self.rotate, bool):
            raise ValueError(f"rotate must be true or false, got {self.rotate!r}")
        if not isinstance(self.preset_integrator, bool):
            raise ValueError(f"preset_integrator must be true or false, got {self.preset_integrator!r}")
        if not isinstance(self.friction, FrictionModel):
            raise ValueError("friction must be a FrictionModel")
        d = self.drift_deg_h
        if len(d) != 3 or not all(isinstance(v, (int, float)) and math.isfinite(v) for v in d):
            raise ValueError(f"drift_deg_h must be 3 finite numbers, got {d!r}")
        if self.command_source not in COMMAND_SOURCES:
            raise ValueError(f"command_source must be one of {COMMAND_SOURCES}, got {self.command_source!r}")
        for name in ("max_gap_s", "command_max_age_s"):
            positive(name, getattr(self, name))

    @classmethod
    def from_values(cls, v: dict) -> PlatformServoParams:
        """The parameters from a ``platform_servo`` node's values (name -> value, as declared
        in :mod:`.platform_servo_params`): the Table 1 loops' gains placed at the requested
        bandwidths (each at most ``imu_rate_hz`` / :data:`BANDWIDTH_RATE_DIVISOR`);
        :class:`ParameterError` names the parameter refused."""
        control_hz = v["imu_rate_hz"]
        for name in ("azimuth_bandwidth_hz", "level_bandwidth_hz", "outer_roll_bandwidth_hz"):
            if v[name] > control_hz / BANDWIDTH_RATE_DIVISOR:
                raise ParameterError(f"parameter {name!r} = {v[name]} Hz is above imu_rate_hz/"
                                     f"{BANDWIDTH_RATE_DIVISOR:g} = {control_hz / BANDWIDTH_RATE_DIVISOR:g} Hz: "
                                     "the sampled loop loses its margin")
        if len(v["drift_deg_h"]) != 3:
            raise ParameterError(f"parameter 'drift_deg_h' needs 3 values (x, y, z), got {v['drift_deg_h']}")
        try:
            return cls(
                lat_deg=v["lat_deg"], rate_deg_s=v["rate_deg_s"], sweep_deg=v["sweep_deg"],
                reversal_time_s=v["reversal_time_s"], rotate=v["rotation"] == "bidirectional",
                azimuth_pid=platform_pid_gains("a", v["azimuth_bandwidth_hz"]),
                inner_roll_pid=platform_pid_gains("q", v["level_bandwidth_hz"]),
                pitch_pid=platform_pid_gains("p", v["level_bandwidth_hz"]),
                outer_roll_pid=platform_pid_gains("r", v["outer_roll_bandwidth_hz"], v["outer_roll_derivative_tau_s"]),
                preset_integrator=v["preset_integrator"],
                friction=FrictionModel(coulomb_nm=v["friction_coulomb_nm"],
                                       viscous_nm_s_rad=v["friction_viscous_nm_s_rad"],
                                       smoothing_rad_s=v["friction_smoothing_rad_s"]),
                drift_deg_h=tuple(v["drift_deg_h"]), max_gap_s=v["max_gap_s"],
                command_source=v["command_source"], command_max_age_s=v["command_max_age_s"])
        except ValueError as exc:
            raise ParameterError(str(exc)) from exc

    def schedule(self) -> BidirectionalRotation:
        """The modulation schedule φz(t) (t from the first tick)."""
        return BidirectionalRotation(rate_deg_s=self.rate_deg_s, sweep_deg=self.sweep_deg,
                                     reversal_time_s=self.reversal_time_s)


class ServoCommand(NamedTuple):
    """Output of a control tick: motor voltages (a, q, p, r) [V], the control signals
    (Δθ_am, Δθ_qm, Δθ_pm, Δθ_rm) [rad], the commanded modulation angle φz and rate φ̇z
    [rad, rad/s], and whether the command was held (bad input)."""

    t: float
    voltages: tuple[float, float, float, float]
    control_signals: tuple[float, float, float, float]
    phi_z: float
    phi_z_rate: float
    held: bool


_USED = Fed(True)
_NO_ANGLES = Fed(False)  # no resolver angles yet: nothing to command, nothing wrong
_NONFINITE_ANGLES = refused("non-finite resolver angles")
_NONFINITE_COMMAND = refused("non-finite navigator command rate")


class PlatformServo:
    """The four loops of paper 3 (module docstring). The state of one servo is a vector
    (:mod:`.servo_kernels`: pickoff, last tick, held command, voltages, counters) plus the
    four PID rows; each message calls the kernel that the compiled engine calls too."""

    def __init__(self, params: PlatformServoParams | None = None) -> None:
        self.params = params if params is not None else PlatformServoParams()
        if not isinstance(self.params, PlatformServoParams):
            raise ValueError("params must be a PlatformServoParams")
        p = self.params
        self.schedule = p.schedule()
        self._lat = p.lat_deg * DEG
        self._drift = tuple(v * DEG_H for v in p.drift_deg_h)
        # the four channels' states are the rows of one array: one kernel call steps them
        self._pid_state = np.zeros((4, ck.N_STATE))
        self.pid_a = Pid(p.azimuth_pid, self._pid_state[0])
        self.pid_q = Pid(p.inner_roll_pid, self._pid_state[1])
        self.pid_p = Pid(p.pitch_pid, self._pid_state[2])
        self.pid_r = Pid(p.outer_roll_pid, self._pid_state[3])
        self._pid_gains = np.array([pid.gains for pid in (self.pid_a, self.pid_q, self.pid_p, self.pid_r)])
        self.kernel_params = self._kernel_params()
        self.state = sk.initial_state()
        self.rejected_nonfinite = 0
        self.reset_reasons: list[str] = []
        self._reset_state()

    def _kernel_params(self) -> np.ndarray:
        """The constants of :func:`.servo_kernels.servo_tick` (``P_*``)."""
        p, sched = self.params, self.schedule
        lim = self.pid_a.params.integrator_limit
        presets = [max(-lim, min(lim, float(p.friction.voltage(d * sched.rate_rad_s)))) for d in (1, -1)]
        return np.array([1.0 if p.rotate else 0.0, sched.rate_rad_s, math.radians(p.sweep_deg), sched.leg_duration_s,
                         0.5 * p.reversal_time_s, 1.0 if p.command_source == "navigator" else 0.0,
                         p.command_max_age_s, p.max_gap_s, OMEGA_IE * math.cos(self._lat),
                         OMEGA_IE * -math.sin(self._lat), *self._drift, _LOCK_COS,
                         1.0 if p.preset_integrator else 0.0, *presets], dtype=float)

    def _reset_state(self) -> None:
        for pid in (self.pid_a, self.pid_q, self.pid_p, self.pid_r):
            pid.reset()
        counters = self.state[sk.S_NO_CMD:].copy()  # the counters outlive a reset
        self.state[:] = sk.initial_state()
        self.state[sk.S_NO_CMD:] = counters

    held_commands = slot(sk.S_HELD, int, "ticks that held the last command")
    rejected_gimbal_lock = slot(sk.S_LOCK, int, "ticks within 1° of gimbal lock")
    presets = slot(sk.S_PRESETS, int, "azimuth integrator presets")
    ticks_without_command = slot(sk.S_NO_CMD, int, "ticks before the first command")
    stale_command_ticks = slot(sk.S_STALE, int, "ticks on a stale command")

    @property
    def pickoff(self) -> tuple[float, float, float]:
        """The emulated gyro pickoff δ (x, y, z in s) [rad]."""
        return tuple(self.state[sk.S_D0:sk.S_D2 + 1].tolist())

    @property
    def command_voltages(self) -> tuple[float, float, float, float]:
        """The last commanded motor voltages (a, q, p, r) [V] (zeros before the first tick)."""
        return tuple(self.state[sk.S_V0:sk.S_V3 + 1].tolist())

    def _stamp(self, index: int) -> float | None:
        v = self.state[index]
        return None if math.isnan(v) else float(v)

    def reset(self, reason: str) -> None:
        """Reset the loops and restart the schedule; ``reason`` goes to ``reset_reasons``."""
        self.reset_reasons.append(reason)
        self._reset_state()

    def on_resolvers(self, t: float, angles: Sequence[float]) -> Fed:
        """Gimbal resolver angles (θ_a, θ_q, θ_p, θ_r) [rad] at stamp ``t`` [s]; returns what
        it did (:class:`~gimbal_kinematics.maths.outcome.Fed`)."""
        vals = self._finite("angles", angles, "a, q, p, r")
        if vals is None:
            return _NONFINITE_ANGLES
        sk.servo_resolvers(self.state, t, *vals)
        return _USED

    def on_command_rate(self, t: float, omega_n: Sequence[float]) -> Fed:
        """The navigator's level command rate ω_c^n (3,) NED [rad/s] at stamp ``t`` [s], held
        until the next one (module docstring; used with ``command_source="navigator"``);
        returns what it did."""
        vals = self._finite("omega_n", omega_n, "N, E, D")
        if vals is None:
            return _NONFINITE_COMMAND
        sk.servo_command(self.state, float(t), *vals)
        return _USED

    def modulation_at(self, t: float) -> tuple[float, float]:
        """(φz, φ̇z) [rad, rad/s] the schedule gives a tick at ``t`` [s]
        (:func:`.servo_kernels.servo_modulation`): what ``~/modulation_next`` carries."""
        phi, rate = sk.servo_modulation(self.state, self.kernel_params, float(t))
        return float(phi), float(rate)

    def _finite(self, name: str, values: Sequence[float], axes: str) -> tuple[float, ...] | None:
        """``values`` as floats, one per axis of ``axes``; None (counted) when one is not finite."""
        vals = tuple(float(v) for v in values)
        n = len(axes.split(", "))
        if len(vals) != n:
            raise ValueError(f"{name} must have {n} elements ({axes}), got {len(vals)}")
        if not all(math.isfinite(v) for v in vals):
            self.rejected_nonfinite += 1
            return None
        return vals

    def _output(self, t: float, held: bool) -> ServoCommand:
        s = self.state
        return ServoCommand(t, self.command_voltages, tuple(s[sk.S_G0:sk.S_G3 + 1].tolist()), float(s[sk.S_PHI]),
                            float(s[sk.S_PHI_RATE]), held)

    def on_gyro(self, t: float, omega_s: Sequence[float]) -> Fed:
        """Control tick on a platform gyro sample ω_meas (3,) [rad/s] resolved in s
        (:func:`.servo_kernels.servo_tick`); returns what it did
        (:class:`~gimbal_kinematics.maths.outcome.Fed`), its ``output`` the
        :class:`ServoCommand`.

        No output until resolver angles have arrived; a non-finite sample, or one within 1°
        of gimbal lock, holds the last command (``held=True``, and ``why``).
        """
        last = self._stamp(sk.S_T_TICK)
        wx, wy, wz = (float(v) for v in omega_s)
        if not (math.isfinite(wx) and math.isfinite(wy) and math.isfinite(wz)):
            self.rejected_nonfinite += 1
            sk.servo_held(self.state, self.kernel_params, float(t))
            return Fed(False, "non-finite gyro sample: the last command held", self._output(t, True))
        gaps = self.state[sk.S_GAPS]
        result = sk.servo_tick(self.state, self.kernel_params, self._pid_state, self._pid_gains, float(t), wx, wy, wz)
        if self.state[sk.S_GAPS] != gaps:
            self.reset_reasons.append(f"gap of {t - last:.3f} s before t={t:.3f}: pickoff integration restarted")
        if result == sk.TICK_NONE:
            return _NO_ANGLES
        if result == sk.TICK_HELD:
            return Fed(True, "within 1° of gimbal lock: the last command held", self._output(t, True))
        return Fed(True, output=self._output(t, False))
