"""Paper 1 LOS rate stabilization: dynamic inversion + PI on the inertial LOS rate (§5).

Plant model (:mod:`.linearize`): at rest ẏ = ẏ₀ + A′x + B′u with x = (ψm, θm, ψ̇m, θ̇m),
y = (ψ̇m, θ̇m), u = (τ_a, τ_e). Inverting it for commanded joint accelerations ÿ_c,

    τ_c = B′⁻¹ (ÿ_c − A′x − ẏ₀)                                        (paper 1 eq. 30)

(the ẏ₀ term is the gravity trim of our imbalanced gimbal, −B′⁻¹ẏ₀ = u₀; ``trim=False``
drops it and leaves it to the integrator, as in the paper). x comes from the encoders.

Error (paper 1 §5, "task frame to joint frame"): the gyro on the inner gimbal measures the
inertial LOS rates (q_m, r_m); the commanded ones are (q_md, r_md) = 0 to hold the LOS
inertially still (an outer loop may command others; an operator's slew command, shaped by
:mod:`.operator_command`, is added to it: :meth:`LosRateController.reference`). Both are mapped to joint rates with
the chain kinematics (``sighting_chain.task_to_joint_rates``): with w the turret's inertial
rate in the outer frame a (INS body rates, ψt, ψ̇t, ψm) and c, s = cos θm, sin θm,

    ψ̇ = (r − s w₁)/c − w₃,   θ̇ = q − w₂,

and e = (ψ̇md − ψ̇m, θ̇md − θ̇m) = ((r_md − r_m)/c, q_md − q_m). The INS terms cancel in the
difference, so the loop is purely inertial; they set the individual joint rates
(``joint_rate_command``), which the LOS-hold outer loop and telemetry use.

PI (paper 1 eq. 31): ÿ_c = K_p e + K_i ∫e dt, K_p = 2ξω_n I, K_i = ω_n² I. With exact
inversion the inertial rate error obeys ë + k_p ė + k_i e = 0 per axis. No feed-forward
of the desired joint acceleration: the base drives the joints' relative motion itself
(a frictionless balanced gimbal stays inertially still under turret motion with zero
torque); adding d/dt ψ̇md would count the base motion twice.

Discrete implementation at T = 1/rate_hz: trapezoidal (Tustin) integrator I_k = I_{k−1} +
Δt (e_k + e_{k−1})/2 (Δt the stamp difference clipped to ``max_dt_factor``·T; nothing is
integrated at the first sample), v_k = k_p e_k + k_i I_k. I is the LOS angle memory: a
rectangle rule would book e_0 Δt/2 too much when the loop starts with a rate error (the
turret already turns at t = 0: 0.12 rad/s × 1 ms / 2 = 60 µrad of permanent offset). The
loop rate and ω_n come from :mod:`.loop_design` (≥ 45° phase margin with one sample of
extra delay); paper 1's ω_n = 100 Hz needs ≥ 3.7 kHz, so the default is ω_n = 25 Hz at
1 kHz, just under the 27.2 Hz that rate allows: see ``DEFAULT_RATE_HZ``.

Saturation and anti-windup: the command is clipped to the torque limits (the plant's by
default). The integrator here is the LOS angle memory (∫ of the inertial rate error), so
the default anti-windup is *clamping*: each integrator is limited to |k_i I_i| ≤
f·τ_max,i / B′⁻¹_ii (f = ``integrator_limit_factor`` = 4: the integral term alone may ask
for four times the axis' torque authority). It cannot run away while saturated (it sits
at its bound and unwinds in ~(f − 1)·τ_max/(B′⁻¹_ii k_i |e|)), and it keeps the angle swept
during an unavoidable short saturation: at t = 0 the turret already turns the LOS at
0.12 rad/s and stopping it with 3 N·m sweeps ~270 µrad, which at ω_n = 100 Hz is more than
a bound of f = 1 holds (198 µrad of permanent offset in the paper 1 scenario; 0.2 µrad with
f = 4). ``"conditional"`` integration (no integration on a saturated axis whose error
pushes further out; B′⁻¹ = M(0) is diagonally dominant with a positive diagonal) stops at
once but forgets all of that angle (255 µrad offset at ω_n = 100 Hz, 4 kHz).

Bad input: a non-finite measurement or rate command is rejected: the last command is
returned, the event counted (``rejected_inputs``), nothing is integrated. Samples come
checked and in stamp order: duplicates, samples out of order and a clock jump back (a bag
loop, which calls :meth:`LosRateController.reset`) are the node's input policy's
(:mod:`gimbal_kinematics.timing.control_policy`).

Gyro bias: :meth:`LosRateController.set_bias_estimate` stores the EKF's 3-axis bias
estimate (m frame, rad/s); with ``feedback`` its y, z components are subtracted from q_m,
r_m.

Hot path: one call of the compiled :func:`.los_rate_kernels.los_rate_step` per sample, on the
state vector this class holds (the engine's compiled loop calls the same kernel).
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from gimbal_kinematics.params.table import ParameterError
from gimbal_kinematics.maths.validate import positive
from gimbal_kinematics.gimbal.gimbal_params import GimbalParams
from gimbal_kinematics.maths.units import G0
from gimbal_kinematics.maths.outcome import Fed
from gimbal_kinematics.maths.attribute_views import slot

from . import los_rate_kernels as lk
from .linearize import linearize_gimbal
from .operator_command import OperatorCommand

#: Default loop rate [Hz]: the lockstep simulation rate of the paper 1 scenario (and the
#: rate of its sensors); 1000 steps per simulated second.
DEFAULT_RATE_HZ = 1000.0
#: Default ω_n [Hz] at 1 kHz, under ``loop_design.max_omega_n_hz(1000)`` = 27.2 Hz: PM
#: 47.0°, GM 11.5 dB with one extra sample of delay; 62.4°, 18.0 dB in the lockstep graph.
#: The paper's 100 Hz needs 4 kHz (PM 47.0° / 62.3°) at four times the steps.
DEFAULT_OMEGA_N_HZ = 25.0
PAPER_OMEGA_N_HZ = 100.0
PAPER_ZETA = 0.8
ANTI_WINDUP_MODES = ("clamp", "conditional", "none")


@dataclass(frozen=True)
class LosRateControllerParams:
    """Controller parameters (validated, immutable).

    Attributes:
        rate_hz: loop rate [Hz] (nominal Δt of the integrator).
        omega_n_hz: closed-loop natural frequency ω_n [Hz]; must be < rate_hz / 4.
        zeta: damping ratio ξ (> 0).
        feedback: subtract the gyro-bias estimate from (q_m, r_m).
        azimuth_torque_limit_nm, elevation_torque_limit_nm: output limits [N·m]; None
            takes the plant's (``GimbalParams``).
        anti_windup: ``"clamp"`` (default: |k_i I| limited to what the axis' torque limit
            can deliver), ``"conditional"`` (no integration on a saturated axis pushing
            outwards) or ``"none"`` (comparisons only); module docstring.
        integrator_limit_factor: ``"clamp"`` bound, as a multiple of the torque limit that
            the integral term alone may ask for (> 0).
        trim: feed forward the gravity trim torque of the linearisation point.
        gravity_m_s2: gravity of the linearisation [m/s²].
        min_cos_elevation: |cos θm| floor in the 1/c of the azimuth error (gimbal lock at
            θm = ±90°); below it the gain is limited and ``singular_steps`` counts.
        max_dt_factor: largest integration step as a multiple of 1/rate_hz (a gap in
            the stamps does not make one huge integrator step).
    """

    rate_hz: float = DEFAULT_RATE_HZ
    omega_n_hz: float = DEFAULT_OMEGA_N_HZ
    zeta: float = PAPER_ZETA
    feedback: bool = True
    azimuth_torque_limit_nm: float | None = None
    elevation_torque_limit_nm: float | None = None
    anti_windup: str = "clamp"
    integrator_limit_factor: float = 4.0
    trim: bool = True
    gravity_m_s2: float = G0
    min_cos_elevation: float = 0.05
    max_dt_factor: float = 2.0

    def __post_init__(self) -> None:
        positive("rate_hz", self.rate_hz)
        positive("omega_n_hz", self.omega_n_hz)
        if self.omega_n_hz >= self.rate_hz / 4.0:
            raise ValueError(f"omega_n_hz must be < rate_hz / 4 = {self.rate_hz / 4.0} Hz (the loop crosses over "
                             f"at ~1.7 ω_n), got {self.omega_n_hz}")
        positive("zeta", self.zeta)
        positive("integrator_limit_factor", self.integrator_limit_factor)
        if self.anti_windup not in ANTI_WINDUP_MODES:
            raise ValueError(f"anti_windup must be one of {ANTI_WINDUP_MODES}, got {self.anti_windup!r}")
        for name in ("feedback", "trim"):
            if not isinstance(getattr(self, name), bool):
                raise ValueError(f"{name} must be a bool, got {getattr(self, name)!r}")
        for name in ("azimuth_torque_limit_nm", "elevation_torque_limit_nm"):
            value = getattr(self, name)
            if value is not None:
                if isinstance(value, bool) or not isinstance(value, (int, float)) or math.isnan(value) or value <= 0.0:
                    raise ValueError(f"{name} must be > 0 (inf for no limit) or None, got {value!r}")
        if isinstance(self.gravity_m_s2, bool) or not math.isfinite(self.gravity_m_s2) or self.gravity_m_s2 < 0.0:
            raise ValueError(f"gravity_m_s2 must be finite and >= 0, got {self.gravity_m_s2!r}")
        if not (0.0 < self.min_cos_elevation < 1.0):
            raise ValueError(f"min_cos_elevation must be in (0, 1), got {self.min_cos_elevation!r}")
        if not (math.isfinite(self.max_dt_factor) and self.max_dt_factor >= 1.0):
            raise ValueError(f"max_dt_factor must be >= 1, got {self.max_dt_factor!r}")

    @classmethod
    def from_values(cls, v: dict) -> LosRateControllerParams:
        """The parameters from a ``los_rate_controller`` node's values (name -> value, as
        declared in :mod:`.los_rate_controller_params`; the loop runs at ``sim_rate_hz``, and
        ``mode: los_hold`` implies bias feedback); :class:`ParameterError` names the
        parameter refused."""
        try:
            return cls(
                rate_hz=v["sim_rate_hz"], omega_n_hz=v["omega_n_hz"], zeta=v["zeta"],
                feedback=v["feedback"] or v["mode"] == "los_hold", anti_windup=v["anti_windup"],
                integrator_limit_factor=v["integrator_limit_factor"], trim=v["trim"])
        except ValueError as exc:
            raise ParameterError(f"parameter {exc}") from exc

    @property
    def gains(self) -> tuple[float, float]:
        """(k_p, k_i) = (2ξω_n [1/s], ω_n² [1/s²]), ω_n in rad/s."""
        w = 2.0 * math.pi * self.omega_n_hz
        return 2.0 * self.zeta * w, w * w


class LosRateController:
    """Inverse-dynamics PI LOS rate controller (module docstring); one :meth:`step` per
    gyro sample. Pure Python, no ROS; time is the measurement stamp [s]."""

    def __init__(self, params: LosRateControllerParams | None = None,
                 plant_params: GimbalParams | None = None, operator: OperatorCommand | None = None) -> None:
        self.params = params if params is not None else LosRateControllerParams()
        self.operator = operator
        self.plant_params = plant_params if plant_params is not None else GimbalParams()
        p = self.params
        self.model = linearize_gimbal(self.plant_params, p.gravity_m_s2)
        self.kp, self.ki = p.gains
        self.dt_nominal = 1.0 / p.rate_hz
        self._dt_max = p.max_dt_factor * self.dt_nominal
        pp = self.plant_params
        lim_a = pp.azimuth_torque_limit_nm if p.azimuth_torque_limit_nm is None else p.azimuth_torque_limit_nm
        lim_e = pp.elevation_torque_limit_nm if p.elevation_torque_limit_nm is None else p.elevation_torque_limit_nm
        self.torque_limits = (float(lim_a), float(lim_e))
        # Scalars of B′⁻¹ (2×2), A′ (2×4) and the trim for the hot path.
        Bi = self.model.B_prime_inv
        Ap = self.model.A_prime
        (self._b00, self._b01), (self._b10, self._b11) = ((float(v) for v in row) for row in Bi)
        self._a = tuple(tuple(float(v) for v in row) for row in Ap)
        ut = self.model.u_trim if p.trim else (0.0, 0.0)
        self._trim = (float(ut[0]), float(ut[1]))
        self._aw_mode = ANTI_WINDUP_MODES.index(p.anti_windup) + 1 if p.anti_windup != "none" else 0
        # Clamp bounds [rad]: k_i I_i B′⁻¹_ii reaches integrator_limit_factor × the limit.
        f = p.integrator_limit_factor
        self._i_max = (f * lim_a / (self.ki * self._b00), f * lim_e / (self.ki * self._b11))
        self.rejected_bias = 0
        self.last_reset_reason = ""
        self.bias_stamp: float | None = None  # stamp of the bias estimate in use [s]
        # the state and parameter vectors of the kernel (:mod:`.los_rate_kernels`)
        self._s = lk.initial_state()
        self._g = lk.controller_params(self)

    # ----------------------------------------------------------------------- state
    def reset(self, reason: str = "") -> None:
        """Zero the integrators and forget the last stamp and command."""
        s = self._s
        for i in (lk.S_IA, lk.S_IE, lk.S_EA_PREV, lk.S_EE_PREV, lk.S_TAU_A, lk.S_TAU_E, lk.S_JR_A, lk.S_JR_E,
                  lk.S_UNSAT_A, lk.S_UNSAT_E):
            s[i] = 0.0
        s[lk.S_LAST_T] = math.nan
        if reason:
            s[lk.S_RESETS] += 1
            self.last_reset_reason = reason

    def _pair(self, i: int, j: int) -> tuple[float, float]:
        return float(self._s[i]), float(self._s[j])

    integrator = property(lambda self: list(self._pair(lk.S_IA, lk.S_IE)), doc="(I_a, I_e) [rad]")
    command = property(lambda self: self._pair(lk.S_TAU_A, lk.S_TAU_E), doc="last command (τ_a, τ_e) [N·m]")
    unsaturated_command = property(lambda self: self._pair(lk.S_UNSAT_A, lk.S_UNSAT_E), doc="before the clip [N·m]")
    rate_error = property(lambda self: self._pair(lk.S_EA_PREV, lk.S_EE_PREV), doc="last e [rad/s]")
    joint_rate_command = property(lambda self: self._pair(lk.S_JR_A, lk.S_JR_E), doc="(ψ̇_md, θ̇_md) [rad/s]")
    bias_estimate_qr = property(lambda self: self._pair(lk.S_BIAS_Q, lk.S_BIAS_R),
                                doc="Gyro bias (y, z components) [rad/s] currently subtracted when ``feedback``.")
    rejected_inputs = slot(lk.S_REJECTED_INPUTS, int, array="_s")
    singular_steps = slot(lk.S_SINGULAR, int, array="_s")
    saturated_steps = slot(lk.S_SATURATED, int, array="_s")
    resets = slot(lk.S_RESETS, int, array="_s")

    @property
    def last_t(self) -> float | None:
        """Stamp of the last accepted sample [s], None before the first (or after a reset)."""
        t = float(self._s[lk.S_LAST_T])
        return None if math.isnan(t) else t

    def set_bias_estimate(self, t: float, bias_xyz: Sequence[float]) -> bool:
        """Store the EKF's gyro bias estimate (m frame, (3,) rad/s) stamped ``t`` [s];
        only y, z are used. Non-finite values are rejected (counted); returns acceptance."""
        try:
            by, bz = float(bias_xyz[1]), float(bias_xyz[2])
            bx = float(bias_xyz[0])
        except (TypeError, IndexError, ValueError):
            self.rejected_bias += 1
            return False
        if not all(math.isfinite(v) for v in (t, bx, by, bz)):
            self.rejected_bias += 1
            return False
        self._s[lk.S_BIAS_Q], self._s[lk.S_BIAS_R] = by, bz
        self.bias_stamp = float(t)
        return True

    def set_rate_command(self, q_md: float, r_md: float) -> bool:
        """Inertial LOS rate command (q_md, r_md) [rad/s] for an outer (LOS-hold/slew) loop;
        (0, 0) holds the LOS still. Non-finite is rejected (counted)."""
        if not (math.isfinite(q_md) and math.isfinite(r_md)):
            self._s[lk.S_REJECTED_INPUTS] += 1
            return False
        self._s[lk.S_CMD_Q], self._s[lk.S_CMD_R] = float(q_md), float(r_md)
        return True

    def reference(self, released) -> tuple[float, float] | None:
        """The step's LOS rate reference for :meth:`step`: the outer loop's command
        (:meth:`set_rate_command`) plus the operator's shaped command
        (:class:`.operator_command.OperatorCommand`, advanced to the step with the commands
        it reached, ``released``: what the node's
        :class:`~gimbal_kinematics.timing.control_policy.CommandStamps` hands over). None
        (use the outer loop's alone) without an operator or while its shaped command is zero,
        so a controller nobody commands computes exactly what it did without one."""
        if self.operator is None:
            return None
        q, r = self.operator.step(released)
        if q == 0.0 and r == 0.0:
            return None
        return (float(self._s[lk.S_CMD_Q]) + q, float(self._s[lk.S_CMD_R]) + r)

    def control(self, t: float, gyro_qr: Sequence[float], joint_angles: Sequence[float],
                joint_rates: Sequence[float], omega_b_b: Sequence[float],
                rate_command_qr: Sequence[float] | None = None) -> Fed:
        """:meth:`step`, reporting what it did (:class:`~gimbal_kinematics.maths.outcome.Fed`,
        its ``output`` the torque command): a non-finite input is not used (counted in
        ``rejected_inputs``) and the last command is held."""
        rejected = self._s[lk.S_REJECTED_INPUTS]
        tau = self.step(t, gyro_qr, joint_angles, joint_rates, omega_b_b, rate_command_qr)
        if self._s[lk.S_REJECTED_INPUTS] != rejected:
            return Fed(False, "non-finite input: the last command held", tau)
        return Fed(True, output=tau)

    # ----------------------------------------------------------------------- hot path
    def step(self, t: float, gyro_qr: Sequence[float], joint_angles: Sequence[float],
             joint_rates: Sequence[float], omega_b_b: Sequence[float],
             rate_command_qr: Sequence[float] | None = None) -> tuple[float, float]:
        """One control step; returns the saturated torque command (τ_a, τ_e) [N·m].

        Args:
            t: measurement stamp [s].
            gyro_qr: gimbal gyro (q_m, r_m) [rad/s], inertial rate of m about its y, z.
            joint_angles: encoders (ψt, ψm, θm) [rad].
            joint_rates: (ψ̇t, ψ̇m, θ̇m) [rad/s].
            omega_b_b: INS body rates (p, q, r) [rad/s].
            rate_command_qr: (q_md, r_md) [rad/s] for this step; None uses
                :meth:`set_rate_command`'s (default 0, 0).
        """
        s = self._s
        q_md, r_md = (s[lk.S_CMD_Q], s[lk.S_CMD_R]) if rate_command_qr is None else rate_command_qr[:2]
        tau = lk.los_rate_step(s, self._g, float(t), float(gyro_qr[0]), float(gyro_qr[1]), float(joint_angles[0]),
                               float(joint_angles[1]), float(joint_angles[2]), float(joint_rates[0]),
                               float(joint_rates[1]), float(joint_rates[2]), float(omega_b_b[0]), float(omega_b_b[1]),
                               float(omega_b_b[2]), float(q_md), float(r_md))
        return tau
