"""The DC motor and PWM drive of paper 2's gimbal (gimbal_sim.world.plant.dc_motor) against
closed forms and scipy.signal: the armature's L/R, the steady-state speed
ω = k_t V/(R b + k_t k_e), the motor-and-load step response, the averaged PWM against a
switched bridge, the duty's clip and steps; and the vehicle's dc_motor actuator."""
import math
from pathlib import Path

import numpy as np
import pytest
from scipy import signal

from gimbal_sim.world.plant.dc_motor import (
    SMALL_GIMBAL_MOTOR, DcMotorDrive, DcMotorParams, armature_step, duty_cycle, steady_state_speed,
)
from gimbal_sim.world.vehicle import VehicleConfig, VehicleCore
from gimbal_kinematics.gimbal.gimbal_params import UAV_SMALL_GIMBAL

#: a motor with a slow armature (L/R = 1 ms) and a continuous duty, for the dynamic checks
SLOW = DcMotorParams(resistance_ohm=2.0, inductance_h=2e-3, torque_constant_nm_a=0.02, back_emf_v_s_rad=0.02,
                     bus_voltage_v=12.0, pwm_hz=20_000.0, pwm_timer_hz=0.0)


def _demand_for_voltage(p: DcMotorParams, volts: float) -> float:
    """The torque demand whose duty applies ``volts``."""
    return volts / p.bus_voltage_v * p.torque_constant_nm_a * p.bus_voltage_v / p.resistance_ohm


def test_the_default_motor_is_the_data_sheets_and_self_consistent():
    p = SMALL_GIMBAL_MOTOR
    assert (p.resistance_ohm, p.inductance_h, p.torque_constant_nm_a) == (1.9, 65e-6, 13.4e-3)
    # 1.4 mV/rpm in SI, and k_t = k_e in SI to the data sheet's rounding
    assert p.back_emf_v_s_rad == pytest.approx(1.4e-3 * 60 / (2 * math.pi), rel=1e-12)
    assert p.back_emf_v_s_rad == pytest.approx(p.torque_constant_nm_a, rel=0.005)
    # the data sheet's mechanical time constant 6 ms from R J / (k_t k_e) with its 5.8 g cm^2
    assert 1.9 * 5.8e-7 / (p.torque_constant_nm_a * p.back_emf_v_s_rad) == pytest.approx(6e-3, rel=0.05)
    assert p.electrical_time_constant_s == pytest.approx(65e-6 / 1.9)
    assert p.stall_torque_nm == pytest.approx(0.0134 * 12 / 1.9)
    assert p.pwm_counts == 3600
    # the drive can hold the UAV gimbal's torques: above its gravity torque on the inner cg offset
    g_torque = UAV_SMALL_GIMBAL.inner_mass_kg * 9.81 * math.hypot(*UAV_SMALL_GIMBAL.inner_cg_m)
    assert p.stall_torque_nm > 5 * g_torque


def test_blocked_rotor_current_rises_with_l_over_r_as_scipy_step():
    """ω = 0: I(s)/V(s) = 1/(L s + R); the stepped current at the step ends against
    scipy.signal.step, and the time constant L/R from the 63 % point."""
    p = SLOW
    volts = 6.0
    dt = p.electrical_time_constant_s / 25
    drive = DcMotorDrive(p, 1)
    n = 200
    i = np.zeros(n + 1)
    for k in range(n):
        drive.step([_demand_for_voltage(p, volts)], [0.0], dt)
        i[k + 1] = drive.current_a[0]
    t = np.arange(n + 1) * dt
    _, ref = signal.step(signal.lti([1.0], [p.inductance_h, p.resistance_ohm]), T=t)
    np.testing.assert_allclose(i, volts * ref, rtol=0, atol=1e-9 * volts / p.resistance_ohm)
    k63 = int(np.argmax(i >= (1 - math.exp(-1)) * volts / p.resistance_ohm))
    assert t[k63] == pytest.approx(p.inductance_h / p.resistance_ohm, abs=dt)


def test_step_mean_current_is_the_integral_of_the_exact_current():
    p = SLOW
    i0, v, w, dt = 0.3, 5.0, 40.0, 3e-3
    i1, mean = armature_step(p, i0, v, w, dt)
    tau = p.inductance_h / p.resistance_ohm
    i_ss = (v - p.back_emf_v_s_rad * w) / p.resistance_ohm
    ts = np.linspace(0.0, dt, 20001)
    exact = i_ss + (i0 - i_ss) * np.exp(-ts / tau)
    assert i1 == pytest.approx(exact[-1], rel=1e-12)
    assert mean == pytest.approx(np.trapezoid(exact, ts) / dt, rel=1e-8)


@pytest.mark.parametrize("b", [1e-4, 1e-3, 1e-2])
def test_steady_state_speed_against_a_viscous_load(b):
    """Motor on an inertia J with viscous friction b, constant voltage: the speed settles at
    k_t V/(R b + k_t k_e) (the closed form), and the whole response follows scipy.signal's
    step of ω(s)/V(s) = k_t / ((L s + R)(J s + b) + k_t k_e)."""
    p = SLOW
    J, volts = 2e-6, 6.0
    kt, ke, R, L = p.torque_constant_nm_a, p.back_emf_v_s_rad, p.resistance_ohm, p.inductance_h
    tf = signal.lti([kt], np.polyadd(np.polymul([L, R], [J, b]), [kt * ke]))
    slowest = max(-1.0 / np.real(tf.poles))
    dt = 2e-6
    n = int(round(8 * slowest / dt))
    drive = DcMotorDrive(p, 1)
    w = 0.0
    ws = np.empty(n + 1)
    ws[0] = 0.0
    a = math.exp(-b / J * dt)
    for k in range(n):
        (torque,) = drive.step([_demand_for_voltage(p, volts)], [w], dt)
        w = w * a + torque / b * (1 - a)   # the load's exact step under the held torque
        ws[k + 1] = w
    closed = kt * volts / (R * b + kt * ke)
    assert steady_state_speed(p, volts, b) == pytest.approx(closed, rel=1e-15)
    assert ws[-1] == pytest.approx(closed, rel=2e-3)
    t = np.arange(n + 1) * dt
    _, ref = signal.step(tf, T=t)
    # the rate is held over each 2 us step: first-order error, well below 1 % of the final speed
    assert np.max(np.abs(ws - volts * ref)) < 2e-3 * closed


def test_averaged_pwm_is_the_switched_bridges_mean_current():
    """A bipolar bridge switching ±V_bus at f_PWM with duty d, blocked rotor: its periodic
    steady state's mean current over a period equals the averaged model's d V_bus / R,
    whatever L/R against the PWM period (the default motor's 34 us < 50 us)."""
    for p in (SMALL_GIMBAL_MOTOR, SLOW):
        R, L, V = p.resistance_ohm, p.inductance_h, p.bus_voltage_v
        T = 1.0 / p.pwm_hz
        for d in (-0.6, 0.1, 0.45):
            t_on = 0.5 * (1 + d) * T     # +V for (1 + d)/2 of the period, −V for the rest: mean d V
            i = 0.0
            for _ in range(int(50 * (L / R) / T) + 200):   # to the periodic steady state
                i, m1 = armature_step(p, i, V, 0.0, t_on)
                i, m2 = armature_step(p, i, -V, 0.0, T - t_on)
            mean = (m1 * t_on + m2 * (T - t_on)) / T
            assert mean == pytest.approx(d * V / R, rel=1e-9, abs=1e-12)


def test_duty_is_clipped_at_the_bus_and_stepped_by_the_timer():
    p = SMALL_GIMBAL_MOTOR
    assert duty_cycle(p, 10 * p.stall_torque_nm) == 1.0
    assert duty_cycle(p, -10 * p.stall_torque_nm) == -1.0
    d = duty_cycle(p, 0.3 * p.stall_torque_nm + 1e-7)
    assert d * 3600 == pytest.approx(round(d * 3600), abs=1e-9)
    assert abs(d - 0.3) <= 0.5 / 3600 + 1e-12
    assert duty_cycle(p, float("nan")) == 0.0


def test_vehicle_dc_motor_torque_is_the_demand_less_the_back_emf_damping():
    """Gimbal on a static base driven through the motors: at each step the joint torque is
    k_t times the mean current; after the first step (whose current starts from 0 and rises
    with L/R = 34 us, 3.4 % of the 1 ms step) it is the demand less (k_t k_e / R) times the
    joint rate at the step's start, to the armature's lag behind that rate's change
    (about 1e-7 N·m here)."""
    cfg = VehicleConfig(profile="static", plant="two_axis_gimbal", sim_rate_hz=1000.0, duration_s=1.0,
                        earth_rate=False, gimbal_actuator="dc_motor")
    core = VehicleCore(cfg, UAV_SMALL_GIMBAL)
    p = cfg.motor
    demand = (0.02, -0.015)
    lag = p.electrical_time_constant_s / cfg.dt
    for k in range(300):
        rates = core.truth().joint_velocity[1:]
        core.step(demand)
        effort = core.truth().joint_effort[1:]
        for tau, tau_star, w in zip(effort, demand, rates):
            q = duty_cycle(p, tau_star) * p.bus_voltage_v * p.torque_constant_nm_a / p.resistance_ohm
            if k == 0:   # from rest, zero current: k_t i_ss (1 − (L/R/dt)(1 − e^{−dt R/L}))
                assert tau == pytest.approx(q * (1 - lag * -math.expm1(-1 / lag)), rel=1e-12)
            else:
                assert tau == pytest.approx(q - p.back_emf_damping_nm_s_rad * w, abs=3e-7)
    assert abs(core.truth().joint_velocity[1]) > 0.1   # the gimbal did turn, so the back-EMF acted


def test_torque_actuator_is_unchanged_and_bad_actuator_refused():
    cfg = VehicleConfig(profile="static", plant="two_axis_gimbal", duration_s=0.01, earth_rate=False)
    assert cfg.gimbal_actuator == "torque"
    core = VehicleCore(cfg, UAV_SMALL_GIMBAL)
    core.step((0.01, 0.02))
    assert core.truth().joint_effort[1:] == (0.01, 0.02)
    with pytest.raises(ValueError, match="gimbal_actuator"):
        VehicleConfig(gimbal_actuator="stepper")
    with pytest.raises(ValueError, match="resistance_ohm"):
        DcMotorParams(resistance_ohm=0.0)


def test_the_controller_side_holds_no_motor_model():
    """No inverse crime: the paper 2 controller and filter (gimbal_control) never see the motor's
    figures; the motor lives in the simulated world only."""
    root = Path(__file__).resolve().parents[1] / "src" / "gimbal_control" / "gimbal_control"
    for name in ("encoder_fusion.py", "fusion_kf.py", "pid.py", "encoder_fusion_controller_node.py",
                 "encoder_fusion_controller_params.py"):
        text = (root / name).read_text()
        assert "dc_motor" not in text and "back_emf" not in text and "armature" not in text, name
