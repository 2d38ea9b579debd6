"""Paper 3 single-axis DC-motor gimbal loops: closed-form steady state and electrical time
constant, friction, base-rate coupling, RK4 against scipy (solve_ivp and expm)."""
import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.linalg import expm
from scipy.optimize import brentq

from gimbal_sim.world.plant import PAPER3_TABLE1, PlatformAxis, paper3_axis_params, rk4_step

AXES = ("a", "q", "p", "r")


def settle_time(p, n=25):
    """n mechanical time constants R J / (k_t k_e + R b) [s]."""
    return n * p.resistance_ohm * p.inertia_kg_m2 / (
        p.torque_constant_nm_a * p.back_emf + p.resistance_ohm * p.viscous_friction_nm_s_rad)


def run(axis, x, voltage, dt, seconds, **kw):
    for _ in range(int(round(seconds / dt))):
        x = axis.step(x, voltage, dt, **kw)
    return x


def test_table1_values():
    expected = {"a": (0.0026, 0.21, 31.2), "q": (0.0066, 0.21, 35.5), "p": (0.0093, 0.21, 28.7),
                "r": (0.0115, 0.29, 34.3)}
    for name, (j, kt, r) in expected.items():
        p = paper3_axis_params(name)
        assert (p.inertia_kg_m2, p.torque_constant_nm_a, p.resistance_ohm) == (j, kt, r)
        assert p.back_emf == kt and p.name == name
    assert set(PAPER3_TABLE1) == set(AXES)


@pytest.mark.parametrize("name", AXES)
def test_step_response_reaches_closed_form_speed(name):
    """No Coulomb friction: ω_ss = k_t V / (k_t k_e + R b), i_ss = b ω_ss / k_t."""
    p = paper3_axis_params(name, coulomb_friction_nm=0.0)
    axis = PlatformAxis(p)
    v = 10.0
    kt, ke, r, b = p.torque_constant_nm_a, p.back_emf, p.resistance_ohm, p.viscous_friction_nm_s_rad
    w_ss = kt * v / (kt * ke + r * b)
    x = run(axis, (0.0, 0.0, 0.0), v, 1e-3, round(settle_time(p), 1))
    assert x[1] == pytest.approx(w_ss, rel=1e-7)
    assert x[2] == pytest.approx(b * w_ss / kt, rel=1e-6)


@pytest.mark.parametrize("name", ("a", "r"))
def test_step_response_with_coulomb_friction(name):
    """Well above the smoothing rate: ω_ss = (k_t V − R T_c) / (k_t k_e + R b)."""
    p = paper3_axis_params(name)
    axis = PlatformAxis(p)
    v = 5.0
    kt, ke, r, b = p.torque_constant_nm_a, p.back_emf, p.resistance_ohm, p.viscous_friction_nm_s_rad
    w_ss = (kt * v - r * p.coulomb_friction_nm) / (kt * ke + r * b)
    x = run(axis, (0.0, 0.0, 0.0), v, 1e-3, round(settle_time(p), 1))
    assert x[1] == pytest.approx(w_ss, rel=1e-7)
    assert x[1] < kt * v / (kt * ke + r * b) * 0.8  # Coulomb friction matters here


@pytest.mark.parametrize("name", AXES)
def test_electrical_time_constant_is_l_over_r(name):
    """Rotor locked (huge J): i(t) = V/R (1 − exp(−t R / L))."""
    p = paper3_axis_params(name, inertia_kg_m2=1e9)
    axis = PlatformAxis(p)
    tau_e = p.inductance_h / p.resistance_ohm
    v = 12.0
    dt = tau_e / 50
    x = (0.0, 0.0, 0.0)
    for k in range(1, 251):
        x = axis.step(x, v, dt)
        if k == 50:
            assert x[2] == pytest.approx(v / p.resistance_ohm * (1 - math.exp(-1.0)), rel=1e-8)
    assert x[2] == pytest.approx(v / p.resistance_ohm * (1 - math.exp(-5.0)), rel=1e-8)
    assert 0.8e-3 < tau_e < 1.1e-3


def test_friction_model():
    p = paper3_axis_params("q")
    axis = PlatformAxis(p)
    tc, b, ws = p.coulomb_friction_nm, p.viscous_friction_nm_s_rad, p.friction_smoothing_rad_s
    for w in np.linspace(3 * ws, 5.0, 50):
        ideal = tc + b * w
        assert axis.friction_torque(w) == pytest.approx(ideal, abs=0.005 * tc)
        assert axis.friction_torque(-w) == -axis.friction_torque(w)
    assert axis.friction_torque(0.0) == 0.0
    # Smooth through zero: slope T_c/w_s + b.
    h = 1e-7
    assert (axis.friction_torque(h) - axis.friction_torque(-h)) / (2 * h) == pytest.approx(tc / ws + b, rel=1e-6)


def test_below_breakaway_the_gimbal_creeps_at_the_friction_balance():
    """k_t V / R < T_c: steady rate solves k_t (V − k_e ω)/R = T_c tanh(ω/w_s) + b ω (brentq)."""
    p = paper3_axis_params("a")
    axis = PlatformAxis(p)
    kt, ke, r = p.torque_constant_nm_a, p.back_emf, p.resistance_ohm
    v = 0.5 * p.coulomb_friction_nm * r / kt
    balance = lambda w: kt * (v - ke * w) / r - p.coulomb_friction_nm * math.tanh(w / p.friction_smoothing_rad_s) \
        - p.viscous_friction_nm_s_rad * w  # noqa: E731
    w_ss = brentq(balance, 0.0, 1.0)
    x = run(axis, (0.0, 0.0, 0.0), v, 1e-3, 1.0)
    assert x[1] == pytest.approx(w_ss, rel=1e-8)
    assert w_ss < p.friction_smoothing_rad_s  # inside the smoothing band, i.e. nearly stuck


def test_bearing_friction_and_back_emf_drag_the_gimbal_with_the_base():
    """V = 0 (driver holding zero volts) and a base turning at ω_A: ω → ω_A."""
    axis = PlatformAxis(paper3_axis_params("p"))
    w_a = 0.05
    x = run(axis, (0.0, 0.0, 0.0), 0.0, 1e-3, 20.0, base_rate=w_a)  # friction slope: τ ≪ 1 s
    assert x[1] == pytest.approx(w_a, rel=1e-9)
    assert abs(x[2]) < 1e-10


def test_disturbance_torque_is_balanced_by_current():
    """V = 0, constant disturbance T_d: the gimbal runs up until viscous friction and the
    back-EMF brake (current −k_e ω / R) balance it."""
    p = paper3_axis_params("r", coulomb_friction_nm=0.0)
    axis = PlatformAxis(p)
    td = 0.02
    # Steady state with V = 0: J ω̇ = 0 → k_t i − b ω + T_d = 0, and R i = −k_e ω.
    kt, ke, r, b = p.torque_constant_nm_a, p.back_emf, p.resistance_ohm, p.viscous_friction_nm_s_rad
    w_ss = td / (b + kt * ke / r)
    x = run(axis, (0.0, 0.0, 0.0), 0.0, 1e-3, round(settle_time(p), 1), disturbance_nm=td)
    assert x[1] == pytest.approx(w_ss, rel=1e-7)
    assert x[2] == pytest.approx(-ke * w_ss / r, rel=1e-6)


def test_rk4_matches_matrix_exponential_on_the_linear_model():
    p = paper3_axis_params("a", coulomb_friction_nm=0.0)
    axis = PlatformAxis(p)
    j, kt, ke, r, b, l = (p.inertia_kg_m2, p.torque_constant_nm_a, p.back_emf, p.resistance_ohm,
                          p.viscous_friction_nm_s_rad, p.inductance_h)
    v, td = 8.0, -0.01
    # Augmented state (θ, ω, i, 1) makes the constant inputs part of a homogeneous system.
    a = np.array([[0, 1, 0, 0], [0, -b / j, kt / j, td / j], [0, -ke / l, -r / l, v / l], [0, 0, 0, 0]])
    exact = expm(a * 0.5) @ np.array([0.1, 0.0, 0.0, 1.0])
    x = run(axis, (0.1, 0.0, 0.0), v, 1e-4, 0.5, disturbance_nm=td)
    np.testing.assert_allclose(x, exact[:3], rtol=1e-9, atol=1e-12)


def test_rk4_matches_solve_ivp_with_friction_and_moving_base():
    p = paper3_axis_params("q")
    axis = PlatformAxis(p)
    j, kt, ke, r, b, l = (p.inertia_kg_m2, p.torque_constant_nm_a, p.back_emf, p.resistance_ohm,
                          p.viscous_friction_nm_s_rad, p.inductance_h)
    tc, ws = p.coulomb_friction_nm, p.friction_smoothing_rad_s
    v = 3.0
    w_base = lambda t: 0.2 * math.sin(3.0 * t)  # noqa: E731
    t_d = lambda t: 0.01 * math.cos(5.0 * t)  # noqa: E731

    def f(t, y):
        rel = y[1] - w_base(t)
        torque = kt * y[2] - tc * math.tanh(rel / ws) - b * rel + t_d(t)
        return [y[1], torque / j, (v - r * y[2] - ke * rel) / l]

    T = 2.0
    ref = solve_ivp(f, (0.0, T), [0.0, 0.0, 0.0], method="Radau", rtol=1e-11, atol=1e-13).y[:, -1]
    dt = 2e-4
    x = (0.0, 0.0, 0.0)
    for k in range(int(round(T / dt))):
        t = k * dt
        x = axis.step(x, v, dt, base_rate=(w_base(t), w_base(t + dt / 2), w_base(t + dt)),
                      disturbance_nm=(t_d(t), t_d(t + dt / 2), t_d(t + dt)))
    np.testing.assert_allclose(x, ref, rtol=1e-7, atol=1e-9)
    # Substeps with interpolated inputs at a 1 kHz loop rate stay close too.
    dt, n = 1e-3, 5
    y = (0.0, 0.0, 0.0)
    for k in range(int(round(T / dt))):
        t = k * dt
        y = axis.step(y, v, dt, base_rate=(w_base(t), w_base(t + dt / 2), w_base(t + dt)),
                      disturbance_nm=(t_d(t), t_d(t + dt / 2), t_d(t + dt)), substeps=n)
    np.testing.assert_allclose(y, ref, rtol=1e-5, atol=1e-7)


def test_voltage_limit_is_respected():
    p = paper3_axis_params("a")
    axis = PlatformAxis(p)
    x = (0.0, 0.5, 0.1)
    assert axis.derivative(x, 1e3) == axis.derivative(x, p.voltage_limit_v)
    assert axis.derivative(x, -1e3) == axis.derivative(x, -p.voltage_limit_v)
    assert axis.step(x, 500.0, 1e-3) == axis.step(x, 27.0, 1e-3)


@pytest.mark.parametrize(
    "field, value",
    [("inertia_kg_m2", 0.0), ("torque_constant_nm_a", -0.2), ("resistance_ohm", float("nan")),
     ("inductance_h", 0.0), ("back_emf_v_s_rad", -1.0), ("viscous_friction_nm_s_rad", -1e-3),
     ("coulomb_friction_nm", -0.1), ("friction_smoothing_rad_s", 0.0), ("voltage_limit_v", 0.0)],
)
def test_bad_params_raise_naming_the_field(field, value):
    with pytest.raises(ValueError, match=field):
        paper3_axis_params("p", **{field: value})


def test_bad_axis_and_arguments():
    with pytest.raises(ValueError, match="'x'"):
        paper3_axis_params("x")
    with pytest.raises(ValueError, match="bogus"):
        paper3_axis_params("a", bogus=1.0)
    axis = PlatformAxis(paper3_axis_params("a"))
    with pytest.raises(ValueError, match="substeps"):
        axis.step((0, 0, 0), 1.0, 1e-3, substeps=0)
    with pytest.raises(ValueError, match="base_rate"):
        axis.step((0, 0, 0), 1.0, 1e-3, base_rate=(0.0, 1.0))
    with pytest.raises(ValueError, match="params"):
        PlatformAxis({"inertia_kg_m2": 1.0})


def test_generic_rk4_step_is_fourth_order():
    """ẋ = (−t x0, x0): exact x0 = exp(−t²/2), x1 = √(π/2) erf(t/√2)."""
    f = lambda t, x: (-t * x[0], x[0])  # noqa: E731
    exact = np.array([math.exp(-2.0), math.sqrt(math.pi / 2) * math.erf(2.0 / math.sqrt(2))])

    def err(n):
        x, dt = (1.0, 0.0), 2.0 / n
        for k in range(n):
            x = rk4_step(f, k * dt, x, dt)
        return np.max(np.abs(np.array(x) - exact))

    e1, e2 = err(20), err(40)
    assert 14.0 < e1 / e2 < 18.0 and e2 < 1e-6
