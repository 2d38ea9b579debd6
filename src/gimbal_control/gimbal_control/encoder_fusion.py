"""Paper 2: two-axis gimbal stabilization by PID with encoder/gyro fusion (docs/spec.md §3.2).

What the loop controls (our reading of paper 2, Fig. 1)
-------------------------------------------------------
Each axis runs a PID driven by a *velocity* error. The steering reference comes from the
base gyros through the "quaternion transformation": it is the joint rate that cancels the
base's motion about that axis. The feedback velocity is the gimbal's own velocity.
Comparing a joint-rate reference −(base rate about the axis) with a joint-rate feedback is
the same as comparing a zero inertial-rate reference with the inertial rate of the inner
gimbal m. This core therefore works in the inertial form, one loop per gimbal-gyro axis::

    elevation  q_m = (C_mb ω_b)_y + θ̇m              -> elevation torque τ_e = u_q
    azimuth    r_m = (C_mb ω_b)_z + cos θm ψ̇m       -> azimuth torque τ_a = u_r / cos θm

Here C_mb = rot2(θm) rot3(ψm); there is no turret, the azimuth axis sits on the airframe.
Velocity error e = ω_ref − ω_fb, with ω_ref = 0 to stabilize (:meth:`set_rate_reference`
slews). The PID acts on the angle error ∫e dt, the LOS angle the loop believes it has
lost, and its D term is e itself:

    u = k_p ∫e + k_i ∫∫e + k_d e.

A PI on e alone would leave a constant-torque offset (gravity on the mass imbalance) of
τ/k_i in the LOS. The gains come from pole placement (:func:`.pid.pole_placement_gains`).
``mode`` picks ω_fb:

* ``encoder``: paper 2's loop "without correction". ω_fb is the base part (C_mb ω_b from
  the UAV autopilot's rates) plus the encoder velocity. That velocity is the pulse count
  over a gate T_g, held between gates (paper 2 eq. 1: ω = 60 f/N rpm = Δcount·δ/T_g rad/s;
  1024 lines and T_g = 0.2 s give the paper's ≈ 2°/s resolution). The count is exact, so
  the LOS cannot drift. But the velocity is coarse and about T_g late, so the loop has to
  be slow (its own gains).
* ``gyro``: the raw MEMS gyro (q_m, r_m). Full bandwidth, but the loop nulls the
  *measured* rate, so the LOS drifts at the gyro bias.
* ``fused``: the gyro corrected by paper 2's closed-loop complementary Kalman filter
  (:mod:`.fusion_kf`), ω̂ = ω_g (1 + S) + E + A. The filter's measurement is the encoder
  rate minus the corrected gyro rate, integrated: a running discrepancy
  D = ψ_enc − ψ̃ = ∫(base part) dt + Δ(encoder angle) − ∫ω̃ dt (trapezoids over the 1 kHz
  ticks). ψ̃ takes each angle correction at once; the loop receives it as the rate A over
  the next gate. Once per gate T_g (the paper 2 eq. 1 gate, computed here from the encoder
  angles so the integrals span exactly the same ticks) the filter takes z = D averaged
  over the gate. The joint motion dithers the count quantisation, so this average is
  about 3.5 times less noisy than one count (σ ≈ 0.03° here against δ/√12 = 0.1°). z is
  taken relative to the first gate's average, which also zeroes the encoder reference
  better than a single count does. T = T_g, and Δψ_g = ∫ω_g over the gate.

Message-driven API (times are message stamps [s]; SI units; no wall clock)::

    ctl.on_base_rates(t, omega_b)      # UAV body inertial rates (3,) [rad/s], in b
    ctl.on_encoders(t, psi_m, theta_m) # joint angles [rad] (quantised counts)
    out = ctl.on_gyro(t, q_m, r_m)     # gimbal gyro [rad/s] -> FusionCommand (torques)
    out = ctl.step(t, omega_b, psi_m, theta_m, q_m, r_m)  # the three at once (the node)

Feed the encoder and base samples of a stamp before the gyro sample of the same stamp,
as the lockstep graph orders them; the gyro sample is the control tick. Stamps come checked
and in order, each stream's rising: the node's input policy
(:mod:`gimbal_kinematics.timing.control_policy`) drops repeated and late ones and, on a clock jump
back, calls :meth:`~EncoderFusionController.reset`. Bad input:

* NaN/inf inputs are rejected and counted. A bad gyro sample returns the last command with
  ``held`` set; so does :meth:`~EncoderFusionController.step` for a bad value in any of its
  inputs.
* A gap longer than ``max_gap_s`` restarts the gate without integrating across it.

The closed-loop experiment on the simulated UAV gimbal (plant, base motion, MEMS gyro) sits
with the simulator, in its ``experiments.encoder_fusion`` module: this core needs none of it.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import NamedTuple, Sequence

from gimbal_kinematics.maths.validate import positive
from gimbal_kinematics.params.table import ParameterError
from gimbal_kinematics.gimbal.gimbal_params import UAV_SMALL_GIMBAL

from .fusion_kf import ClosedLoopComplementaryKf, FusionKfParams
from .pid import Pid, PidParams, pole_placement_gains

MODES = ("encoder", "gyro", "fused")


# ============================================================================ parameters
#: Small UAV gimbal inertias about the loop axes at θm = −20° [kg·m²] (from
#: :data:`UAV_SMALL_GIMBAL`'s mass matrix; the test checks them): used by the default gains.
UAV_AZIMUTH_INERTIA_KG_M2 = 1.35e-3
UAV_ELEVATION_INERTIA_KG_M2 = 8.0e-4

#: Fused/gyro loops: triple pole at 8 Hz; at 1 kHz (ZOH) the loop crosses over at ≈ 24 Hz
#: with ≈ 67° phase margin.
LOOP_BANDWIDTH_HZ = 8.0
#: Encoder loop: the pulse-count velocity is held for T_g = 0.2 s and lags about T_g, so
#: the loop must stay far slower. 0.3 Hz was the best of a sweep in the UAV experiment
#: (12 s, seed 1: 0.15/0.2/0.3/0.4 Hz gave 83/54/51/190 mrad RMS; 0.5 Hz and faster go
#: unstable on the gate delay).
ENCODER_LOOP_BANDWIDTH_HZ = 0.3
#: PID output clip [N·m]: the UAV gimbal's motor torque limit.
TORQUE_LIMIT_NM = UAV_SMALL_GIMBAL.azimuth_torque_limit_nm
#: Highest loop bandwidth per Hz of control rate: a triple-pole loop crosses over at about
#: 3 x its bandwidth; at sim_rate_hz / 25 the zero-order hold's half-sample delay leaves
#: >= 45 deg of phase margin (49 deg measured).
BANDWIDTH_PER_RATE = 1.0 / 25.0


def _gains(inertia: float, hz: float) -> PidParams:
    return pole_placement_gains(inertia, hz, output_limit=TORQUE_LIMIT_NM)


@dataclass(frozen=True)
class EncoderFusionParams:
    """Controller parameters (validated, immutable).

    Attributes:
        mode: feedback velocity, one of ``MODES``.
        encoder_gate_s: pulse-count gate T_g [s] (paper 2 eq. 1).
        elevation_pid / azimuth_pid: PID of the q_m / r_m loop (gyro, fused modes): P and
            I on the angle error ∫(ω_ref − ω_fb) dt, D on the velocity error; outputs N·m.
        encoder_elevation_pid / encoder_azimuth_pid: gains used in ``encoder`` mode.
        kf: the complementary filter's Q, R, P0 (``fused`` mode).
        min_cos_elevation: floor of cos θm in τ_a = u_r / cos θm (near θm = ±90° the
            azimuth motor no longer turns the LOS about m-z).
        max_gap_s: a longer gap between control ticks restarts the gate and derivative [s].
    """

    mode: str = "fused"
    encoder_gate_s: float = 0.2
    elevation_pid: PidParams = field(default_factory=lambda: _gains(UAV_ELEVATION_INERTIA_KG_M2, LOOP_BANDWIDTH_HZ))
    azimuth_pid: PidParams = field(default_factory=lambda: _gains(UAV_AZIMUTH_INERTIA_KG_M2, LOOP_BANDWIDTH_HZ))
    encoder_elevation_pid: PidParams = field(default_factory=lambda: _gains(UAV_ELEVATION_INERTIA_KG_M2, ENCODER_LOOP_BANDWIDTH_HZ))
    encoder_azimuth_pid: PidParams = field(default_factory=lambda: _gains(UAV_AZIMUTH_INERTIA_KG_M2, ENCODER_LOOP_BANDWIDTH_HZ))
    kf: FusionKfParams = field(default_factory=FusionKfParams)
    min_cos_elevation: float = 0.2
    max_gap_s: float = 0.05

    def __post_init__(self) -> None:
        if self.mode not in MODES:
            raise ValueError(f"mode must be one of {MODES}, got {self.mode!r}")
        for name in ("encoder_gate_s", "max_gap_s"):
            positive(name, getattr(self, name))
        v = self.min_cos_elevation
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not 0.0 < v <= 1.0:
            raise ValueError(f"min_cos_elevation must be in (0, 1], got {v!r}")
        for name in ("elevation_pid", "azimuth_pid", "encoder_elevation_pid", "encoder_azimuth_pid"):
            if not isinstance(getattr(self, name), PidParams):
                raise ValueError(f"{name} must be a PidParams")
        if not isinstance(self.kf, FusionKfParams):
            raise ValueError("kf must be a FusionKfParams")

    @classmethod
    def from_values(cls, v: dict) -> EncoderFusionParams:
        """The parameters from an ``encoder_fusion_controller`` node's values (name -> value,
        as declared in :mod:`.encoder_fusion_controller_params`): the PID gains placed for
        the loop inertias and bandwidths, the filter's Q, R, P0 (``kf_gate_sigma`` 0: no
        gate); :class:`ParameterError` names the parameter refused."""
        rate = v["sim_rate_hz"]
        if v["loop_bandwidth_hz"] > rate * BANDWIDTH_PER_RATE:
            raise ParameterError(f"parameter 'loop_bandwidth_hz' = {v['loop_bandwidth_hz']} Hz exceeds "
                                 f"sim_rate_hz / 25 = {rate * BANDWIDTH_PER_RATE:g} Hz (the sampled loop would "
                                 "lose its phase margin)")
        if v["encoder_gate_s"] * rate < 1.0 - 1e-9:
            raise ParameterError(f"parameter 'encoder_gate_s' = {v['encoder_gate_s']} s is shorter than one step")

        def gains(inertia: str, bandwidth: str) -> PidParams:
            return pole_placement_gains(v[inertia], v[bandwidth], output_limit=v["torque_limit_nm"],
                                        derivative_tau_s=v["derivative_tau_s"])

        try:
            kf = FusionKfParams(q_angle_deg_rt_s=v["kf_q_angle_deg_rt_s"], q_scale_rt_s=v["kf_q_scale_rt_s"],
                                q_drift_deg_s_rt_s=v["kf_q_drift_deg_s_rt_s"], r_deg=v["kf_r_deg"],
                                p0_angle_deg=v["kf_p0_angle_deg"], p0_scale=v["kf_p0_scale"],
                                p0_drift_deg_s=v["kf_p0_drift_deg_s"], gate_sigma=v["kf_gate_sigma"] or math.inf)
            return cls(
                mode=v["mode"], encoder_gate_s=v["encoder_gate_s"],
                elevation_pid=gains("elevation_inertia_kg_m2", "loop_bandwidth_hz"),
                azimuth_pid=gains("azimuth_inertia_kg_m2", "loop_bandwidth_hz"),
                encoder_elevation_pid=gains("elevation_inertia_kg_m2", "encoder_loop_bandwidth_hz"),
                encoder_azimuth_pid=gains("azimuth_inertia_kg_m2", "encoder_loop_bandwidth_hz"),
                kf=kf, min_cos_elevation=v["min_cos_elevation"], max_gap_s=v["max_gap_s"])
        except ValueError as exc:
            raise ParameterError(str(exc)) from exc


class FusionCommand(NamedTuple):
    """Output of a control tick: joint torques [N·m], the feedback velocities used
    [rad/s] and whether the command was held (bad input)."""

    t: float
    torque_azimuth: float
    torque_elevation: float
    velocity_q: float
    velocity_r: float
    held: bool


# ============================================================================ the core
class EncoderFusionController:
    """Two-axis PID stabilizer with per-axis encoder/gyro fusion (module docstring)."""

    def __init__(self, params: EncoderFusionParams | None = None) -> None:
        self.params = params if params is not None else EncoderFusionParams()
        if not isinstance(self.params, EncoderFusionParams):
            raise ValueError("params must be an EncoderFusionParams")
        p = self.params
        enc = p.mode == "encoder"
        self.pid_q = Pid(p.encoder_elevation_pid if enc else p.elevation_pid)
        self.pid_r = Pid(p.encoder_azimuth_pid if enc else p.azimuth_pid)
        self.kf_q = ClosedLoopComplementaryKf(p.kf, "fusion_kf_q")
        self.kf_r = ClosedLoopComplementaryKf(p.kf, "fusion_kf_r")
        self.rejected_nonfinite = 0
        self.held_commands = 0
        self.reset_reasons: list[str] = []
        self._reset_state()

    # ------------------------------------------------------------------ state
    def _reset_state(self) -> None:
        self.pid_q.reset()
        self.pid_r.reset()
        self.kf_q.reset()
        self.kf_r.reset()
        self._t_enc = self._t_tick = None
        self._omega_b = (0.0, 0.0, 0.0)
        self._have_base = False
        self._psi = self._theta = 0.0
        self._have_enc = False
        self._cmd = (0.0, 0.0)
        self._rate_ref = (0.0, 0.0)
        self._ang_q = self._ang_r = 0.0  # angle errors ∫(ω_ref − ω_fb) dt [rad]
        self._e_prev: tuple[float, float] | None = None
        self._dt_last = 1e-3
        #: encoder joint velocities (ψ̇m, θ̇m) of the last completed gate [rad/s]
        self.encoder_rates = (0.0, 0.0)
        self.feedback = (0.0, 0.0)
        self._restart_gate()

    def _restart_gate(self) -> None:
        self._gate_t0 = None  # stamp of the encoder angles that open the gate
        self._gate_psi0 = self._gate_theta0 = 0.0
        self._int_gq = self._int_gr = 0.0  # ∫ raw gyro q, r over the gate (Δψ_g)
        self._int_t = 0.0
        # running discrepancy D = ψ_enc − ψ̃ since the restart, ψ̃ = the angle with every
        # filter correction applied at once (module docstring), and its sum over the gate
        self._disc_q = self._disc_r = 0.0
        self._dsum_q = self._dsum_r = 0.0
        self._nsum = 0
        self._anchor: tuple[float, float] | None = None
        self._prev_tick_vals: tuple | None = None

    def reset(self, reason: str) -> None:
        """Reset filter, PIDs and gate; ``reason`` is recorded in ``reset_reasons``."""
        self.reset_reasons.append(reason)
        self._reset_state()

    def set_rate_reference(self, q_ref: float, r_ref: float) -> None:
        """Commanded inertial LOS rates [rad/s] (0, 0 = stabilize)."""
        if not (math.isfinite(q_ref) and math.isfinite(r_ref)):
            self.rejected_nonfinite += 1
            return
        self._rate_ref = (float(q_ref), float(r_ref))

    @property
    def corrections(self) -> tuple[float, float]:
        """Accumulated drift corrections E (q, r) [rad/s] (≈ −gyro bias when converged)."""
        return self.kf_q.drift_correction, self.kf_r.drift_correction

    # ------------------------------------------------------------------ inputs
    def on_base_rates(self, t: float, omega_b: Sequence[float]) -> None:
        """Base (UAV body) inertial rates (3,) [rad/s] resolved in b at stamp ``t`` [s]."""
        wx, wy, wz = (float(v) for v in omega_b)
        if not (math.isfinite(wx) and math.isfinite(wy) and math.isfinite(wz)):
            self.rejected_nonfinite += 1
            return
        self._omega_b = (wx, wy, wz)
        self._have_base = True

    def on_encoders(self, t: float, psi_m: float, theta_m: float) -> None:
        """Encoder joint angles [rad] (azimuth ψm, elevation θm) at stamp ``t`` [s]."""
        if not (math.isfinite(psi_m) and math.isfinite(theta_m)):
            self.rejected_nonfinite += 1
            return
        self._t_enc = t
        self._psi, self._theta = float(psi_m), float(theta_m)
        self._have_enc = True

    def on_gyro(self, t: float, q_m: float, r_m: float) -> FusionCommand | None:
        """Control tick on a gimbal gyro sample (q_m, r_m) [rad/s]; returns the torques.

        Returns None until base rates and encoder angles have arrived; a non-finite sample
        returns the last command with ``held=True``.
        """
        if not (math.isfinite(q_m) and math.isfinite(r_m)):
            self.rejected_nonfinite += 1
            self.held_commands += 1
            return FusionCommand(t, self._cmd[0], self._cmd[1], self.feedback[0], self.feedback[1], True)
        if not (self._have_base and self._have_enc):
            self._t_tick = t
            return None
        dt = 0.0 if self._t_tick is None else t - self._t_tick
        self._t_tick = t
        if dt > self.params.max_gap_s:
            self.reset_reasons.append(f"gap of {dt:.3f} s before t={t:.3f}: gate restarted")
            self._restart_gate()
            self.pid_q.forget_previous()
            self.pid_r.forget_previous()
            self._e_prev = None
            dt = 0.0

        # base part of the inertial rates of m: (C_mb ω_b)_y, _z with C_mb = rot2(θ) rot3(ψ)
        wx, wy, wz = self._omega_b
        cpsi, spsi = math.cos(self._psi), math.sin(self._psi)
        cth, sth = math.cos(self._theta), math.sin(self._theta)
        bq = -spsi * wx + cpsi * wy
        br = sth * (cpsi * wx + spsi * wy) + cth * wz

        mode = self.params.mode
        if mode == "gyro":
            fq, fr = q_m, r_m
        elif mode == "fused":
            tg = self.params.encoder_gate_s
            fq = self.kf_q.corrected_rate(q_m, tg)
            fr = self.kf_r.corrected_rate(r_m, tg)
        else:
            fq = bq + self.encoder_rates[1]
            fr = br + cth * self.encoder_rates[0]
        self._accumulate_gate(dt, q_m, r_m, bq, br, cth)
        self.feedback = (fq, fr)
        if dt > 0.0:
            self._dt_last = dt
        else:
            dt = self._dt_last  # first tick after a (re)start: the PID has no history
        # PID on the angle error (the integral of the velocity error), D from the velocity
        eq, er = self._rate_ref[0] - fq, self._rate_ref[1] - fr
        if self._e_prev is not None:
            self._ang_q += 0.5 * dt * (self._e_prev[0] + eq)
            self._ang_r += 0.5 * dt * (self._e_prev[1] + er)
        self._e_prev = (eq, er)
        uq = self.pid_q.step(self._ang_q, dt, error_rate=eq)
        ur = self.pid_r.step(self._ang_r, dt, error_rate=er)
        tau_a = ur / max(cth, self.params.min_cos_elevation)
        self._cmd = (tau_a, uq)
        return FusionCommand(t, tau_a, uq, fq, fr, False)

    def step(self, t: float, omega_b: Sequence[float], psi_m: float, theta_m: float,
             q_m: float, r_m: float) -> FusionCommand | None:
        """One lockstep tick with all three inputs stamped ``t`` [s]: base rates (3,)
        [rad/s], encoder angles [rad], gyro rates [rad/s]. A non-finite value in any of
        them holds the last command (``held``, counted in ``held_commands``) without
        ticking the loop, so no stale angle or rate enters the gate or the PID."""
        return self.tick(t, q_m, r_m, (t, omega_b), (t, psi_m, theta_m))

    def tick(self, t: float, q_m: float, r_m: float, base: tuple[float, Sequence[float]] | None = None,
             encoders: tuple[float, float, float] | None = None) -> FusionCommand | None:
        """A control tick on a gyro sample stamped ``t`` [s] (:meth:`on_gyro`), after the
        inputs new since the last tick: ``base`` (t_b, omega_b) and ``encoders`` (t_e, ψm, θm)
        (None: none new). A non-finite one holds the last command as in :meth:`step`."""
        bad_before = self.rejected_nonfinite
        if base is not None:
            self.on_base_rates(*base)
        if encoders is not None:
            self.on_encoders(*encoders)
        if self.rejected_nonfinite > bad_before:
            self.held_commands += 1
            return FusionCommand(t, self._cmd[0], self._cmd[1], self.feedback[0], self.feedback[1], True)
        return self.on_gyro(t, q_m, r_m)

    @property
    def command(self) -> tuple[float, float]:
        """The last command (τ_a, τ_e) [N·m]."""
        return self._cmd

    # ------------------------------------------------------------------ gate + filter
    def _accumulate_gate(self, dt: float, q: float, r: float, bq: float, br: float, cth: float) -> None:
        """Trapezoid integrals over the gate; closes it when the encoder stamp has moved on
        by T_g (the encoder angle difference then spans exactly the integrated ticks)."""
        fused = self.params.mode == "fused"
        # ψ̃ rates: the gyro with the accumulated scale and drift corrections, no pending angle
        wq = self.kf_q.corrected_rate(q, math.inf) if fused else q
        wr = self.kf_r.corrected_rate(r, math.inf) if fused else r
        vals = (q, r, bq, br, cth, wq, wr, self._psi, self._theta)
        if self._gate_t0 is None:
            self._open_gate(vals)
            return
        pq, pr, pbq, pbr, pcth, pwq, pwr, ppsi, ptheta = self._prev_tick_vals
        h = 0.5 * dt
        self._int_gq += h * (pq + q)
        self._int_gr += h * (pr + r)
        self._int_t += dt
        self._prev_tick_vals = vals
        if fused:
            self._disc_q += h * (pbq + bq) + (self._theta - ptheta) - h * (pwq + wq)
            self._disc_r += h * (pbr + br) + 0.5 * (pcth + cth) * (self._psi - ppsi) - h * (pwr + wr)
            self._dsum_q += self._disc_q
            self._dsum_r += self._disc_r
            self._nsum += 1
        if self._t_enc - self._gate_t0 >= self.params.encoder_gate_s - 1e-9:
            self._close_gate()
            self._open_gate(vals)

    def _open_gate(self, vals: tuple) -> None:
        self._gate_t0 = self._t_enc
        self._gate_psi0, self._gate_theta0 = self._psi, self._theta
        self._int_gq = self._int_gr = self._int_t = 0.0
        self._dsum_q = self._dsum_r = 0.0
        self._nsum = 0
        self._prev_tick_vals = vals

    def _close_gate(self) -> None:
        T = self._t_enc - self._gate_t0
        self.encoder_rates = ((self._psi - self._gate_psi0) / T, (self._theta - self._gate_theta0) / T)
        if self.params.mode != "fused" or self._nsum == 0:
            return
        # z: the discrepancy averaged over the gate (the motion dithers the quantisation),
        # relative to the first gate's average (a better zero than the single first count)
        zq, zr = self._dsum_q / self._nsum, self._dsum_r / self._nsum
        if self._anchor is None:
            self._anchor = (zq, zr)
            return
        Ti = self._int_t
        for kf, dpsi, z, axis in ((self.kf_q, self._int_gq, zq - self._anchor[0], 0),
                                  (self.kf_r, self._int_gr, zr - self._anchor[1], 1)):
            kf.predict(Ti, dpsi)
            if kf.update(z):
                # ψ̃ takes the angle correction at once; the loop gets it over the next gate
                if axis == 0:
                    self._disc_q -= kf.pending_angle
                else:
                    self._disc_r -= kf.pending_angle
