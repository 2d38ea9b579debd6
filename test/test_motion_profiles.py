"""Host motion profiles: analytic rates/accelerations against numerical differentiation of
the DCM (built with scipy), paper 1 closed forms, the YAML front end and the inertial-rate
conversion against a directly differentiated inertial DCM."""
import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from gimbal_kinematics.gimbal import host_state
from gimbal_kinematics.maths.earth import earth_rate_n
from gimbal_sim.world.plant import motion_profiles as mp

D = math.pi / 180.0
H = 2e-4  # 5-point stencil step [s]: truncation ~h⁴ f⁽⁵⁾, rounding ~eps/h².


def c_nb(profile, t):
    s = profile.sample(t)
    # Intrinsic Z-Y'-X'' (yaw, pitch, roll) is the 3-2-1 sequence: the matrix is C_nb.
    return Rotation.from_euler("ZYX", [s.yaw, s.pitch, s.roll]).as_matrix()


def d1(f, t, h=H):
    return (f(t - 2 * h) - 8 * f(t - h) + 8 * f(t + h) - f(t + 2 * h)) / (12 * h)


def d2(f, t, h=H):
    return (-f(t - 2 * h) + 16 * f(t - h) - 30 * f(t) + 16 * f(t + h) - f(t + 2 * h)) / (12 * h * h)


def vee(m):
    return np.array([m[2, 1] - m[1, 2], m[0, 2] - m[2, 0], m[1, 0] - m[0, 1]]) / 2.0


def numeric_body_rates(dcm, t):
    """ω from [ω×] = Cᵀ Ċ and α from d/dt(Cᵀ Ċ) = ĊᵀĊ + CᵀC̈, all numerical."""
    C, Cd, Cdd = dcm(t), d1(dcm, t), d2(dcm, t)
    w = Cd.T @ Cd + C.T @ Cdd
    return vee(C.T @ Cd), vee(w), np.max(np.abs(C.T @ Cd + (C.T @ Cd).T))


PROFILES = {
    "paper1": mp.make_profile("paper1_land_vehicle", {"lat_deg": 39.9}),
    "paper1_no_modes": mp.make_profile("paper1_land_vehicle", {"structural_modes": False}),
    "ship": mp.make_profile("paper5_ship", {"mean_heading_deg": 120.0, "roll_phase_rad": 0.4,
                                            "heading_period_s": 12.0}),
    "static": mp.make_profile("static", {"lat_deg": -33.0, "roll_deg": 12.0, "pitch_deg": -7.0,
                                         "yaw_deg": 250.0, "psi_t_deg": 40.0}),
    "user": mp.make_profile("sinusoids", {
        "roll": {"offset_deg": 20.0, "terms": [[8.0, 1.3, 0.2], {"amplitude_deg": 3.0, "period_s": 0.7}]},
        "pitch": [[30.0, 0.9, 1.0], [5.0, 4.0, -0.5]],
        "yaw": {"offset_deg": -40.0, "rate_deg_s": 6.0, "terms": [[10.0, 2.0, 0.0]]},
        "psi_t": {"rate_deg_s": 15.0, "terms": [{"amplitude_deg": 4.0, "frequency_rad_s": 5.0, "phase_rad": 1.0}]},
        "accel_z_m_s2": [[0.5, 6.0, 0.0]],
    }),
}
TIMES = (0.0, 0.37, 3.1, 17.25)


@pytest.mark.parametrize("name", sorted(PROFILES))
@pytest.mark.parametrize("t", TIMES)
def test_body_rates_and_accelerations_match_numerical_dcm_derivative(name, t):
    profile = PROFILES[name]
    s = profile.sample(t)
    w_num, a_num, skew_err = numeric_body_rates(lambda tt: c_nb(profile, tt), t)
    assert skew_err < 1e-8
    np.testing.assert_allclose(s.omega_nb_b, w_num, rtol=0, atol=1e-9)
    np.testing.assert_allclose(s.alpha_nb_b, a_num, rtol=0, atol=1e-7)


@pytest.mark.parametrize("name", sorted(PROFILES))
def test_angle_rates_match_numerical_derivative_of_angles(name):
    profile = PROFILES[name]
    for t in TIMES:
        s = profile.sample(t)
        for ang, rate, acc in (("roll", "roll_dot", "roll_ddot"), ("pitch", "pitch_dot", "pitch_ddot"),
                               ("yaw", "yaw_dot", "yaw_ddot"), ("psi_t", "psi_t_dot", "psi_t_ddot")):
            f = lambda tt, a=ang: getattr(profile.sample(tt), a)  # noqa: E731
            assert getattr(s, rate) == pytest.approx(d1(f, t), abs=1e-9)
            assert getattr(s, acc) == pytest.approx(d2(f, t), abs=2e-7)


def test_paper1_closed_form_at_t0():
    """Hand-computed: at t = 0 every sin(ωt) vanishes, so φ = θ = 0, rates are Σ A ω."""
    s = PROFILES["paper1"].sample(0.0)
    modes_rate = 0.01 * 101 + 0.0001 * 258  # deg/s
    assert s.roll == 0.0 and s.pitch == 0.0
    assert s.yaw == pytest.approx(2.5 * math.sin(math.pi / 3) * D, abs=1e-15)
    assert s.psi_t == pytest.approx(0.1 * math.sin(math.pi / 4) * D, abs=1e-15)
    assert s.roll_dot == pytest.approx((0.9 + 0.3 + modes_rate) * D, abs=1e-15)
    assert s.pitch_dot == pytest.approx((-0.9 + 0.3 + modes_rate) * D, abs=1e-15)
    assert s.yaw_dot == pytest.approx((1.2 * 0.5 + modes_rate) * D, abs=1e-15)
    assert s.psi_t_dot == pytest.approx((6.0 * math.cos(math.pi / 4) + modes_rate) * D, abs=1e-15)
    assert s.roll_ddot == 0.0 and s.pitch_ddot == 0.0
    assert s.yaw_ddot == pytest.approx(-(1.5 * 0.36 + 0.09) * math.sin(math.pi / 3) * D, abs=1e-15)
    assert s.psi_t_ddot == pytest.approx(-360.0 * math.sin(math.pi / 4) * D, abs=1e-13)
    # Level host: p, q, r = Euler rates; ṗ = −θ̇ψ̇, q̇ = φ̇ψ̇, ṙ = ψ̈ − φ̇θ̇.
    assert (s.p, s.q, s.r) == pytest.approx((s.roll_dot, s.pitch_dot, s.yaw_dot), abs=1e-15)
    assert s.p_dot == pytest.approx(-s.pitch_dot * s.yaw_dot, abs=1e-15)
    assert s.q_dot == pytest.approx(s.roll_dot * s.yaw_dot, abs=1e-15)
    assert s.r_dot == pytest.approx(s.yaw_ddot - s.roll_dot * s.pitch_dot, abs=1e-15)
    assert (s.accel_x, s.accel_y, s.accel_z) == (0.0, 0.0, 0.0)


@pytest.mark.parametrize("t", (1.0, 7.5, 42.0))
def test_paper1_angles_match_the_papers_formulas(t):
    s = PROFILES["paper1"].sample(t)
    modes = 0.01 * math.sin(101 * t) + 0.0001 * math.sin(258 * t)
    assert s.roll == pytest.approx((1.5 * math.sin(0.6 * t) + math.sin(0.3 * t) + modes) * D, abs=1e-14)
    assert s.pitch == pytest.approx((-1.5 * math.sin(0.6 * t) + math.sin(0.3 * t) + modes) * D, abs=1e-14)
    third = math.pi / 3
    assert s.yaw == pytest.approx((1.5 * math.sin(0.6 * t + third) + math.sin(0.3 * t + third) + modes) * D,
                                  abs=1e-14)
    assert s.psi_t == pytest.approx((0.1 * math.sin(60 * t + math.pi / 4) + modes) * D, abs=1e-14)
    s2 = PROFILES["paper1_no_modes"].sample(t)
    assert s.roll - s2.roll == pytest.approx(modes * D, abs=1e-15)


def test_ship_amplitudes_and_static_profile():
    ship = mp.make_profile("paper5_ship", {"mean_heading_deg": 30.0})
    ts = np.linspace(0.0, 60.0, 6001)
    samples = [ship.sample(t) for t in ts]
    assert max(abs(s.roll) for s in samples) == pytest.approx(5.0 * D, rel=1e-3)
    assert max(abs(s.pitch) for s in samples) == pytest.approx(3.0 * D, rel=1e-3)
    assert max(abs(s.yaw - 30.0 * D) for s in samples) == pytest.approx(3.0 * D, rel=1e-3)
    # Default periods: roll 10 s -> roll repeats after 10 s.
    assert ship.sample(3.3).roll == pytest.approx(ship.sample(13.3).roll, abs=1e-14)
    st = PROFILES["static"].sample(123.0)
    assert (st.roll, st.pitch, st.yaw, st.psi_t) == pytest.approx((12 * D, -7 * D, 250 * D, 40 * D))
    assert np.all(st.omega_nb_b == 0.0) and np.all(st.alpha_nb_b == 0.0)
    assert PROFILES["static"].site.lat_rad == pytest.approx(-33.0 * D)
    user = PROFILES["user"].sample(1.7)
    assert user.accel_b == pytest.approx([0.0, 0.0, 0.5 * math.sin(6.0 * 1.7)], abs=1e-15)
    assert user.yaw == pytest.approx((-40.0 + 6.0 * 1.7 + 10.0 * math.sin(3.4)) * D, abs=1e-14)


@pytest.mark.parametrize(
    "name, params, needle",
    [
        ("paper2_uav", {}, "paper2_uav"),
        ("paper5_ship", {"roll_period_s": -1.0}, "roll_period_s"),
        ("paper5_ship", {"rol_amplitude_deg": 1.0}, "rol_amplitude_deg"),
        ("paper5_ship", {"roll_amplitude_deg": "big"}, "roll_amplitude_deg"),
        ("paper1_land_vehicle", {"lat_deg": 95.0}, "lat_deg"),
        ("paper1_land_vehicle", {"structural_modes": "yes"}, "structural_modes"),
        ("static", {"pitch_deg": 90.0}, "pitch"),
        ("static", {"height_m": float("nan")}, "height_m"),
        ("sinusoids", {"rol": [[1.0, 1.0, 0.0]]}, "rol"),
        ("sinusoids", {"roll": [[1.0, -1.0, 0.0]]}, "roll[0]"),
        ("sinusoids", {"roll": [[1.0, 1.0]]}, "roll[0]"),
        ("sinusoids", {"yaw": [{"amplitude_deg": 1.0, "period_s": 2.0, "frequency_rad_s": 1.0}]}, "yaw[0]"),
        ("sinusoids", {"yaw": [{"amplitude_deg": 1.0, "period_s": 0.0}]}, "yaw[0].period_s"),
        ("sinusoids", {"pitch": [{"amplitude": 1.0, "period_s": 1.0}]}, "amplitude"),
        ("sinusoids", {"psi_t": {"offset": 1.0}}, "offset"),
        ("sinusoids", {"accel_x_m_s2": [{"amplitude_deg": 1.0, "period_s": 1.0}]}, "amplitude_deg"),
    ],
)
def test_bad_profile_names_and_params_raise_naming_them(name, params, needle):
    with pytest.raises(ValueError, match=None) as err:
        mp.make_profile(name, params)
    assert needle in str(err.value)


def test_params_must_be_a_mapping():
    with pytest.raises(ValueError, match="params"):
        mp.make_profile("static", [1, 2])


@pytest.mark.parametrize("name", ["paper1", "user", "ship"])
def test_inertial_rate_conversion_matches_differentiated_inertial_dcm(name):
    """C_ib = C_in C_nb with n turning at a constant ω_in^n: C_in = exp(t [ω×]) (scipy)."""
    profile = PROFILES[name]
    w_in_n = np.array([0.3, -0.1, 0.2])  # large, so the coupling term is well resolved

    def c_ib(t):
        return Rotation.from_rotvec(w_in_n * t).as_matrix() @ c_nb(profile, t)

    for t in (0.4, 5.0):
        w_num, a_num, _ = numeric_body_rates(c_ib, t)
        w, a = host_state.body_inertial_rates(profile.sample(t), w_in_n)
        np.testing.assert_allclose(w, w_num, atol=1e-9)
        np.testing.assert_allclose(a, a_num, atol=2e-7)


def test_inertial_rate_conversion_with_earth_rate():
    """Earth rate at 45°: ω_ib - ω_nb = C_bn ω_ie^n exactly (scipy DCM), and zero ω_in is a no-op."""
    s = PROFILES["user"].sample(2.0)
    w_ie = earth_rate_n(math.radians(45.0))
    w, a = host_state.body_inertial_rates(s, w_ie)
    np.testing.assert_allclose(w - s.omega_nb_b, c_nb(PROFILES["user"], 2.0).T @ w_ie, atol=1e-18)
    np.testing.assert_allclose(a - s.alpha_nb_b, -np.cross(s.omega_nb_b, w - s.omega_nb_b), atol=1e-18)
    w0, a0 = host_state.body_inertial_rates(s, np.zeros(3))
    assert np.array_equal(w0, s.omega_nb_b) and np.array_equal(a0, s.alpha_nb_b)
    with pytest.raises(ValueError, match="omega_in_n"):
        host_state.body_inertial_rates(s, np.zeros(2))
