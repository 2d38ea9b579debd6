"""Paper 3 four-gimbal platform: DCMs against scipy, rates against numerical derivatives,
servo signals against perturbed-geometry solves, earth-rate command against integration."""
import math

import numpy as np
import pytest
from scipy.integrate import quad, solve_ivp
from scipy.optimize import least_squares
from scipy.spatial.transform import Rotation

from gimbal_kinematics.maths import earth
from gimbal_kinematics.maths import four_gimbal as fg
from gimbal_kinematics.maths.rotations import small_angles_from_dcm, unskew

RNG_SEED = 3303


def _scipy_C_bs(a, q, p, r):
    """Platform-to-base DCM built independently: intrinsic x (r), y (p), x (q), z (a)."""
    return (Rotation.from_euler("XYX", [r, p, q]) * Rotation.from_euler("Z", a)).as_matrix()


def _random_angles(rng, q_max=1.3, p_max=1.3):
    return np.array([rng.uniform(-math.pi, math.pi), rng.uniform(-q_max, q_max),
                     rng.uniform(-p_max, p_max), rng.uniform(-math.pi, math.pi)])


def _wrap(x):
    return (np.asarray(x) + math.pi) % (2 * math.pi) - math.pi


def _omega_from_dcm(C_of_t, h=1e-5):
    # ω× = Cᵀ dC/dt for C mapping the moving frame to the inertial frame
    return unskew(C_of_t(0.0).T @ (C_of_t(h) - C_of_t(-h)) / (2 * h), tol=1e-6)


def _solve_inner_angles(C_sb_target, theta_r, guess):
    """(a, q, p) with the outer roll fixed that realise C_sb_target, by a scipy solve on the
    scipy-built chain (independent of the module's closed forms)."""
    def resid(x):
        return (_scipy_C_bs(x[0], x[1], x[2], theta_r).T - C_sb_target).ravel()
    sol = least_squares(resid, guess, xtol=1e-15, ftol=1e-15, gtol=1e-15, method="lm")
    assert np.max(np.abs(sol.fun)) < 1e-14
    return sol.x


# ------------------------------------------------------------------------------ DCMs

def test_dcms_match_scipy():
    rng = np.random.default_rng(RNG_SEED)
    for _ in range(100):
        a, q, p, r = rng.uniform(-math.pi, math.pi, 4)
        np.testing.assert_allclose(fg.dcm_br(r), Rotation.from_euler("x", r).as_matrix(), atol=1e-15)
        np.testing.assert_allclose(fg.dcm_rp(p), Rotation.from_euler("y", p).as_matrix(), atol=1e-15)
        np.testing.assert_allclose(fg.dcm_pq(q), Rotation.from_euler("x", q).as_matrix(), atol=1e-15)
        np.testing.assert_allclose(fg.dcm_qs(a), Rotation.from_euler("z", a).as_matrix(), atol=1e-15)
        expected = _scipy_C_bs(a, q, p, r)
        np.testing.assert_allclose(fg.dcm_bs((a, q, p, r)), expected, atol=1e-14)
        np.testing.assert_allclose(fg.dcm_sb(np.array([a, q, p, r])), expected.T, atol=1e-14)


def test_dcm_qs_is_the_paper_eq1_matrix():
    a = 0.7
    c, s = math.cos(a), math.sin(a)
    np.testing.assert_allclose(fg.dcm_qs(a), [[c, -s, 0], [s, c, 0], [0, 0, 1]], atol=1e-15)


def test_level_platform_on_level_base_gimbal_angles():
    # base with heading psi, pitch theta, roll phi; platform level at modulation angle phi_z:
    # with the inner roll at null the gimbals take up -roll, -pitch and phi_z - heading
    rng = np.random.default_rng(RNG_SEED + 1)
    for _ in range(50):
        phi, theta, psi = rng.uniform(-1.2, 1.2), rng.uniform(-1.2, 1.2), rng.uniform(-3, 3)
        phi_z = rng.uniform(-3, 3)
        C_nb = Rotation.from_euler("ZYX", [psi, theta, phi]).as_matrix()
        C_sn = Rotation.from_euler("z", phi_z).as_matrix().T
        ang = fg.gimbal_angles_from_dcm(C_sn @ C_nb)
        np.testing.assert_allclose(_wrap(ang - [phi_z - psi, 0, -theta, -phi]), 0, atol=1e-12)
        np.testing.assert_allclose(fg.dcm_ns_level(phi_z), C_sn.T, atol=1e-15)


def test_gimbal_angles_from_dcm_roundtrip_and_lock():
    rng = np.random.default_rng(RNG_SEED + 2)
    for _ in range(100):
        ang = _random_angles(rng)
        C_sb = _scipy_C_bs(*ang).T
        np.testing.assert_allclose(_wrap(fg.gimbal_angles_from_dcm(C_sb, ang[3]) - ang), 0, atol=1e-11)
        null = fg.gimbal_angles_from_dcm(C_sb)
        assert null[1] == 0.0
        np.testing.assert_allclose(fg.dcm_sb(null), C_sb, atol=1e-12)
    with pytest.raises(ValueError, match="inner-roll"):
        fg.gimbal_angles_from_dcm(_scipy_C_bs(0.3, math.pi / 2, 0.2, 0.1).T, 0.1)
    with pytest.raises(ValueError, match="pitch"):
        fg.gimbal_angles_from_dcm(_scipy_C_bs(0.3, 0.0, -math.pi / 2, 0.1).T)


def test_bad_shapes_raise_naming_the_argument():
    with pytest.raises(ValueError, match="angles"):
        fg.dcm_bs([0.1, 0.2, 0.3])
    with pytest.raises(ValueError, match="omega_b_b"):
        fg.platform_rate_s([0.0, 0.0], [0.0] * 4, [0.0] * 4)
    with pytest.raises(ValueError, match="pickoff_s"):
        fg.inner_gimbal_control_signals([0.0] * 4, 0.1)


# ------------------------------------------------------------------------------ rates

class RandomMotion:
    """Base turning at a constant body rate; gimbal angles quadratic in time."""

    def __init__(self, rng):
        self.C_ib0 = Rotation.random(random_state=rng.integers(1 << 31)).as_matrix()
        self.w_b = rng.normal(scale=0.5, size=3)
        self.j0 = _random_angles(rng)
        self.j1 = rng.normal(scale=1.0, size=4)
        self.j2 = rng.normal(scale=2.0, size=4)

    def angles(self, t):
        return self.j0 + self.j1 * t + 0.5 * self.j2 * t * t

    def rates(self, t):
        return self.j1 + self.j2 * t

    def dcms(self, t):
        """C_ir, C_ip, C_iq, C_is built with scipy."""
        a, q, p, r = self.angles(t)
        C_ib = self.C_ib0 @ Rotation.from_rotvec(self.w_b * t).as_matrix()
        C_ir = C_ib @ Rotation.from_euler("x", r).as_matrix()
        C_ip = C_ir @ Rotation.from_euler("y", p).as_matrix()
        C_iq = C_ip @ Rotation.from_euler("x", q).as_matrix()
        return C_ir, C_ip, C_iq, C_iq @ Rotation.from_euler("z", a).as_matrix()


def test_platform_rate_matches_dcm_derivative():
    rng = np.random.default_rng(RNG_SEED + 3)
    worst = 0.0
    for _ in range(100):
        m = RandomMotion(rng)
        chain = fg.four_gimbal_rates(m.w_b, np.zeros(3), m.angles(0.0), m.rates(0.0), m.j2)
        got = (chain.omega_r_r, chain.omega_p_p, chain.omega_q_q, chain.omega_s_s)
        for k, omega in enumerate(got):
            expected = _omega_from_dcm(lambda t, k=k: m.dcms(t)[k])
            np.testing.assert_allclose(omega, expected, atol=1e-7, rtol=0)
            worst = max(worst, float(np.max(np.abs(omega - expected))))
        np.testing.assert_allclose(
            fg.platform_rate_s(m.w_b, m.angles(0.0), m.rates(0.0)), chain.omega_s_s, atol=1e-14
        )
    print(f"max |omega - numerical| = {worst:.2e} rad/s")


def test_angular_accelerations_match_rate_derivative():
    rng = np.random.default_rng(RNG_SEED + 4)
    for _ in range(50):
        m = RandomMotion(rng)
        alpha_b = rng.normal(size=3)

        def rates_at(t):
            return fg.four_gimbal_rates(m.w_b + alpha_b * t, alpha_b, m.angles(t), m.rates(t), m.j2)

        h = 1e-5
        now, up, down = rates_at(0.0), rates_at(h), rates_at(-h)
        for name in ("r_r", "p_p", "q_q", "s_s"):
            numeric = (getattr(up, "omega_" + name) - getattr(down, "omega_" + name)) / (2 * h)
            np.testing.assert_allclose(getattr(now, "alpha_" + name), numeric, atol=1e-7, rtol=0)


def test_rate_inverses_reproduce_the_forward_rates():
    rng = np.random.default_rng(RNG_SEED + 5)
    for _ in range(200):
        ang = _random_angles(rng)
        w_b = rng.normal(scale=0.5, size=3)
        rates = rng.normal(scale=1.0, size=4)
        w_s = fg.platform_rate_s(w_b, ang, rates)
        got = fg.gimbal_rates_given_outer_roll(w_s, w_b, ang, theta_r_dot=rates[3])
        np.testing.assert_allclose(got, rates, atol=1e-11 / math.cos(ang[1]))
        got = fg.gimbal_rates_given_inner_roll(w_s, w_b, ang, theta_q_dot=rates[1])
        np.testing.assert_allclose(got, rates, atol=1e-11 / (math.cos(ang[1]) * math.cos(ang[2])))


def test_rate_inverses_raise_at_gimbal_lock():
    w = np.array([0.01, -0.02, 0.03])
    with pytest.raises(ValueError, match="gimbal lock: inner-roll"):
        fg.gimbal_rates_given_outer_roll(w, w, (0.2, math.pi / 2, 0.1, 0.3))
    with pytest.raises(ValueError, match="gimbal lock: pitch gimbal"):
        fg.gimbal_rates_given_inner_roll(w, w, (0.2, 0.0, -math.pi / 2 + 1e-3, 0.3))
    # the outer-roll-given inverse does not care about the pitch gimbal
    fg.gimbal_rates_given_outer_roll(w, w, (0.2, 0.0, math.pi / 2, 0.3))


# ------------------------------------------------------------------------------ servo signals

def test_control_signals_match_perturbed_geometry():
    """Tilt the platform by a small δ (in s) with the base and outer roll still; re-solve the
    three inner gimbal angles with scipy: their changes are the control signals to 1st order."""
    rng = np.random.default_rng(RNG_SEED + 6)
    for k in range(40):
        ang = _random_angles(rng, q_max=0.0 if k < 10 else 1.2)
        delta = rng.normal(size=3) * 1e-6
        C_sb = _scipy_C_bs(*ang).T
        # s' is s turned by δ: C_s's = R(δ)ᵀ with R the active rotation
        C_s2b = Rotation.from_rotvec(delta).as_matrix().T @ C_sb
        new = _solve_inner_angles(C_s2b, ang[3], ang[:3])
        d_a, d_q, d_p = new - ang[:3]
        sig = fg.inner_gimbal_control_signals(delta, ang[0], ang[1])
        tol = 1e-11 / math.cos(ang[1]) ** 2
        np.testing.assert_allclose([sig.inner_roll, sig.pitch, sig.azimuth], [d_q, d_p, d_a], atol=tol)
        # same thing from the rate inverse: a platform rate δ per second, base still
        inv = fg.gimbal_rates_given_outer_roll(delta, np.zeros(3), ang)
        np.testing.assert_allclose([sig.azimuth, sig.inner_roll, sig.pitch], inv[:3], atol=1e-18)


def test_control_signals_at_null_are_the_paper_rotation():
    rng = np.random.default_rng(RNG_SEED + 7)
    for _ in range(20):
        a = rng.uniform(-math.pi, math.pi)
        g = rng.normal(size=3) * 1e-4
        c, s = math.cos(a), math.sin(a)
        # paper eq. 1 rows (pitch, inner roll, azimuth) with its x = pitch axis; here x = roll
        expected_q, expected_p, expected_a = c * g[0] - s * g[1], s * g[0] + c * g[1], g[2]
        sig = fg.inner_gimbal_control_signals(g, a)
        np.testing.assert_allclose(sig, (expected_q, expected_p, expected_a), atol=1e-18)


def test_outer_roll_null_closed_form_and_effect():
    rng = np.random.default_rng(RNG_SEED + 8)
    for _ in range(30):
        a, p, r = rng.uniform(-math.pi, math.pi), rng.uniform(-1.4, 1.4), rng.uniform(-math.pi, math.pi)
        q = rng.normal(scale=1e-4)
        d_r = fg.outer_roll_control_signal(q, p)
        assert d_r == pytest.approx(q / math.cos(p), rel=1e-14)
        # platform held by the inner loops, base still: turn the outer roll by Δθ_rm, re-solve
        C_sb = _scipy_C_bs(a, q, p, r).T
        a2, q2, p2 = _solve_inner_angles(C_sb, r + d_r, np.array([a, q, p]))
        assert abs(q2) < 1e-3 * abs(q)  # second order: the inner roll is back at null
        assert abs(a2 - a + math.sin(p) * d_r) < 1e-3 * abs(d_r)


@pytest.mark.parametrize("theta_p", [math.pi / 2, -math.pi / 2, 3 * math.pi / 2,
                                     math.pi / 2 - 0.5 * fg.GIMBAL_LOCK_MARGIN,
                                     -math.pi / 2 + 0.99 * fg.GIMBAL_LOCK_MARGIN])
def test_outer_roll_null_raises_near_gimbal_lock(theta_p):
    with pytest.raises(ValueError, match=r"gimbal lock: pitch gimbal .* sec θ_p is unbounded"):
        fg.outer_roll_control_signal(1e-3, theta_p)


def test_outer_roll_null_just_outside_margin_is_finite():
    theta_p = math.pi / 2 - 1.01 * fg.GIMBAL_LOCK_MARGIN
    assert fg.outer_roll_control_signal(1e-3, theta_p) == pytest.approx(1e-3 / math.cos(theta_p))


# ------------------------------------------------------------------------------ command rate

def _paper_eq4_enu(lat, h, v_n):
    """Paper 3 eq. 4, ENU geographic frame t: ω_it^t from earth rate and ground speed."""
    v_north, v_east = v_n[0], v_n[1]
    rm = earth.meridian_radius(lat) + h
    rn = earth.prime_vertical_radius(lat) + h
    om = earth.OMEGA_IE
    return np.array([-v_north / rm, om * math.cos(lat) + v_east / rn,
                     om * math.sin(lat) + v_east * math.tan(lat) / rn])


def test_command_rate_matches_paper_closed_form_in_enu():
    rng = np.random.default_rng(RNG_SEED + 9)
    for _ in range(50):
        lat, phi_z, phi_dot = rng.uniform(-1.4, 1.4), rng.uniform(-7, 7), rng.normal(scale=0.03)
        v_n, h = np.array([*rng.normal(scale=200, size=2), 0.0]), rng.uniform(0, 1e4)
        drift = rng.normal(scale=1e-7, size=3)
        w_c = fg.command_rate_s(lat, phi_z, phi_dot, v_n=v_n, h=h, drift_s=drift)
        C_ns = Rotation.from_euler("z", phi_z).as_matrix()
        # ENU platform rotation ω_r about up is -φ̇z (φz is about NED down here)
        expected_enu = _paper_eq4_enu(lat, h, v_n) + [0.0, 0.0, -phi_dot]
        np.testing.assert_allclose(fg.C_ENU_NED @ C_ns @ (w_c + drift), expected_enu, atol=1e-18)
    # static: closed form Ω (cos L, 0, -sin L) in NED at φz = 0
    lat = 0.6
    np.testing.assert_allclose(fg.command_rate_s(lat, 0.0, 0.0),
                               earth.OMEGA_IE * np.array([math.cos(lat), 0, -math.sin(lat)]), atol=1e-20)


def _integrate_platform(schedule, lat_lon_of_t, t_end, dt, command):
    """Integrate C_is with the midpoint exponential and return the worst level and azimuth
    errors of C_ns against rot3(φz)ᵀ, with C_in = C_ie(t) C_en(lat(t), lon(t))."""
    def C_in(t):
        lat, lon = lat_lon_of_t(t)
        C_ie = Rotation.from_euler("z", earth.OMEGA_IE * t).as_matrix()
        return C_ie @ earth.dcm_en(lat, lon)

    C_is = C_in(0.0) @ fg.dcm_ns_level(schedule.angle(0.0))
    worst_level = worst_az = 0.0
    n = int(round(t_end / dt))
    for i in range(n):
        t_mid = (i + 0.5) * dt
        w = command(t_mid)
        C_is = C_is @ Rotation.from_rotvec(w * dt).as_matrix()
        t = (i + 1) * dt
        err = small_angles_from_dcm(C_in(t).T @ C_is @ fg.dcm_ns_level(schedule.angle(t)).T, 0.5)
        worst_level = max(worst_level, math.hypot(err[0], err[1]))
        worst_az = max(worst_az, abs(err[2]))
    return worst_level, worst_az


@pytest.mark.parametrize("moving", [False, True])
def test_commanded_platform_stays_locally_level(moving):
    lat0, lon0, h = math.radians(40.0), math.radians(116.0), 3000.0
    v_n = np.array([150.0, 100.0, 0.0]) if moving else None
    # short sweep so that several reversals (2 s ramps) fall inside the run
    sched = fg.BidirectionalRotation(rate_deg_s=1.2, sweep_deg=30.0, reversal_time_s=2.0)
    if moving:
        def ode(_t, y):
            return [v_n[0] / (earth.meridian_radius(y[0]) + h),
                    v_n[1] / ((earth.prime_vertical_radius(y[0]) + h) * math.cos(y[0]))]
        sol = solve_ivp(ode, (0.0, 61.0), [lat0, lon0], rtol=1e-13, atol=1e-15, dense_output=True)

        def lat_lon(t):
            return tuple(sol.sol(t))
    else:
        def lat_lon(_t):
            return lat0, lon0

    def command(t):
        phi, phi_dot, _ = sched.state(t)
        return fg.command_rate_s(lat_lon(t)[0], phi, phi_dot, v_n=v_n, h=h)

    level, az = _integrate_platform(sched, lat_lon, 60.0, 0.01, command)
    print(f"moving={moving}: level error {level:.2e} rad, azimuth error {az:.2e} rad")
    assert level < 1e-10 and az < 1e-9

    # without the earth/transport compensation the same platform tilts measurably
    def bare(t):
        return np.array([0.0, 0.0, sched.rate(t)])
    level_bare, _ = _integrate_platform(sched, lat_lon, 60.0, 0.05, bare)
    assert level_bare > 1e-3


# ------------------------------------------------------------------------------ schedule

@pytest.mark.parametrize("reversal_time_s", [0.0, 0.05, 3.0])
def test_bidirectional_schedule_kinematics(reversal_time_s):
    sched = fg.BidirectionalRotation(rate_deg_s=1.2, sweep_deg=360.0, reversal_time_s=reversal_time_s)
    w, sweep = math.radians(1.2), 2 * math.pi
    leg = sched.leg_duration_s
    assert leg == pytest.approx(300.0 + reversal_time_s / 2)
    rev = sched.reversal_times(4 * leg + 1.0)
    np.testing.assert_allclose(rev, leg * np.arange(1, 5))
    # extremes: exactly the sweep and back to zero at the reversals, at rest there if ramped
    for k, tk in enumerate(rev, start=1):
        assert sched.angle(tk) == pytest.approx(sweep if k % 2 else 0.0, abs=1e-9)
    # angle is the integral of the rate (independent quadrature), rate the derivative of angle
    rng = np.random.default_rng(RNG_SEED + 10)
    pts = sorted({reversal_time_s / 2, *(rev[:3]), *(rev[:3] - reversal_time_s / 2),
                  *(rev[:3] + reversal_time_s / 2)} - {0.0})
    for t in rng.uniform(0.0, 3 * leg, 20):
        integral, _ = quad(sched.rate, 0.0, t, points=[p for p in pts if p < t], limit=200)
        assert sched.angle(t) == pytest.approx(integral, abs=1e-8)
        h = 1e-4
        if all(abs(t - p) > 2 * h for p in pts):
            phi_num = (sched.angle(t + h) - sched.angle(t - h)) / (2 * h)
            assert sched.rate(t) == pytest.approx(phi_num, abs=1e-9)
            acc_num = (sched.rate(t + h) - sched.rate(t - h)) / (2 * h)
            assert sched.state(t)[2] == pytest.approx(acc_num, abs=1e-7)
    # cruise rate in both senses
    assert sched.rate(leg / 2) == pytest.approx(w)
    assert sched.rate(1.5 * leg) == pytest.approx(-w)
    assert sched.state(-1.0) == (0.0, 0.0, 0.0)


@pytest.mark.parametrize("kwargs, name", [({"rate_deg_s": 0.0}, "rate_deg_s"),
                                          ({"sweep_deg": -1.0}, "sweep_deg"),
                                          ({"reversal_time_s": -0.1}, "reversal_time_s"),
                                          ({"reversal_time_s": float("nan")}, "reversal_time_s"),
                                          ({"sweep_deg": 1.0, "reversal_time_s": 10.0}, "reversal_time_s")])
def test_schedule_validation_names_the_parameter(kwargs, name):
    with pytest.raises(ValueError, match=name):
        fg.BidirectionalRotation(**kwargs)
