"""Gyro-bias EKF of paper 1 §3 (docs/spec.md §3.1): attitude C(n,m) of the inner gimbal + gyro biases.

Pure Python (no rclpy). It takes grouped samples, checked and in stamp order:

    ekf.integrate(t, q_m, r_m, angles, rates)   a gimbal gyro sample [rad/s] (e.g. 1 kHz) with the
                                                encoder angles (ψt, ψm, θm) [rad] and INS body rates
                                                (p, q, r) [rad/s] of its stamp
    ekf.fuse(t, euler, angles)                  an INS attitude (φ, θ, ψ) [rad] (e.g. 100 Hz) the
                                                integration has reached, with the angles of its stamp

Stamps, duplicates, clock jumps (a jump back calls :meth:`GyroBiasEkf.reset`) and the
multi-rate grouping are the input edge's (:mod:`gimbal_kinematics.timing.input_policy`,
:class:`gimbal_kinematics.timing.sync.RateSync`); :class:`.gyro_bias_ekf_stamp.EkfInput` puts the
three raw streams through the checks (``check_*``) and the grouping into the core, each
call returning a :class:`Fed`: the sample used or why not, and the update it completed.

Mechanization (gyro rate)
-------------------------
Ĉ = Ĉ(n,m) is carried as a quaternion and integrated with the exact rotation-vector form of

    Ċ_nm = C_nm [ω_im^m ×] − [ω_in^n ×] C_nm,      ω_in^n = ω_ie^n + ω_en^n,

i.e. ``Ĉ ← exp(−[ω_in Δt ×]) Ĉ exp([φ ×])`` with the second-order (trapezoid + coning)
rotation vector ``φ = ½(ω_{k−1} + ω_k) Δt + (Δt²/12) ω_{k−1} × ω_k``, exact for linearly
varying rates; its error is far below the biases (< 3e-7 rad in 10 s on paper 1's motion).
ω_im^m = (p̂_m, q_m − b̂_q, r_m − b̂_r). The roll rate is paper 1 eq. 4
(:func:`gimbal_kinematics.maths.sighting_chain.reconstruct_roll_rate`) in closed scalar form:
since rot3(ψm) rot3(ψt) turns the INS rate into the outer-gimbal frame and ψ̇t only enters
its third component,

    w1 = cos(ψt + ψm) p + sin(ψt + ψm) q,     p̂_m = (w1 − b̂_x − sin θm r̂_m) / cos θm.

The INS body rates are interpolated to the gyro stamps (see "Synchronisation").

State, error model and measurement: :mod:`.gyro_bias_ekf_model` (the 9-state error model,
the lumped bias, the measured attitude and the INS error states).

Synchronisation (the grouping :class:`gimbal_kinematics.timing.sync.RateSync` does)
---------------------------------------------------------------------------
All streams are stamped on one clock. Gyro samples are queued and integrated in stamp order
once an encoder sample and an INS-rate sample stamped at or after them are in (or after
``max_sync_wait_s``, with the latest values held): joint angles and INS body rates are then
linearly interpolated to each gyro stamp. So in lockstep (all streams at the same stamps)
eq. 4 uses the angles and rates of the same instant, whatever order the messages of one
stamp arrive in, and 100 Hz INS rates feed a 1 kHz gyro without the 5 ms mean lag of a hold.
The attitude estimate therefore lags the newest gyro sample by at most one INS period;
measurement updates are not delayed: an INS attitude stamped t_ins is fused as soon as the
gyro samples up to t_ins are integrated, with the encoder angles interpolated to t_ins. When
the INS is not stamped on gyro stamps (a driver, free timing), the gyro rates are
interpolated linearly to each INS stamp, the attitude integrated to it and the update made
there, so there is no skew; several updates may then complete in one call,
:meth:`GyroBiasEkf.take_outputs` returns them all (each input returns the last). (An INS
message later than ``max_sync_wait_s`` is fused against the current attitude, a skew of up
to that wait.)

``attitude_noise_floor_deg`` (default 0.02°, white, isotropic, added to R) stands for the
unmodelled residuals: the interpolation ripple, sync skew, encoder quantisation. It
matters beyond its size. No encoder measures roll about the LOS, so without a floor that
component of z is nearly noise-free; the filter then reads every LOS-roll residual as a
change of the INS roll/pitch error states (whose process noise exceeds the roll channel's)
and, through their correlation with ψ, moves ψ̂ and ê in opposite directions along the
unobservable combination. On paper 1's motion the deterministic 2e-5 rad ripple alone
drove ê_θ by −0.07° in 60 s in every run (attitude error mean −1.4σ, NEES 9 instead of 6).
With 0.01° the drift is 10× smaller, with 0.02° 50×, and the ~0.05° encoder-dominated
components of R grow by only 8 %.

Robustness
----------
NaN/inf inputs are rejected and counted (the :class:`Fed` says why); resets are logged in
``reset_log``. A gyro gap longer than ``max_gyro_gap_s`` or ``max_consecutive_gated`` gated
measurements in a row re-align the attitude from the next measurement but keep the bias
estimate (also logged). Innovations beyond the chi-square gate are rejected and counted. The
covariance goes through the Joseph form and is re-symmetrised each step. Near θm = ±90° (eq.
4 singular) the last roll rate is held and the sample counted.
"""
from __future__ import annotations

import math
from collections import deque
from typing import NamedTuple, Sequence

import numpy as np

from gimbal_kinematics.maths.earth import earth_rate_n, transport_rate_n
from gimbal_kinematics.maths.rotations import (
    quat_from_rotation_vector, quat_mul, quat_to_dcm, rotation_vector_from_quat,
)
from gimbal_kinematics.maths.units import DEG, DEG_H, DEG_RT_H

from gimbal_kinematics.maths import kalman
from gimbal_kinematics.maths.outcome import Fed
from . import gyro_bias_ekf_kernels as kernels
from .gyro_bias_ekf_model import BIAS, INS_ERROR, N_STATES_BASE, N_STATES_INS, PSI
from .gyro_bias_ekf_params import GyroBiasEkfParams


#: |cos θm| below which eq. 4 is treated as singular (roll and azimuth axes aligned).
_SINGULAR_COS = 1e-3
#: Outputs held for :meth:`GyroBiasEkf.take_outputs` at most.
_MAX_OUTPUTS = 100


class Counters(NamedTuple):
    """Health counters (cumulative since construction; resets do not clear them)."""

    updates: int
    gated: int
    rejected_nonfinite: int
    resets: int
    realignments: int
    singular_elevation: int


class EkfOutput(NamedTuple):
    """Result of one measurement update (or of the initial alignment, ``accepted`` True,
    zero innovation).

    ``bias`` (3,) [rad/s]: (b_x, b_q, b_r), b_x the roll-channel (INS-rate) bias of eq. 4;
    ``bias_sigma`` (3,) its 1σ. ``quat_nm`` (4,) (x, y, z, w): estimated C(n,m) after the
    update. ``attitude_cov`` (3, 3) [rad²]: covariance of ψ, the small rotation about the
    n axes. ``innovation`` (3,) [rad], ``d2`` its squared Mahalanobis distance,
    ``accepted`` whether the gate passed it; ``nis`` the update's NIS contribution (``d2`` of
    an update, accepted or gated; None for an alignment).
    """

    t: float
    bias: np.ndarray
    bias_sigma: np.ndarray
    quat_nm: np.ndarray
    attitude_cov: np.ndarray
    innovation: np.ndarray
    d2: float
    accepted: bool
    counters: Counters
    nis: float | None = None


_NONFINITE = Fed(False, "non-finite or malformed values")


_rotvec_quat = quat_from_rotation_vector
_rotvec_from_quat = rotation_vector_from_quat


class GyroBiasEkf:
    """Gyro-bias EKF core (module docstring). Not thread-safe; feed messages in order."""

    def __init__(self, params: GyroBiasEkfParams | None = None) -> None:
        p = params if params is not None else GyroBiasEkfParams()
        if not isinstance(p, GyroBiasEkfParams):
            raise TypeError(f"params must be GyroBiasEkfParams, got {type(p).__name__}")
        self.params = p
        lat = p.lat_deg * DEG
        self.omega_in_n = earth_rate_n(lat) + transport_rate_n(lat, p.height_m, np.array(p.velocity_n_m_s))
        self._win = tuple(float(v) for v in self.omega_in_n)
        self.n_states = N_STATES_INS if p.ins_error_states else N_STATES_BASE
        self._gate = kalman.chi2_gate(3, p.gate_probability)
        # Continuous noise densities (rad²/s for rates, rad²/s³ for the bias walks).
        arw_g, arw_r = p.gyro_arw_deg_rt_h * DEG_RT_H, p.roll_arw_deg_rt_h * DEG_RT_H
        self._n_psd = np.array([arw_r**2, arw_g**2, arw_g**2])

        def walk(sigma_deg_h: float, tau_s: float) -> float:
            return 0.0 if math.isinf(tau_s) else 2.0 * (sigma_deg_h * DEG_H) ** 2 / tau_s

        self._qb_psd = np.array([walk(p.roll_bias_instability_deg_h, p.roll_bias_tau_s),
                                 walk(p.gyro_bias_instability_deg_h, p.gyro_bias_tau_s),
                                 walk(p.gyro_bias_instability_deg_h, p.gyro_bias_tau_s)])
        self._Pb0 = np.diag([(p.roll_bias_sigma_deg_h * DEG_H) ** 2] + [(p.gyro_bias_sigma_deg_h * DEG_H) ** 2] * 2)
        rp, hd = p.ins_roll_pitch_rms_deg * DEG, p.ins_heading_rms_deg * DEG
        self._pe_var = np.array([rp * rp, rp * rp, hd * hd])
        self._enc_var = (p.encoder_noise_deg * DEG) ** 2
        self._floor_var = (p.attitude_noise_floor_deg * DEG) ** 2
        self._H = np.zeros((3, self.n_states))
        self._H[:, PSI] = np.eye(3)
        self.counters = Counters(0, 0, 0, 0, 0, 0)
        #: (t, reason) of the latest resets and re-alignments, newest last.
        self.reset_log: deque[tuple[float, str]] = deque(maxlen=100)
        #: every EkfOutput since the last :meth:`take_outputs` (a call may complete several)
        self.outputs: list[EkfOutput] = []
        self._realigned: list[tuple[float, str]] = []  # by the call under way (its Fed)
        self._clear()

    # ------------------------------------------------------------------ state handling
    def _clear(self) -> None:
        self._q: list[float] | None = None  # Ĉ(n,m) as (x, y, z, w); None until aligned
        self._b = [0.0, 0.0, 0.0]
        self._e = np.zeros(3)
        self.P: np.ndarray | None = None
        self._t_gyro: float | None = None  # stamp of the last integrated gyro sample
        self._w_prev: tuple[float, float, float] | None = None
        self._trig = (1.0, 0.0, 1.0, 0.0)  # cos, sin (ψt+ψm); cos, sin θm at t_gyro

        self._t_cov: float | None = None
        self._A_cov: np.ndarray | None = None
        self._consecutive_gated = 0
        self._p_m_last = 0.0
        self._P_bb_keep: np.ndarray | None = None

    def _count(self, **inc: int) -> None:
        self.counters = self.counters._replace(**{k: getattr(self.counters, k) + v for k, v in inc.items()})

    def reset(self, reason: str, t: float = math.nan) -> None:
        """Forget everything (e.g. on a clock jump back); log ``reason``."""
        self._count(resets=1)
        self.reset_log.append((t, reason))
        self._clear()

    def _realign(self, reason: str, t: float) -> None:
        """Re-align the attitude from the next measurement, keeping the bias estimate."""
        self._count(realignments=1)
        self.reset_log.append((t, "realign: " + reason))
        self._realigned.append(self.reset_log[-1])
        self._P_bb_keep = None if self.P is None else self.P[BIAS, BIAS].copy()
        self._q = None
        self._t_cov = None
        self._consecutive_gated = 0

    def set_navigation(self, lat_rad: float, height_m: float, velocity_n_m_s: Sequence[float]) -> bool:
        """Update the site and NED velocity that set ω_in^n = ω_ie^n + ω_en^n (e.g. from a
        navigation fix of a moving vehicle). Non-finite or out-of-range values are
        rejected, counted as non-finite and leave ω_in unchanged; returns whether accepted."""
        try:
            v = (float(velocity_n_m_s[0]), float(velocity_n_m_s[1]), float(velocity_n_m_s[2]))
            lat, h = float(lat_rad), float(height_m)
            ok = len(velocity_n_m_s) == 3 and math.isfinite(lat + h + v[0] + v[1] + v[2]) \
                and abs(lat) < 0.5 * math.pi - 1e-6
        except (TypeError, ValueError, IndexError):
            ok = False
        if not ok:
            self._count(rejected_nonfinite=1)
            return False
        self.omega_in_n = earth_rate_n(lat) + transport_rate_n(lat, h, np.array(v))
        self._win = tuple(float(w) for w in self.omega_in_n)
        return True

    # ------------------------------------------------------------------ public state
    @property
    def aligned(self) -> bool:
        return self._q is not None

    @property
    def bias(self) -> np.ndarray:
        """Current bias estimate (b_x, b_q, b_r) [rad/s], (3,)."""
        return np.array(self._b)

    @property
    def bias_sigma(self) -> np.ndarray:
        """1σ of the bias estimate [rad/s], (3,) (prior σ before alignment)."""
        return np.sqrt(np.diag(self.P[BIAS, BIAS] if self.P is not None else self._Pb0))

    @property
    def attitude_cov(self) -> np.ndarray | None:
        """Covariance [rad²] (3, 3) of ψ, the attitude error about the n axes; None before alignment."""
        return None if self._q is None else self.P[PSI, PSI].copy()

    @property
    def ins_error(self) -> np.ndarray:
        """Estimated INS Euler-angle errors (φ, θ, ψ) [rad], (3,) (zeros without those states)."""
        return self._e.copy()

    @property
    def quat_nm(self) -> np.ndarray | None:
        """Estimated C(n,m) as (x, y, z, w) at :attr:`time`, or None before alignment."""
        return None if self._q is None else np.array(self._q)

    @property
    def C_nm(self) -> np.ndarray | None:
        """Estimated C(n,m) (3, 3) at :attr:`time`, or None before alignment."""
        return None if self._q is None else quat_to_dcm(np.array(self._q))

    @property
    def corrected_rate(self) -> np.ndarray | None:
        """Latest bias-corrected inertial rate of the inner gimbal (p̂_m by eq. 4, q̂_m, r̂_m)
        [rad/s], (3,), at :attr:`time`; None until encoders and INS rates are in."""
        return None if self._w_prev is None else np.array(self._w_prev)

    @property
    def time(self) -> float | None:
        """Stamp of the last integrated gyro sample, which the attitude refers to [s]."""
        return self._t_gyro

    # ------------------------------------------------------------------ input checks
    def fed(self, output: EkfOutput | None, why: str | None = None) -> Fed:
        """The :class:`Fed` of a sample used: ``output`` and the re-alignments since the last call."""
        realigned, self._realigned = tuple(self._realigned), []
        return Fed(True, why, output, realigned)

    def rejected(self) -> Fed:
        """Count a sample refused by a check (:meth:`check_gyro` …) and say why."""
        self._count(rejected_nonfinite=1)
        return _NONFINITE

    @staticmethod
    def check_gyro(t: float, q_m: float, r_m: float) -> tuple[float, float, float] | None:
        """(t, q_m, r_m) as floats, or None when a value is non-finite or not a number."""
        try:
            t, q_m, r_m = float(t), float(q_m), float(r_m)
        except (TypeError, ValueError):
            return None
        # A sum is finite iff every term is (NaN and ±inf propagate); one call instead of three.
        return (t, q_m, r_m) if math.isfinite(t + q_m + r_m) else None

    @staticmethod
    def check_encoders(t: float, angles: Sequence[float], rates: Sequence[float] | None = None
                       ) -> tuple[float, tuple[float, float, float]] | None:
        """(t, (ψt, ψm, θm)) as floats, or None; ``rates`` [rad/s] are checked but unused (eq. 4
        needs no joint rate once r_m is measured)."""
        try:
            t = float(t)
            a = (float(angles[0]), float(angles[1]), float(angles[2]))
            ok = len(angles) == 3 and math.isfinite(t + a[0] + a[1] + a[2])
            if rates is not None:
                ok = ok and len(rates) == 3 and math.isfinite(float(rates[0]) + float(rates[1]) + float(rates[2]))
        except (TypeError, ValueError, IndexError):
            return None
        return (t, a) if ok else None

    @staticmethod
    def check_ins(t: float, euler: Sequence[float] | None, omega_b: Sequence[float]) -> tuple | None:
        """(t, euler or None, (p, q, r)) as floats, or None (``euler=None``: the rates only)."""
        try:
            t = float(t)
            e = None if euler is None else (float(euler[0]), float(euler[1]), float(euler[2]))
            w = (float(omega_b[0]), float(omega_b[1]), float(omega_b[2]))
            ok = len(omega_b) == 3 and math.isfinite(t + w[0] + w[1] + w[2]) \
                and (e is None or (len(euler) == 3 and math.isfinite(e[0] + e[1] + e[2])))
        except (TypeError, ValueError, IndexError):
            return None
        return (t, e, w) if ok else None

    def take_outputs(self) -> list[EkfOutput]:
        """Every output produced since the last call, oldest first (an ``on_*`` may complete several)."""
        out, self.outputs = self.outputs, []
        return out

    def _omega(self, q_m: float, r_m: float, rates: tuple[float, float, float]) -> tuple[float, float, float]:
        """Bias-corrected ω_im^m, p̂_m by eq. 4, with the trig of the current joint angles."""
        ca, sa, ct, st = self._trig
        b = self._b
        q = q_m - b[1]
        r = r_m - b[2]
        if abs(ct) < _SINGULAR_COS:
            self._count(singular_elevation=1)
            p = self._p_m_last
        else:
            p = (ca * rates[0] + sa * rates[1] - b[0] - st * r) / ct
        self._p_m_last = p
        return (p, q, r)

    def integrate(self, t: float, q_m: float, r_m: float, angles: Sequence[float] | None,
                  rates: Sequence[float] | None) -> None:
        """A gyro sample at ``t`` [s] (q_m, r_m [rad/s] about m-y, m-z) with the encoder angles
        (ψt, ψm, θm) [rad] and INS body rates (p, q, r) [rad/s] of its stamp (None: not in yet):
        mechanize from the previous gyro sample to this one (trapezoid in ω)."""
        t_prev = self._t_gyro
        self._t_gyro = t
        if angles is None or rates is None:
            self._w_prev = None
            return
        az = angles[0] + angles[1]
        self._trig = (math.cos(az), math.sin(az), math.cos(angles[2]), math.sin(angles[2]))
        w = self._omega(q_m, r_m, rates)
        w0 = self._w_prev
        self._w_prev = w
        if self._q is None or t_prev is None:
            return
        dt = t - t_prev
        if dt > self.params.max_gyro_gap_s:
            self._realign(f"gyro gap of {dt:.4f} s", t)
            return
        self._mechanize(w0 if w0 is not None else w, w, dt)
        if t - self._t_cov >= self.params.covariance_period_s:
            self._propagate_covariance()

    # ------------------------------------------------------------------ mechanization
    def _mechanize(self, w0: Sequence[float], w1: Sequence[float], dt: float) -> None:
        """Ĉ ← exp(−[ω_in Δt×]) Ĉ exp([φ×]) on the quaternion (:func:`.gyro_bias_ekf_kernels.mechanize`)."""
        self._q = list(kernels.mechanize(tuple(self._q), tuple(w0), tuple(w1), dt, self._win))

    def _A_now(self) -> np.ndarray:
        """C_nm M (3, 3) at the current estimate and elevation (:func:`.gyro_bias_ekf_kernels.a_matrix`)."""
        _, _, ct, st = self._trig
        return kernels.a_matrix(tuple(self._q), ct, st)

    def _propagate_covariance(self) -> None:
        """P over [t_cov, t_gyro] with the discretised error model (module docstring)."""
        T = self._t_gyro - self._t_cov
        if T <= 0.0:
            return
        A1 = self._A_now()
        self.P, f_e = kernels.propagate(self.P, 0.5 * (self._A_cov + A1), T, np.asarray(self.omega_in_n, dtype=float),
                                        self._n_psd, self._qb_psd, self._pe_var, self.params.ins_attitude_tau_s)
        if self.n_states == N_STATES_INS:
            self._e = self._e * f_e
        self._t_cov = self._t_gyro
        self._A_cov = A1

    # ------------------------------------------------------------------ measurement
    def fuse(self, t_ins: float, euler: Sequence[float], angles: Sequence[float]) -> EkfOutput:
        """The INS attitude (φ, θ, ψ) [rad] at ``t_ins`` [s], reached by the integration, with
        the encoder angles [rad] of its stamp: align, or update (gated)."""
        q_meas, Je, Jenc = kernels.measurement(tuple(euler), tuple(angles))
        R = kernels.measurement_cov(Jenc, Je, self._enc_var, self._floor_var, self._pe_var,
                                    self.n_states == N_STATES_BASE)
        if self._q is None:
            return self._align(t_ins, q_meas, Je, R)
        self._propagate_covariance()
        n = self.n_states
        hx, hy, hz, hw = self._q
        mx, my, mz, mw = q_meas
        # z = log(C_meas Ĉᵀ): rotation vector of q_meas ⊗ conj(q̂).
        ex = -mw * hx + mx * hw - my * hz + mz * hy
        ey = -mw * hy + mx * hz + my * hw - mz * hx
        ez = -mw * hz - mx * hy + my * hx + mz * hw
        ew = mw * hw + mx * hx + my * hy + mz * hz
        z = np.array(_rotvec_from_quat(ex, ey, ez, ew))
        H = self._H
        x = np.zeros(n)
        if n == N_STATES_INS:
            H[:, INS_ERROR] = Je
            x[INS_ERROR] = self._e
        accepted, x_up, P_up, y, d2 = kernels.joseph_update3(x, self.P, z, H, R, self._gate)
        up = kalman.Update(x_up, P_up, y, None, float(d2), bool(accepted))
        if up.accepted:
            self._consecutive_gated = 0
            self._count(updates=1)
            self.P = up.P
            dx = up.x.tolist()
            # Ĉ ← exp([ψ̂×]) Ĉ, then b̂ ← b̂ + δb̂ (the error state is reset to zero).
            self._q = list(quat_mul(_rotvec_quat(*dx[PSI]), self._q))
            db = dx[BIAS]
            self._b = [self._b[i] + db[i] for i in range(3)]
            if n == N_STATES_INS:
                self._e = up.x[INS_ERROR].copy()
            if self._w_prev is not None:
                # The next trapezoid starts from this sample: correct it with the new biases.
                _, _, ct, st = self._trig
                ct = ct if abs(ct) >= _SINGULAR_COS else math.copysign(_SINGULAR_COS, ct)
                p, q, r = self._w_prev
                self._w_prev = (p - (db[0] - st * db[2]) / ct, q - db[1], r - db[2])
        else:
            self._count(gated=1)
            self._consecutive_gated += 1
            if self._consecutive_gated >= self.params.max_consecutive_gated:
                out = self._output(t_ins, up.y, up.d2, False, up.d2)
                self._realign(f"{self._consecutive_gated} consecutive innovations beyond the gate", t_ins)
                return out
        return self._output(t_ins, up.y, up.d2, up.accepted, up.d2)

    def _align(self, t: float, q_meas: tuple[float, float, float, float], Je: np.ndarray,
               R: np.ndarray) -> EkfOutput:
        """Initial (or re-)alignment Ĉ = C_meas; ψ = −δα, so P_ψψ = J_e P_e J_eᵀ + R and
        P_ψe = −J_e P_e with the INS-error states."""
        n = self.n_states
        self._q = list(q_meas)
        keep = self._P_bb_keep
        self._P_bb_keep = None
        if n == N_STATES_INS:
            self._e = np.zeros(3)
        self.P = kernels.align_cov(n, R, Je, self._pe_var, keep if keep is not None else self._Pb0)
        self._t_cov = self._t_gyro
        self._A_cov = self._A_now()
        self._consecutive_gated = 0
        return self._output(t, np.zeros(3), 0.0, True, None)

    def _output(self, t: float, y: np.ndarray, d2: float, accepted: bool, nis: float | None) -> EkfOutput:
        P = self.P
        out = EkfOutput(t, np.array(self._b), np.sqrt(np.diag(P)[BIAS]), np.array(self._q),
                        P[PSI, PSI].copy(), np.asarray(y, dtype=float), float(d2), accepted, self.counters,
                        nis)
        self.outputs.append(out)
        if len(self.outputs) > _MAX_OUTPUTS:  # a caller that never takes them
            del self.outputs[0]
        return out
