"""Brushed DC motor with a PWM H-bridge drive: the actuator of paper 2's gimbal axes (world side).

Paper 2 drives each gimbal axis with a DC motor carrying a 1024-line encoder, the PID output
becoming a PWM duty cycle on the microcontroller. Each axis here is that motor, direct drive
(the encoder turns with the gimbal axis, so the paper's ≈ 2 °/s speed resolution is the
gimbal's), with its armature::

    L di/dt = V − R i − k_e ω_rel          (armature; ω_rel the joint rate across the motor)
    τ       = k_t i                        (torque on the gimbal joint)

and an H-bridge switched at ``pwm_hz`` from a ``bus_voltage_v`` supply. The drive turns the
controller's torque demand τ* into a duty cycle with the motor's data-sheet figures,
d = τ* R / (k_t V_bus), clipped to [−1, 1] and rounded to the timer's resolution
(``pwm_timer_hz / pwm_hz`` counts per period). It has no current loop: the back-EMF, the
armature lag, the bus limit (stall torque k_t V_bus / R) and the duty steps are what the
motor adds to a pure torque source, and none of them is in the controller's model.

Averaged PWM model. The bridge applies ±V_bus with duty d at f_PWM. For a linear RL armature
whose ω_rel is constant over a PWM period, the periodic steady-state current's mean over the
period is exactly the current driven by the mean voltage d V_bus (the mean of a linear
system's periodic response is its response to the input's mean); what the averaged model
drops is the ripple at f_PWM and its harmonics. The ripple current cannot exceed the
armature's full swing, V_bus/R peak (with L/R = 34 µs below T_PWM = 50 µs it nearly
reaches it), so the torque ripple is at most the stall torque k_t V_bus/R at 20 kHz and
above; on the gimbal (J ≈ 1e-3 kg·m²) it moves the axis by at most
k_t V_bus / (R J (2π f_PWM)²) ≈ 5e-9 rad, a million times below one encoder count (6.1 mrad).
The averaged model is therefore what this motor does at the gimbal, to ~1e-8 rad.

Step. The simulation holds the duty (the controller's command) and ω_rel (the joint rate at
the step's start: the mechanical time constant is ~10³ times the step) over each step dt; the
armature ODE is then linear with constant input and is solved exactly:
i(t) = i_ss + (i₀ − i_ss) e^{−t/τ_e}, τ_e = L/R, i_ss = (V − k_e ω_rel)/R. The torque held
on the gimbal over the step is k_t times the step's mean current,
ī = i_ss + (i₀ − i_ss) (τ_e/dt)(1 − e^{−dt/τ_e}). Exact for any τ_e/dt (here L/R = 34 µs
against a 1 ms step: the current settles within the step).

Default figures (:data:`SMALL_GIMBAL_MOTOR`): FAULHABER DC-Micromotor series 2342 S 012 CR
(the 12 V winding of the 2342…CR, 16 mN·m continuous), the motor FAULHABER pairs with its
IE2-1024 encoder (1024 lines per revolution: paper 2's figure). From its data sheet: nominal
voltage 12 V, terminal resistance R = 1.9 Ω, rotor inductance L = 65 µH, torque constant
k_M = 13.4 mN·m/A, back-EMF constant k_E = 1.4 mV/rpm (= 0.01337 V·s/rad, k_t in SI to
0.2 %); rotor inertia 5.8 g·cm² (5.8e-7 kg·m², 0.06 % of the gimbal's, left out). The data
sheet's mechanical time constant, 6 ms, is R J/(k_t k_e) = 6.15 ms with these figures: they
are consistent. Stall torque at 12 V: k_t V/R = 84.6 mN·m. Drive: 12 V bus (a 3-cell
battery's nominal 11.1–12.6 V), 20 kHz PWM (above hearing: the usual choice of small
H-bridges), a 72 MHz timer (a Cortex-M3-class microcontroller such as the STM32F1):
3600 counts per period, a duty step of 2.8e-4 (2.3e-5 N·m).
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

#: The actuators of the two-axis gimbal (the ``gimbal_actuator`` parameter of ``vehicle_dynamics``):
#: ``torque`` applies the commanded joint torques directly; ``dc_motor`` drives each joint by
#: a :class:`DcMotorDrive` axis, the command being the torque demand the drive turns into a duty.
GIMBAL_ACTUATORS = ("torque", "dc_motor")

#: rpm -> rad/s
_RPM = 2.0 * math.pi / 60.0


@dataclass(frozen=True)
class DcMotorParams:
    """One brushed DC motor and its PWM drive (module docstring); SI units.

    Attributes:
        resistance_ohm: armature (terminal) resistance R [Ω].
        inductance_h: armature inductance L [H].
        torque_constant_nm_a: k_t [N·m/A].
        back_emf_v_s_rad: k_e [V·s/rad].
        bus_voltage_v: H-bridge supply V_bus [V].
        pwm_hz: PWM switching frequency [Hz].
        pwm_timer_hz: the PWM timer's clock [Hz]; ``pwm_timer_hz / pwm_hz`` counts per
            period set the duty resolution (0: a continuous duty).
    """

    resistance_ohm: float = 1.9
    inductance_h: float = 65e-6
    torque_constant_nm_a: float = 13.4e-3
    back_emf_v_s_rad: float = 1.4e-3 / _RPM
    bus_voltage_v: float = 12.0
    pwm_hz: float = 20_000.0
    pwm_timer_hz: float = 72e6

    def __post_init__(self) -> None:
        for name in ("resistance_ohm", "inductance_h", "torque_constant_nm_a", "back_emf_v_s_rad",
                     "bus_voltage_v", "pwm_hz"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) \
                    or value <= 0.0:
                raise ValueError(f"{name} must be a finite number > 0, got {value!r}")
        t = self.pwm_timer_hz
        if isinstance(t, bool) or not isinstance(t, (int, float)) or not math.isfinite(t) or t < 0.0:
            raise ValueError(f"pwm_timer_hz must be a finite number >= 0, got {t!r}")
        if 0.0 < t < self.pwm_hz:
            raise ValueError(f"pwm_timer_hz {t} must be 0 or >= pwm_hz {self.pwm_hz}")

    @property
    def electrical_time_constant_s(self) -> float:
        """τ_e = L/R [s]."""
        return self.inductance_h / self.resistance_ohm

    @property
    def stall_torque_nm(self) -> float:
        """k_t V_bus / R [N·m]: the most the drive can apply at rest."""
        return self.torque_constant_nm_a * self.bus_voltage_v / self.resistance_ohm

    @property
    def back_emf_damping_nm_s_rad(self) -> float:
        """k_t k_e / R [N·m·s/rad]: the viscous torque the back-EMF adds under a voltage drive."""
        return self.torque_constant_nm_a * self.back_emf_v_s_rad / self.resistance_ohm

    @property
    def pwm_counts(self) -> int:
        """Timer counts per PWM period (0: continuous duty)."""
        return int(round(self.pwm_timer_hz / self.pwm_hz)) if self.pwm_timer_hz > 0.0 else 0


#: The small gimbal motor of the module docstring (FAULHABER 2342 S 012 CR, 12 V, 20 kHz).
SMALL_GIMBAL_MOTOR = DcMotorParams()


def duty_cycle(params: DcMotorParams, torque_demand_nm: float) -> float:
    """The drive's duty d in [−1, 1] for a torque demand [N·m]: τ* R/(k_t V_bus), clipped and
    rounded to the timer's counts."""
    d = torque_demand_nm * params.resistance_ohm / (params.torque_constant_nm_a * params.bus_voltage_v)
    d = min(1.0, max(-1.0, d)) if math.isfinite(d) else 0.0
    n = params.pwm_counts
    return round(d * n) / n if n > 0 else d


def armature_step(params: DcMotorParams, current_a: float, voltage_v: float, rate_rad_s: float,
                  dt: float) -> tuple[float, float]:
    """The armature current after ``dt`` [s] and its mean over the step [A], with the voltage
    and the joint rate held (exact solution, module docstring)."""
    r = params.resistance_ohm
    tau = params.inductance_h / r
    i_ss = (voltage_v - params.back_emf_v_s_rad * rate_rad_s) / r
    x = dt / tau
    decay = math.exp(-x)
    # (1 − e^{−x})/x, by its series near 0 where the difference cancels
    frac = -math.expm1(-x) / x if x > 1e-8 else 1.0 - 0.5 * x
    return i_ss + (current_a - i_ss) * decay, i_ss + (current_a - i_ss) * frac


class DcMotorDrive:
    """``n`` motor axes with their PWM drives (module docstring); state: the armature currents."""

    def __init__(self, params: DcMotorParams, n_axes: int = 2) -> None:
        if not isinstance(params, DcMotorParams):
            raise ValueError("params must be a DcMotorParams")
        if isinstance(n_axes, bool) or not isinstance(n_axes, int) or n_axes < 1:
            raise ValueError(f"n_axes must be an int >= 1, got {n_axes!r}")
        self.params = params
        self.current_a = [0.0] * n_axes
        self.voltage_v = [0.0] * n_axes

    def step(self, torque_demand_nm: Sequence[float], joint_rates_rad_s: Sequence[float],
             dt: float) -> tuple[float, ...]:
        """Advance each armature by ``dt`` [s] under the duty of its torque demand [N·m] and
        its joint rate [rad/s] (both held); returns the torques held on the joints over the
        step, k_t times the step's mean currents [N·m]."""
        p = self.params
        out = []
        for k, (demand, rate) in enumerate(zip(torque_demand_nm, joint_rates_rad_s, strict=True)):
            v = duty_cycle(p, float(demand)) * p.bus_voltage_v
            self.voltage_v[k] = v
            self.current_a[k], mean = armature_step(p, self.current_a[k], v, float(rate), dt)
            out.append(p.torque_constant_nm_a * mean)
        return tuple(out)


def steady_state_speed(params: DcMotorParams, voltage_v: float, viscous_nm_s_rad: float) -> float:
    """Speed [rad/s] of the motor at constant voltage against a viscous load b (no other load):
    ω = k_t V / (R b + k_t k_e)."""
    kt, ke = params.torque_constant_nm_a, params.back_emf_v_s_rad
    return kt * voltage_v / (params.resistance_ohm * viscous_nm_s_rad + kt * ke)
