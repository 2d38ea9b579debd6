"""Two-axis gimbal dynamics: independent Newton–Euler residual with reaction forces
(built on sighting_chain.chain_rates), energy conservation and energy rate, inertial
stillness of a free balanced gimbal, RK4 order, torque saturation and parameter checks."""
import dataclasses
import math

import numpy as np
import pytest

from gimbal_kinematics.maths import sighting_chain as sc
from gimbal_sim.world.plant import (
    GimbalParams, GimbalSimulator, TwoAxisGimbal, body_inertial_rates, make_profile,
    rest_base, site_environment, turret_base_from_host,
)

SEED = 20240611
D = math.pi / 180.0
G = 9.80665

BALANCED_NO_POI = GimbalParams(
    outer_inertia_kg_m2=(0.06, 0.05, 0.04, 0.0, 0.0, 0.0), outer_cg_m=(0.0, 0.0, 0.0),
    inner_inertia_kg_m2=(0.045, 0.06, 0.07, 0.0, 0.0, 0.0), inner_cg_m=(0.0, 0.0, 0.0),
    azimuth_friction_nm_s_rad=0.0, elevation_friction_nm_s_rad=0.0,
)
#: Unbalanced by centimetres (not millimetres) so that gravity is a large share of the energy.
UNBALANCED = GimbalParams(outer_cg_m=(0.01, -0.02, 0.015), inner_cg_m=(0.02, 0.01, -0.03))

MOVING = {
    "lat_deg": 50.0,
    "roll": [[6.0, 1.1, 0.3], [0.5, 9.0, 1.0]],
    "pitch": [[4.0, 0.7, -0.2]],
    "yaw": {"offset_deg": 30.0, "rate_deg_s": 3.0, "terms": [[5.0, 1.9, 0.0]]},
    "psi_t": [[20.0, 0.5, 0.4]],
    "accel_x_m_s2": [[1.5, 2.0, 0.0]], "accel_y_m_s2": [[-0.8, 3.0, 1.0]], "accel_z_m_s2": [[2.0, 1.0, 0.5]],
}


def tensor(e):
    xx, yy, zz, xy, xz, yz = e
    return np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])


def ne_residual(params, x, qdd, tau, host, gravity, omega_in_n):
    """Joint-axis torque balance from body-by-body Newton–Euler about each CG, with the
    reaction force at the pivot; zero when (x, q̈, τ) is a motion of the gimbal."""
    psi, th, psid, thd = x
    w_b, a_b = body_inertial_rates(host, omega_in_n)
    cr = sc.chain_rates(w_b, a_b, np.array([host.psi_t, psi, th]), np.array([host.psi_t_dot, psid, thd]),
                        np.array([host.psi_t_ddot, qdd[0], qdd[1]]))
    C_na = sc.dcm_nb(*host.euler) @ sc.dcm_bt(host.psi_t) @ sc.dcm_ta(psi)
    C_am = sc.dcm_am(th)
    C_nm = C_na @ C_am
    a_p_n = sc.dcm_nb(*host.euler) @ host.accel_b
    g_n = np.array([0.0, 0.0, gravity])
    ra, rm = np.array(params.outer_cg_m), np.array(params.inner_cg_m)
    Ja, Jm = tensor(params.outer_inertia_kg_m2), tensor(params.inner_inertia_kg_m2)
    wa, aa, wm, am = cr.omega_a_a, cr.alpha_a_a, cr.omega_m_m, cr.alpha_m_m
    acc_ga = C_na.T @ a_p_n + np.cross(aa, ra) + np.cross(wa, np.cross(wa, ra))
    acc_gm = C_nm.T @ a_p_n + np.cross(am, rm) + np.cross(wm, np.cross(wm, rm))
    f_am = params.inner_mass_kg * (acc_gm - C_nm.T @ g_n)            # on m from a, at P
    m_am = Jm @ am + np.cross(wm, Jm @ wm) + np.cross(rm, f_am)      # on m from a, about P
    f_a_net = params.outer_mass_kg * (acc_ga - C_na.T @ g_n)         # F_ta − C_am F_am
    m_ta = Ja @ aa + np.cross(wa, Ja @ wa) + np.cross(ra, f_a_net) + C_am @ m_am
    res_a = m_ta[2] - (tau[0] - params.azimuth_friction_nm_s_rad * psid)
    res_e = m_am[1] - (tau[1] - params.elevation_friction_nm_s_rad * thd)
    return res_a, res_e


def energy(params, x, C_nt, gravity):
    """KE + PE of the gimbal on a turret at rest (pivot fixed), from the chain DCMs."""
    psi, th, psid, thd = x
    C_ta, C_am = sc.dcm_ta(psi), sc.dcm_am(th)
    wa = np.array([0.0, 0.0, psid])
    wm = C_am.T @ wa + np.array([0.0, thd, 0.0])
    ra, rm = np.array(params.outer_cg_m), np.array(params.inner_cg_m)
    Ja, Jm = tensor(params.outer_inertia_kg_m2), tensor(params.inner_inertia_kg_m2)
    # Velocity of each CG is ω × r (pivot fixed); KE = ½ m v² + ½ ωᵀ J ω.
    ke = (0.5 * params.outer_mass_kg * np.sum(np.cross(wa, ra) ** 2) + 0.5 * wa @ Ja @ wa
          + 0.5 * params.inner_mass_kg * np.sum(np.cross(wm, rm) ** 2) + 0.5 * wm @ Jm @ wm)
    z_a = (C_nt @ C_ta @ ra)[2]
    z_m = (C_nt @ C_ta @ C_am @ rm)[2]
    pe = -gravity * (params.outer_mass_kg * z_a + params.inner_mass_kg * z_m)  # NED z is down
    return ke, pe


def simulate(sim, tau, seconds):
    for _ in range(int(round(seconds / sim.dt))):
        sim.step(tau)
    return np.array(sim.x)


# ----------------------------------------------------------------- Newton–Euler cross-check
@pytest.mark.parametrize("params", [GimbalParams(), UNBALANCED, BALANCED_NO_POI], ids=["default", "unbalanced", "balanced"])
@pytest.mark.parametrize("earth_rate", [False, True])
def test_forward_dynamics_satisfy_independent_newton_euler(params, earth_rate):
    rng = np.random.default_rng(SEED)
    profile = make_profile("sinusoids", MOVING)
    env = site_environment(profile.site.lat_rad, 0.0, earth_rate)
    dyn = TwoAxisGimbal(params)
    worst = 0.0
    for _ in range(25):
        t = rng.uniform(0.0, 30.0)
        host = profile.sample(t)
        base = turret_base_from_host(host, env.gravity_m_s2, env.omega_in_n)
        x = (rng.uniform(-math.pi, math.pi), rng.uniform(-1.4, 1.4), rng.normal(0, 2), rng.normal(0, 2))
        tau = (rng.uniform(-2.5, 2.5), rng.uniform(-1.5, 1.5))
        xd = dyn.derivative(x, tau, base)
        res = ne_residual(params, x, xd[2:], tau, host, env.gravity_m_s2, np.array(env.omega_in_n))
        worst = max(worst, *map(abs, res))
        # Inverse dynamics returns the torque that produced the acceleration.
        assert dyn.inverse_dynamics(x, xd[2:], base) == pytest.approx(tau, abs=1e-12)
    assert worst < 1e-12


def test_newton_euler_residual_detects_a_wrong_acceleration():
    """Guard for the cross-check itself: a 1e-6 rad/s² error gives a visible residual."""
    profile = make_profile("sinusoids", MOVING)
    env = site_environment(profile.site.lat_rad)
    dyn = TwoAxisGimbal()
    host = profile.sample(3.0)
    base = turret_base_from_host(host, env.gravity_m_s2, env.omega_in_n)
    x, tau = (0.3, -0.2, 0.5, -0.7), (0.4, 0.1)
    xd = dyn.derivative(x, tau, base)
    res = ne_residual(dyn.params, x, (xd[2] + 1e-6, xd[3]), tau, host, env.gravity_m_s2, np.array(env.omega_in_n))
    assert abs(res[0]) > 1e-8


def test_turret_base_matches_chain_rates_and_dcms():
    profile = make_profile("paper1_land_vehicle", {"lat_deg": 35.0})
    env = site_environment(profile.site.lat_rad, 100.0)
    accel_profile = make_profile("sinusoids", MOVING)
    for prof in (profile, accel_profile):
        for t in (0.0, 1.234, 77.7):
            host = prof.sample(t)
            base = turret_base_from_host(host, env.gravity_m_s2, env.omega_in_n)
            w_b, a_b = body_inertial_rates(host, np.array(env.omega_in_n))
            cr = sc.chain_rates(w_b, a_b, np.array([host.psi_t, 0.0, 0.0]),
                                np.array([host.psi_t_dot, 0.0, 0.0]), np.array([host.psi_t_ddot, 0.0, 0.0]))
            np.testing.assert_allclose(base.omega_t_t, cr.omega_t_t, atol=1e-15)
            np.testing.assert_allclose(base.alpha_t_t, cr.alpha_t_t, atol=1e-13)
            C_nt = sc.dcm_nb(*host.euler) @ sc.dcm_bt(host.psi_t)
            f_t = sc.dcm_bt(host.psi_t).T @ host.accel_b - C_nt.T @ np.array([0, 0, env.gravity_m_s2])
            np.testing.assert_allclose(base.specific_force_t, f_t, atol=1e-14)
    assert env.gravity_m_s2 == pytest.approx(9.7967, abs=1e-3)  # WGS-84 at 35°, 100 m


def test_mass_matrix_gives_kinetic_energy():
    rng = np.random.default_rng(SEED + 1)
    for params in (GimbalParams(), UNBALANCED):
        dyn = TwoAxisGimbal(params)
        for _ in range(10):
            x = (rng.uniform(-3, 3), rng.uniform(-1.5, 1.5), rng.normal(), rng.normal())
            M = dyn.mass_matrix(x[1])
            ke, _ = energy(params, x, np.eye(3), G)
            qd = np.array(x[2:])
            assert 0.5 * qd @ M @ qd == pytest.approx(ke, rel=1e-13)
            assert M[0, 1] == M[1, 0] and np.all(np.linalg.eigvalsh(M) > 0)


# ----------------------------------------------------------------- energy
def test_energy_rate_equals_input_power_minus_friction():
    """dE/dt along f (central difference in state) = τ·q̇ − b_a ψ̇² − b_e θ̇², tilted static base."""
    rng = np.random.default_rng(SEED + 2)
    params = UNBALANCED
    dyn = TwoAxisGimbal(params)
    roll, pitch, psi_t = 10 * D, -5 * D, 30 * D
    base = rest_base(G, roll, pitch, psi_t)
    C_nt = sc.dcm_nb(roll, pitch, 0.0) @ sc.dcm_bt(psi_t)
    for _ in range(10):
        x = np.array([rng.uniform(-3, 3), rng.uniform(-1.4, 1.4), rng.normal(0, 1.5), rng.normal(0, 1.5)])
        tau = (rng.uniform(-2, 2), rng.uniform(-1.5, 1.5))
        f = np.array(dyn.derivative(x, tau, base))
        eps = 1e-6
        e_plus, e_minus = sum(energy(params, x + eps * f, C_nt, G)), sum(energy(params, x - eps * f, C_nt, G))
        de_dt = (e_plus - e_minus) / (2 * eps)
        power = tau[0] * x[2] + tau[1] * x[3] - params.azimuth_friction_nm_s_rad * x[2] ** 2 \
            - params.elevation_friction_nm_s_rad * x[3] ** 2
        assert de_dt == pytest.approx(power, abs=1e-7)


@pytest.mark.parametrize("case", ["balanced_full_inertia", "unbalanced_tilted"])
def test_energy_conserved_over_10_s_without_friction_or_torque(case):
    if case == "balanced_full_inertia":
        # Products of inertia kept: they couple the axes, yet kinetic energy alone is conserved.
        params = dataclasses.replace(GimbalParams(), outer_cg_m=(0, 0, 0), inner_cg_m=(0, 0, 0),
                                     azimuth_friction_nm_s_rad=0.0, elevation_friction_nm_s_rad=0.0)
        attitude = {"roll_deg": 0.0, "pitch_deg": 0.0}
    else:
        params = dataclasses.replace(UNBALANCED, azimuth_friction_nm_s_rad=0.0, elevation_friction_nm_s_rad=0.0)
        attitude = {"roll_deg": 10.0, "pitch_deg": -5.0, "psi_t_deg": 30.0}
    profile = make_profile("static", {"lat_deg": 45.0, **attitude})
    x0 = (0.2, 0.3, 2.0, -1.5)
    sim = GimbalSimulator(profile, 1e-3, params, x0=x0, earth_rate=False)
    g = sim.env.gravity_m_s2
    C_nt = sc.dcm_nb(*profile.sample(0).euler) @ sc.dcm_bt(profile.sample(0).psi_t)
    ke0, pe0 = energy(params, x0, C_nt, g)
    e0 = ke0 + pe0
    worst = 0.0
    ke_min, ke_max = ke0, ke0
    for _ in range(10):
        x = simulate(sim, (0.0, 0.0), 1.0)
        ke, pe = energy(params, x, C_nt, g)
        worst = max(worst, abs(ke + pe - e0) / ke0)
        ke_min, ke_max = min(ke_min, ke), max(ke_max, ke)
        if case == "balanced_full_inertia":
            assert pe == pytest.approx(0.0, abs=1e-15)
    assert worst < 1e-6
    if case == "unbalanced_tilted":
        assert ke_max - ke_min > 0.05 * ke0  # gravity really trades energy with motion


# ----------------------------------------------------------------- inertial stillness
def _los(host, x):
    return sc.los_azimuth_elevation(sc.dcm_nm(host.euler, host.psi_t, x[0], x[1]))


def test_free_balanced_gimbal_stays_inertially_still_under_base_yaw():
    profile = make_profile("sinusoids", {"yaw": [[20.0, 1.0, 0.0], [2.0, 7.0, 0.3]],
                                         "psi_t": [[10.0, 2.0, 1.0]]})
    s0 = profile.sample(0.0)
    x0 = (0.3, 0.0, -(s0.yaw_dot + s0.psi_t_dot), 0.0)  # zero inertial azimuth rate
    sim = GimbalSimulator(profile, 1e-3, BALANCED_NO_POI, x0=x0, earth_rate=False)
    az0, el0 = _los(s0, x0)
    worst = 0.0
    for _ in range(100):
        x = simulate(sim, (0.0, 0.0), 0.1)
        az, el = _los(sim.host, x)
        worst = max(worst, abs(math.remainder(az - az0, 2 * math.pi)), abs(el - el0))
    assert worst < 1e-6
    assert abs(math.remainder(sim.x[0] - x0[0], 2 * math.pi)) > 0.1  # the joint really moved


def test_free_balanced_gimbal_stays_inertially_still_under_base_pitch():
    profile = make_profile("sinusoids", {"pitch": [[15.0, 1.3, 0.0], [1.0, 11.0, 0.5]]})
    s0 = profile.sample(0.0)
    x0 = (0.0, 0.1, 0.0, -s0.q)  # ψm = 0: elevation axis along the pitch axis
    sim = GimbalSimulator(profile, 1e-3, BALANCED_NO_POI, x0=x0, earth_rate=False)
    az0, el0 = _los(s0, x0)
    worst = 0.0
    for _ in range(100):
        x = simulate(sim, (0.0, 0.0), 0.1)
        az, el = _los(sim.host, x)
        worst = max(worst, abs(el - el0), abs(math.remainder(az - az0, 2 * math.pi)))
        assert x[0] == 0.0 and x[2] == 0.0
    assert worst < 1e-6


def test_imbalance_breaks_inertial_stillness():
    """Control for the two tests above: with the CG off the axis the same motion drifts."""
    profile = make_profile("sinusoids", {"pitch": [[15.0, 1.3, 0.0]]})
    s0 = profile.sample(0.0)
    params = dataclasses.replace(BALANCED_NO_POI, inner_cg_m=(0.0, 0.0, 0.005))
    x0 = (0.0, 0.1, 0.0, -s0.q)
    sim = GimbalSimulator(profile, 1e-3, params, x0=x0, earth_rate=False)
    el0 = _los(s0, x0)[1]
    simulate(sim, (0.0, 0.0), 2.0)
    assert abs(_los(sim.host, sim.x)[1] - el0) > 1e-3


# ----------------------------------------------------------------- integrator
def test_rk4_is_fourth_order_on_a_smooth_moving_base():
    profile = make_profile("sinusoids", {k: v for k, v in MOVING.items() if k != "roll"} | {"roll": [[6.0, 1.1, 0.3]]})
    x0, tau, T = (0.1, 0.2, 0.5, -0.4), (0.3, -0.2), 2.0

    def final(dt):
        return simulate(GimbalSimulator(profile, dt, x0=x0), tau, T)

    ref = final(0.00125)
    e1, e2, e3 = (np.max(np.abs(final(dt) - ref)) for dt in (0.04, 0.02, 0.01))
    assert 12.0 < e1 / e2 < 20.0 and 12.0 < e2 / e3 < 20.0, (e1, e2, e3)


# ----------------------------------------------------------------- limits and parameters
def test_torque_saturation_is_respected():
    p = GimbalParams()
    dyn = TwoAxisGimbal(p)
    assert dyn.saturate((100.0, -100.0)) == (p.azimuth_torque_limit_nm, -p.elevation_torque_limit_nm)
    assert dyn.saturate((-0.5, 0.25)) == (-0.5, 0.25)
    base = rest_base(G)
    x = (0.1, 0.2, 0.3, 0.4)
    assert dyn.derivative(x, (50.0, 50.0), base) == dyn.derivative(x, (3.0, 2.0), base)
    profile = make_profile("paper1_land_vehicle", {})
    a = GimbalSimulator(profile, 1e-3)
    b = GimbalSimulator(profile, 1e-3)
    for _ in range(200):
        a.step((1e3, -1e3))
        b.step((3.0, -2.0))
    assert a.x == b.x and a.applied_torque == (3.0, -2.0)
    # The saturated torque is what the Newton–Euler balance sees.
    env = site_environment(0.0)
    host = profile.sample(0.5)
    base = turret_base_from_host(host, env.gravity_m_s2, env.omega_in_n)
    xd = dyn.derivative(x, (10.0, -10.0), base)
    res = ne_residual(p, x, xd[2:], (3.0, -2.0), host, env.gravity_m_s2, np.array(env.omega_in_n))
    assert max(map(abs, res)) < 1e-12


def test_balanced_gimbal_at_rest_has_zero_derivative():
    dyn = TwoAxisGimbal(BALANCED_NO_POI)
    assert dyn.derivative((0.7, -0.3, 0.0, 0.0), (0.0, 0.0), rest_base(G, 0.1, 0.2)) == (0.0, 0.0, 0.0, 0.0)
    # Default (unbalanced) gimbal at rest: gravity torque m g r, elevation axis, level base.
    p = GimbalParams()
    tau_g = TwoAxisGimbal(p).bias_torques((0.0, 0.0, 0.0, 0.0), rest_base(G))
    rm = p.inner_cg_m
    # N = m r × (−g e3): e2 component −m r_x (−g) ... = m g r_x; e3 component 0.
    assert tau_g[1] == pytest.approx(p.inner_mass_kg * G * rm[0], rel=1e-12)
    assert tau_g[0] == pytest.approx(0.0, abs=1e-15)


@pytest.mark.parametrize(
    "field, value",
    [
        ("inner_mass_kg", -1.0),
        ("outer_mass_kg", 0.0),
        ("outer_inertia_kg_m2", (0.01, 0.01, 0.01, 0.02, 0.0, 0.0)),
        ("inner_inertia_kg_m2", (0.01, 0.01, 0.05, 0.0, 0.0, 0.0)),
        ("inner_inertia_kg_m2", (0.01, 0.01, 0.01)),
        ("inner_cg_m", (0.0, 0.0)),
        ("inner_cg_m", (0.0, "x", 0.0)),
        ("outer_inertia_kg_m2", 0.05),
        ("outer_cg_m", (0.0, float("nan"), 0.0)),
        ("azimuth_friction_nm_s_rad", -0.01),
        ("elevation_friction_nm_s_rad", float("inf")),
        ("azimuth_torque_limit_nm", 0.0),
        ("elevation_torque_limit_nm", -1.0),
    ],
)
def test_bad_params_raise_naming_the_field(field, value):
    with pytest.raises(ValueError, match=field):
        GimbalParams(**{field: value})


def test_bad_simulator_arguments():
    profile = make_profile("static", {})
    with pytest.raises(ValueError, match="dt"):
        GimbalSimulator(profile, 0.0)
    with pytest.raises(ValueError, match="state"):
        GimbalSimulator(profile, 1e-3, x0=(0.0, 0.0, 0.0))
    with pytest.raises(ValueError, match="gravity_m_s2"):
        rest_base(-1.0)


def test_simulator_time_and_earth_rate():
    profile = make_profile("static", {"lat_deg": 45.0})
    sim = GimbalSimulator(profile, 1e-3, t0=2.0)
    for _ in range(1000):
        sim.step((0.0, 0.0))
    assert sim.t == pytest.approx(3.0, abs=1e-12) and sim.host.t == sim.t
    # Level, north-facing base: the turret senses the earth rate Ω (cos L, 0, −sin L).
    np.testing.assert_allclose(sim.base.omega_t_t, 7.292115e-5 * np.array([math.cos(math.pi / 4), 0, -math.sin(math.pi / 4)]),
                               atol=1e-18)
