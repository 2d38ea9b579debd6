"""A simulated sight operator: the person who re-centres the target when the stabilised
LOS drifts off it (paper 1, §1: drift "can be compensated with frequent corrections from
the operator"; §6: without the bias filter "the biases should be corrected periodically by
the user"). The core of the ``operator`` node; it sees the truth.

Each step it is given the true sight-frame attitude C_fm (its first column is the LOS, the
m-frame x axis) and the target direction u_f, in any common frame f. The target seen in the
sight, v = C_fmᵀ u_f, gives the pointing error: its angle ε = atan2(√(v_y² + v_z²), v_x) and
its direction in the picture, as the error vector e = ε (−v_z, v_y)/√(v_y² + v_z²) about
(m-y, m-z). The LOS rate command (q, r) = e/s would cancel it in one second: +q raises the
LOS towards a target above it (−z, FRD), +r turns it right towards a target at +y. The
command goes to :mod:`gimbal_control.operator_command` (the joystick's rate command).

Behaviour, per correction:

1. Watch: on target while ε <= ``tolerance_mrad``.
2. React: once ε exceeds the tolerance, nothing happens for ``reaction_time_s``; meanwhile
   the operator sees the image creep, at ḋ = (e(t) − e(t_detect)) / (t − t_detect). If ε
   falls back inside the tolerance first, the reaction is cancelled (counted).
3. Slew: the command is ω = sat(K e + ḋ), its magnitude saturated at ``peak_rate_deg_s``,
   until ε <= ``settle_band_mrad``; then the command is zero and the operator watches again.

Why this profile. In compensatory tracking the operator and the controlled element together
behave like the crossover model, Y_p Y_c ≈ ω_c e^{−τ_e s}/s (McRuer & Jex 1967, "A Review
of Quasi-Linear Pilot Models", IEEE Trans. Human Factors in Electronics HFE-8(3), 231–249);
a stabilised sight commanded in rate is a single integrator, Y_c = 1/s, so the operator is a
pure gain K with an effective delay τ_e: the rate is proportional to the error. A sight is
a pursuit display (the target and its motion are in the picture), so the operator also
leads the creep he sees (ḋ); without that lead a constant drift d would leave a standing
error d/K and a slew could never reach a settle band narrower than it. The peak-rate
saturation is the stick's travel. The profile is smooth in between; its steps at onset and
stop are what :mod:`gimbal_control.operator_command`'s acceleration limit shapes. With
ḋ exact (a constant drift), the error decays as ε0 e^{−Kt}, so a correction starting at ε0
lasts ln(ε0/band)/K (unsaturated), and a LOS drifting at d from the band corrects with the
period (tol − band)/d + τ + ln((tol + dτ)/band)/K.

Defaults (cited or argued):

* ``reaction_time_s`` = 0.25: the crossover model's effective delay τ_e for a single-
  integrator controlled element lies around 0.2–0.3 s (McRuer & Jex 1967); the middle.
  With τ = 0 there is no time to see the creep and ḋ = 0.
* ``gain_1_s`` = 1.5: the largest gain with which a delayed proportional loop
  s + K e^{−τs} = 0 still has real roots (no overshoot) is K = 1/(e τ) = 1.47 s⁻¹ at 0.25 s;
  an operator re-centring a precise sight avoids overshooting the target.
* ``tolerance_mrad`` = 1: 1 m at 1 km.
* ``settle_band_mrad`` = 0.3: the eye's resolution, 1 arcmin (0.29 mrad; 20/20 acuity),
  at unit magnification: inside it the operator cannot see the target off centre (a sight
  of magnification M lets him see M times finer, a smaller band).
* ``peak_rate_deg_s`` = 1: the automatic LOS hold's limit
  (:class:`gimbal_control.los_hold.LosHoldParams`), so the person and the automatic loop
  share one slew ceiling; at K = 1.5 s⁻¹ it binds only above 11.6 mrad (0.67°) of error,
  never while correcting a drift at the tolerance.

Statistics (:meth:`OperatorModel.statistics`): corrections (slews started), the fraction of
the observed time on target (ε at or inside the tolerance at the start of each step
interval), corrections per minute, and the mean time between the starts of successive
corrections. Stamps are integer nanoseconds; a step at or before the last one within
``clock_jump_s`` is rejected and counted (the last command is returned), one further back
restarts watching (a clock jump); a non-finite or degenerate input is rejected and counted.

Pure Python, no rclpy; numpy-free on the per-step path.
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from numbers import Integral

from gimbal_kinematics.maths.earth import earth_rate_n
from gimbal_kinematics.maths.rotations import dcm_from_rotation_vector, quat_to_dcm
from gimbal_kinematics.maths.validate import nonneg_finite, positive
from gimbal_kinematics.params.table import ParameterError
from gimbal_kinematics.timing.stamps import Stamp, judge

WATCH, REACT, SLEW = "watch", "react", "slew"


@dataclass(frozen=True)
class OperatorModelParams:
    """Operator parameters (validated, immutable); module docstring for the defaults.

    Attributes:
        tolerance_mrad: pointing error that starts a correction [mrad].
        settle_band_mrad: error at which a correction stops [mrad] (< tolerance).
        reaction_time_s: delay from seeing the error to moving the stick [s] (>= 0).
        peak_rate_deg_s: largest commanded LOS rate magnitude [°/s].
        gain_1_s: rate per unit error, K [1/s].
        clock_jump_s: a step stamp this much before the last one restarts watching [s].
    """

    tolerance_mrad: float = 1.0
    settle_band_mrad: float = 0.3
    reaction_time_s: float = 0.25
    peak_rate_deg_s: float = 1.0
    gain_1_s: float = 1.5
    clock_jump_s: float = 0.5

    def __post_init__(self) -> None:
        for name in ("tolerance_mrad", "settle_band_mrad", "peak_rate_deg_s", "gain_1_s", "clock_jump_s"):
            positive(name, getattr(self, name))
        nonneg_finite("reaction_time_s", self.reaction_time_s)
        if self.settle_band_mrad >= self.tolerance_mrad:
            raise ValueError(f"settle_band_mrad must be < tolerance_mrad = {self.tolerance_mrad}, "
                             f"got {self.settle_band_mrad!r}")

    @classmethod
    def from_values(cls, v: dict) -> OperatorModelParams:
        """The parameters from an ``operator`` node's values; :class:`ParameterError` names
        the one refused."""
        try:
            return cls(tolerance_mrad=v["tolerance_mrad"], settle_band_mrad=v["settle_band_mrad"],
                       reaction_time_s=v["reaction_time_s"], peak_rate_deg_s=v["peak_rate_deg_s"],
                       gain_1_s=v["gain_1_s"])
        except ValueError as exc:
            raise ParameterError(f"parameter {exc}") from exc


def sight_error(C_fm: Sequence[Sequence[float]], target_f: Sequence[float]) -> tuple[float, float, float]:
    """Pointing error of a sight with attitude C_fm (3×3, m → f; LOS = first column) at the
    target direction ``target_f`` (any non-zero length): (ε [rad], e_q, e_r) with (e_q, e_r)
    the error vector about (m-y, m-z) [rad] (module docstring). Raises ValueError for a
    non-finite input or a zero target."""
    u = [float(target_f[0]), float(target_f[1]), float(target_f[2])]
    v = [sum(float(C_fm[i][j]) * u[i] for i in range(3)) for j in range(3)]
    if not all(math.isfinite(x) for x in v) or v == [0.0, 0.0, 0.0]:
        raise ValueError(f"the target seen in the sight must be finite and non-zero, got {v}")
    off = math.hypot(v[1], v[2])
    eps = math.atan2(off, v[0])
    if off == 0.0:
        return eps, 0.0, 0.0
    return eps, eps * -v[2] / off, eps * v[1] / off


class OperatorModel:
    """Watch, react, slew (module docstring); :meth:`step` per simulation step returns the
    LOS rate command (q, r) [rad/s] in the sight frame."""

    def __init__(self, params: OperatorModelParams | None = None) -> None:
        self.params = params if params is not None else OperatorModelParams()
        p = self.params
        self.tolerance = p.tolerance_mrad * 1e-3
        self.settle_band = p.settle_band_mrad * 1e-3
        self.peak_rate = math.radians(p.peak_rate_deg_s)
        self.gain = float(p.gain_1_s)
        self._reaction_ns = int(round(p.reaction_time_s * 1e9))
        self._jump_ns = int(round(p.clock_jump_s * 1e9))
        self.corrections = 0
        self.cancelled_reactions = 0
        self.observed_s = 0.0
        self.on_target_s = 0.0
        self.interval_sum_s = 0.0
        self.interval_count = 0
        self.rejected_inputs = 0
        self.rejected_stamps = 0
        self.clock_jumps = 0
        self._last_onset_ns: int | None = None
        self._restart()

    def _restart(self) -> None:
        self.phase = WATCH
        self.command: tuple[float, float] = (0.0, 0.0)
        self.error = 0.0                     # ε at the last step [rad]
        self.error_qr = (0.0, 0.0)           # its (e_q, e_r) [rad]
        self._t_ns: int | None = None
        self._on_target = True
        self._t_detect = 0
        self._e_detect = (0.0, 0.0)
        self._lead = (0.0, 0.0)              # ḋ, the creep seen while reacting [rad/s]

    def step(self, stamp_ns: int, C_fm: Sequence[Sequence[float]], target_f: Sequence[float]) -> tuple[float, float]:
        """One step at ``stamp_ns`` [ns] with the true sight attitude C_fm and target
        direction; returns the commanded (q, r) [rad/s] until the next step."""
        if isinstance(stamp_ns, bool) or not isinstance(stamp_ns, Integral):
            raise TypeError(f"stamps are integer nanoseconds, got {stamp_ns!r}")
        t = int(stamp_ns)
        verdict = judge(t, self._t_ns, self._jump_ns)
        if verdict is Stamp.DUPLICATE or verdict is Stamp.OUT_OF_ORDER:
            self.rejected_stamps += 1
            return self.command
        if verdict is Stamp.JUMPED_BACK:
            self.clock_jumps += 1
            self._restart()
            self._last_onset_ns = None
        last = self._t_ns
        try:
            eps, e_q, e_r = sight_error(C_fm, target_f)
        except (ValueError, TypeError, IndexError):
            self.rejected_inputs += 1
            return self.command
        if last is not None:
            dt = (t - last) * 1e-9
            self.observed_s += dt
            if self._on_target:
                self.on_target_s += dt
        self._t_ns = t
        self.error, self.error_qr = eps, (e_q, e_r)
        self._on_target = eps <= self.tolerance
        self.command = self._decide(t, eps, (e_q, e_r))
        return self.command

    def _decide(self, t: int, eps: float, e: tuple[float, float]) -> tuple[float, float]:
        if self.phase == WATCH and eps > self.tolerance:
            self.phase, self._t_detect, self._e_detect = REACT, t, e
        if self.phase == REACT:
            if eps <= self.tolerance:
                self.cancelled_reactions += 1
                self.phase = WATCH
            elif t - self._t_detect >= self._reaction_ns:
                self._onset(t, e)
        if self.phase == SLEW:
            if eps <= self.settle_band:
                self.phase = WATCH
            else:
                q = self.gain * e[0] + self._lead[0]
                r = self.gain * e[1] + self._lead[1]
                norm = math.hypot(q, r)
                if norm > self.peak_rate:
                    q, r = q * self.peak_rate / norm, r * self.peak_rate / norm
                return (q, r)
        return (0.0, 0.0)

    def _onset(self, t: int, e: tuple[float, float]) -> None:
        span = (t - self._t_detect) * 1e-9
        self._lead = ((e[0] - self._e_detect[0]) / span, (e[1] - self._e_detect[1]) / span) if span > 0.0 else (0.0, 0.0)
        self.phase = SLEW
        self.corrections += 1
        if self._last_onset_ns is not None:
            self.interval_sum_s += (t - self._last_onset_ns) * 1e-9
            self.interval_count += 1
        self._last_onset_ns = t

    def statistics(self) -> dict[str, float | int]:
        """What a report gives (module docstring), with the counters; NaN where undefined
        (no time observed, fewer than two corrections)."""
        nan = float("nan")
        seen = self.observed_s
        return {
            "corrections": self.corrections,
            "corrections_per_min": 60.0 * self.corrections / seen if seen > 0.0 else nan,
            "time_on_target_fraction": self.on_target_s / seen if seen > 0.0 else nan,
            "mean_time_between_corrections_s": self.interval_sum_s / self.interval_count if self.interval_count else nan,
            "observed_s": seen,
            "on_target_s": self.on_target_s,
            "cancelled_reactions": self.cancelled_reactions,
            "rejected_inputs": self.rejected_inputs,
            "rejected_stamps": self.rejected_stamps,
            "clock_jumps": self.clock_jumps,
        }


class SightOperator:
    """The ``operator`` node's core: an :class:`OperatorModel` watching an inertially fixed
    target, the true LOS's direction ``capture_s`` after the first step (what the
    stabilisation is meant to hold, and what the sighting report's drift is measured
    from: a target far enough away that the vehicle's travel does not turn it).
    NED turns with the earth at ω_in^n (``lat_deg``; ``earth_rate`` False: NED is
    inertial), so the target seen from NED at τ after the capture is exp(−[ω×] τ) u_i
    (:func:`gimbal_kinematics.maths.los.inertial_los` inverted). Before the capture the
    operator only watches the sight (no command, nothing observed)."""

    def __init__(self, params: OperatorModelParams | None = None, capture_s: float = 0.0, lat_deg: float = 0.0,
                 earth_rate: bool = True) -> None:
        nonneg_finite("capture_s", capture_s)
        self.model = OperatorModel(params)
        self._capture_ns = int(round(capture_s * 1e9))
        self._w = earth_rate_n(math.radians(lat_deg)) if earth_rate else None
        self._t0_ns: int | None = None
        self.target_ns: int | None = None   # capture stamp [ns]
        self.target_i = None                # the target in n at the capture, (3,)

    def step(self, stamp_ns: int, quat_nm: Sequence[float]) -> tuple[float, float]:
        """One step with the true sight attitude C(n,m) as a quaternion (x, y, z, w);
        returns the LOS rate command (q, r) [rad/s]."""
        t = int(stamp_ns)
        if self._t0_ns is None:
            self._t0_ns = t
        try:
            C_nm = quat_to_dcm(quat_nm)
        except (ValueError, TypeError):
            self.model.rejected_inputs += 1
            return self.model.command
        if self.target_i is None:
            if t - self._t0_ns < self._capture_ns:
                return (0.0, 0.0)
            self.target_ns, self.target_i = t, C_nm[:, 0].copy()
        target = self.target_i
        if self._w is not None:
            target = dcm_from_rotation_vector(-self._w * ((t - self.target_ns) * 1e-9)) @ target
        return self.model.step(t, C_nm, target)

    def pointing_error(self) -> tuple[float, float, float]:
        """(ε, e_q, e_r) [rad] of the last step (what ``~/pointing_error`` carries); NaN before
        the capture."""
        return (self.model.error, *self.model.error_qr) if self.target_i is not None else NAN3


NAN3 = (math.nan,) * 3


class StepStick:
    """A scripted stick, the ``operator`` node's ``script: step``: the LOS rate (q, r) [rad/s]
    held from ``start_s`` after the first step for ``duration_s``, zero before and after (an
    operator's step command at the node's rate, a joystick's autorepeat; the acceptance of a
    slew). It watches no target: its pointing error is NaN."""

    def __init__(self, start_s: float, duration_s: float, rate_qr: Sequence[float]) -> None:
        nonneg_finite("step_start_s", start_s)
        nonneg_finite("step_duration_s", duration_s)
        if len(rate_qr) != 2 or not all(math.isfinite(v) for v in rate_qr):
            raise ValueError(f"step_rate_deg_s must be 2 finite values (q, r), got {list(rate_qr)!r}")
        self._start_ns, self._duration_ns = int(round(start_s * 1e9)), int(round(duration_s * 1e9))
        self.rate_qr = (float(rate_qr[0]), float(rate_qr[1]))
        self._t0_ns: int | None = None

    def step(self, stamp_ns: int, quat_nm: Sequence[float] | None = None) -> tuple[float, float]:
        """The command of the step stamped ``stamp_ns`` [ns] (the sight's attitude unused)."""
        if self._t0_ns is None:
            self._t0_ns = int(stamp_ns)
        since = int(stamp_ns) - self._t0_ns - self._start_ns
        return self.rate_qr if 0 <= since < self._duration_ns else (0.0, 0.0)

    def pointing_error(self) -> tuple[float, float, float]:
        return NAN3


def operator_core(v: dict) -> SightOperator | StepStick:
    """The ``operator`` node's core from its values: the simulated operator (``script:
    watch``) or the scripted step (``script: step``); :class:`ParameterError` names the
    parameter refused."""
    if v["script"] == "watch":
        return SightOperator(OperatorModelParams.from_values(v), v["capture_s"], v["lat_deg"], v["earth_rate"])
    if v["script"] != "step":
        raise ParameterError(f"parameter script must be 'watch' or 'step', got {v['script']!r}")
    try:
        return StepStick(v["step_start_s"], v["step_duration_s"], [math.radians(x) for x in v["step_rate_deg_s"]])
    except ValueError as exc:
        raise ParameterError(f"parameter {exc}") from exc
