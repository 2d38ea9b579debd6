"""Platform INS navigator (paper 3 §4.3) in a closed Schuler loop with an independent truth:
a perfectly servoed platform on a static base at 40° N whose gyro reference turns at the
navigator's command rate plus the true gyro drift, with accelerometers sensing the true
specific force plus a bias. One error source at a time, no noise; the figures asserted are the
classical closed forms (Schuler period 2π√(R/g), peak 2R∇/g, drift law Rε(t − sin ω_s t/ω_s))
and the rotation-modulation reductions."""
import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from gimbal_estimators.platform_navigator import HandOff, PlatformNavigator
from gimbal_estimators.platform_navigator_params import PARAMS, PlatformNavigatorParams
from gimbal_estimators.rotation_alignment import AlignmentEstimate
from gimbal_kinematics.params.table import ParameterError, defaults

# WGS-84 defining constants and Somigliana normal gravity, written out here (not the code under test)
A_WGS, F_WGS, OMEGA = 6378137.0, 1.0 / 298.257223563, 7.292115e-5
E2_WGS = F_WGS * (2.0 - F_WGS)
DEG_H = math.radians(1.0) / 3600.0
ARCSEC = math.radians(1.0) / 3600.0
UG = 9.80665e-6
LAT = math.radians(40.0)
DT_NS = 500_000_000  # 2 Hz: the Schuler dynamics are slow; 1.2 °/s turns 0.6° per step
DT = DT_NS * 1e-9


def radii(lat):
    w = 1.0 - E2_WGS * math.sin(lat) ** 2
    return A_WGS * (1.0 - E2_WGS) / w**1.5, A_WGS / math.sqrt(w)  # R_M, R_N


def gravity(lat):
    s2 = math.sin(lat) ** 2
    return 9.7803253359 * (1.0 + 0.00193185265241 * s2) / math.sqrt(1.0 - E2_WGS * s2)


def expm_skew(v):
    """exp([v×]) by Rodrigues' formula; (3, 3)."""
    x, y, z = (float(c) for c in v)
    th2 = x * x + y * y + z * z
    th = math.sqrt(th2)
    # sin θ/θ and (1 − cos θ)/θ², by their series where the closed forms lose digits
    a = math.sin(th) / th if th > 1e-4 else 1.0 - th2 / 6.0
    b = (1.0 - math.cos(th)) / th2 if th > 1e-4 else 0.5 - th2 / 24.0
    return np.array([[1.0 - b * (y * y + z * z), b * x * y - a * z, b * x * z + a * y],
                     [b * x * y + a * z, 1.0 - b * (x * x + z * z), b * y * z - a * x],
                     [b * x * z - a * y, b * y * z + a * x, 1.0 - b * (x * x + y * y)]])


class StaticBaseTruth:
    """The platform of paper 3 on a static base (heading 0, height 0), servoed perfectly.

    The servo resolves the navigator's NED command through its schedule angle φz and adds
    the modulation, ω_is^s = rot3(φz) ω_c^n + φ̇z e3 + ε_s. In the de-rotated platform frame m
    (C_sm = rot3(φz)) that is ω_im^m = ω_c^n + rot3(φz)ᵀ ε_s + ε_nav, slow and smooth, so
    C_mn is propagated exactly per step: C_mn ← exp(−[θ_m×]) C_mn exp([θ_n×]) with
    θ_n = ω_ie^n dt (the NED frame at rest). The modulated drift is integrated in closed form
    over each step (the reversals fall on the grid). Bidirectional schedule: ±1.2 °/s through
    360° and back, starting positive.
    """

    def __init__(self, rotate=False, drift_s=(0.0, 0.0, 0.0), bias_s=(0.0, 0.0, 0.0),
                 nav_drift_n=(0.0, 0.0, 0.0), misalignment_enu=(0.0, 0.0, 0.0)):
        self.rotate = rotate
        self.eps = np.asarray(drift_s, float)
        self.bias = np.asarray(bias_s, float)
        self.nav_drift = np.asarray(nav_drift_n, float)
        e, n, u = misalignment_enu
        self.C_mn = expm_skew((n, e, -u)).T  # C_nm = exp([φ×]) C_nm,ideal
        self.w_ie = OMEGA * np.array([math.cos(LAT), 0.0, -math.sin(LAT)])
        self.g = gravity(LAT)
        self.rate = math.radians(1.2)
        self.leg = 300.0
        self.t = 0.0

    def phi(self, t):
        if not self.rotate:
            return 0.0, 0.0
        k, u = divmod(t + 1e-9, self.leg)
        u = max(u - 1e-9, 0.0)
        return (self.rate * u, self.rate) if k % 2 == 0 else (self.rate * (self.leg - u), -self.rate)

    def step(self, w_c_n, dt):
        pa, _ = self.phi(self.t)
        _, rate = self.phi(self.t + 0.5 * dt)
        pb = pa + rate * dt if self.rotate else 0.0
        if rate:
            ic, is_ = (math.sin(pb) - math.sin(pa)) / rate, (math.cos(pa) - math.cos(pb)) / rate
        else:
            ic, is_ = math.cos(pa) * dt, math.sin(pa) * dt
        ex, ey, ez = self.eps
        modulated = np.array([ic * ex - is_ * ey, is_ * ex + ic * ey, ez * dt])  # ∫ rot3(φz)ᵀ ε_s dt
        th_m = (np.asarray(w_c_n) + self.nav_drift) * dt + modulated
        self.C_mn = expm_skew(-th_m) @ self.C_mn @ expm_skew(self.w_ie * dt)
        self.t += dt

    def C_sn(self):
        p, _ = self.phi(self.t)
        c, s = math.cos(p), math.sin(p)
        return np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]]) @ self.C_mn

    def sense(self):
        """(specific force in s + bias, azimuth resolver angle) at the current time."""
        C = self.C_sn()
        return C @ np.array([0.0, 0.0, -self.g]) + self.bias, math.atan2(C[0, 1], C[0, 0])

    def misalignment_enu(self):
        """Rotation vector φ of C_nm (= exp([φ×]) at zero φz) in ENU order [rad]."""
        rv = Rotation.from_matrix(self.C_mn.T).as_rotvec()
        return np.array([rv[1], rv[0], -rv[2]])


def fly(truth, hours, nav=None, every=1):
    """Close the loop for ``hours``; returns t [s], north and east position error [m], v_N [m/s]."""
    nav = nav if nav is not None else PlatformNavigator(PlatformNavigatorParams(lat_deg=40.0))
    rm, rn = radii(LAT)
    n = int(round(hours * 3600.0 / DT))
    out = np.empty((n // every + 1, 4))
    for k in range(n + 1):
        f, th = truth.sense()
        o = nav.step(k * DT_NS, f, th).output
        if k % every == 0:
            out[k // every] = (truth.t, (o.lat - LAT) * rm, o.lon * rn * math.cos(LAT), o.velocity_n[0])
        truth.step(o.command_rate_n, DT)
    return out[:, 0], out[:, 1], out[:, 2], out[:, 3]


def schuler_omega(lat=LAT):
    rm, _ = radii(lat)
    return math.sqrt(gravity(lat) / rm)


# --------------------------------------------------------------------------- closed forms
def test_level_accel_bias_rotation_off_gives_the_schuler_oscillation():
    bias = 100.0 * UG
    t, pn, pe, vn = fly(StaticBaseTruth(bias_s=(bias, 0.0, 0.0)), 3.0)
    # period from the zero crossings of the north velocity error (sin ω_s t)
    s = np.sign(vn[1:])
    k = np.nonzero(s[1:] != s[:-1])[0] + 1
    tc = t[1:][k - 1] - vn[1:][k - 1] * (t[1:][k] - t[1:][k - 1]) / (vn[1:][k] - vn[1:][k - 1])
    assert len(tc) >= 3
    period_min = 2.0 * (tc[-1] - tc[0]) / (len(tc) - 1) / 60.0
    assert period_min == pytest.approx(84.4, rel=0.01)
    rm, _ = radii(LAT)
    peak = float(np.max(np.hypot(pn, pe)))
    assert peak == pytest.approx(2.0 * rm * bias / gravity(LAT), rel=0.05)
    print(f"Schuler period {period_min:.2f} min (closed form {2 * math.pi / schuler_omega() / 60:.2f}); "
          f"peak {peak:.1f} m vs 2R∇/g = {2 * rm * bias / gravity(LAT):.1f} m")


def test_horizontal_gyro_drift_follows_the_schuler_drift_law_for_two_hours():
    eps = 0.03 * DEG_H
    t, pn, pe, _ = fly(StaticBaseTruth(drift_s=(0.0, eps, 0.0)), 2.0)
    rm, _ = radii(LAT)
    ws = schuler_omega()
    law = rm * eps * (t - np.sin(ws * t) / ws)
    sel = t >= 300.0
    rel = np.abs(np.hypot(pn, pe)[sel] / law[sel] - 1.0)
    assert float(np.max(rel)) < 0.05
    print(f"drift law: worst relative deviation {np.max(rel):.4f} over 5 min..2 h; "
          f"error at 2 h {np.hypot(pn, pe)[-1]:.1f} m vs {law[-1]:.1f} m")


def _peak_radial(**kw):
    t, pn, pe, _ = fly(StaticBaseTruth(**kw), 3.0, every=20)
    return float(np.max(np.hypot(pn, pe)))


def test_rotation_modulates_level_errors_but_not_the_vertical_drift():
    """Peak radial error over 3 h per source, rotation off vs on (bidirectional ±1.2 °/s)."""
    eps, bias = 0.03 * DEG_H, 100.0 * UG
    sources = {"gyro_xy": dict(drift_s=(eps, eps, 0.0)), "accel_xy": dict(bias_s=(bias, bias, 0.0)),
               "gyro_z": dict(drift_s=(0.0, 0.0, eps))}
    peak = {(name, rot): _peak_radial(rotate=rot, **kw) for name, kw in sources.items() for rot in (False, True)}
    for name in sources:
        print(f"{name}: off {peak[name, False]:.1f} m, on {peak[name, True]:.1f} m, "
              f"ratio {peak[name, False] / peak[name, True]:.1f}")
    print(f"gyro_z closed form R ω_N ε t²/2 at 3 h: "
          f"{radii(LAT)[0] * OMEGA * math.cos(LAT) * eps * (3 * 3600.0) ** 2 / 2:.1f} m")
    assert peak["gyro_xy", False] >= 10.0 * peak["gyro_xy", True]
    assert peak["accel_xy", False] >= 10.0 * peak["accel_xy", True]
    assert peak["gyro_z", True] == pytest.approx(peak["gyro_z", False], rel=0.10)
    # the vertical drift turns the reference in azimuth, ε_z t, and the earth rate applied about
    # the wrong axes tilts it by ω_N ε_z t²/2: a quasi-static R ω_N ε_z t²/2 at 3 h, bent a few
    # per cent by the earth-rate coupling (Ω t = 0.8 rad)
    rm, _ = radii(LAT)
    t3 = 3.0 * 3600.0
    assert peak["gyro_z", False] == pytest.approx(rm * OMEGA * math.cos(LAT) * eps * t3**2 / 2.0, rel=0.10)


def test_vertical_channel_is_damped_by_the_reference_height():
    """A vertical accelerometer bias b into the third-order loop (triple pole at −1/τ, the
    gravity gradient cancelled by k2) gives e(s) = −b/(s + 1/τ)³: h − h_ref = −b t² e^(−t/τ)/2,
    peak 2bτ²/e² at t = 2τ, then back to the reference (a free channel would diverge)."""
    bias, tau = 100.0 * UG, 100.0
    nav = PlatformNavigator(PlatformNavigatorParams(lat_deg=40.0, vertical_tau_s=tau))
    truth = StaticBaseTruth(bias_s=(0.0, 0.0, bias))
    t, h = [], []
    for k in range(int(1800.0 / DT) + 1):
        f, th = truth.sense()
        o = nav.step(k * DT_NS, f, th).output
        t.append(truth.t)
        h.append(o.height)
        truth.step(o.command_rate_n, DT)
    t, h = np.array(t), np.array(h)
    law = -bias * t**2 * np.exp(-t / tau) / 2.0
    peak = 2.0 * bias * tau**2 / math.e**2
    assert float(np.max(np.abs(h - law))) < 0.02 * peak
    assert abs(h[-1]) < 0.01 * peak
    print(f"vertical: peak {-h.min():.3f} m at {t[np.argmin(h)]:.0f} s (closed form {peak:.3f} m at {2 * tau:.0f} s), "
          f"worst deviation {np.max(np.abs(h - law)) / peak:.4f} of the peak")


# --------------------------------------------------------------------------- hand-off
def test_drift_estimates_in_the_command_cancel_the_drifts():
    eps_s = (0.03 * DEG_H, -0.02 * DEG_H, 0.01 * DEG_H)
    eps_n = 0.005 * DEG_H
    hand = HandOff(LAT, 0.0, 0.0, gyro_drift_s=eps_s, north_drift=eps_n)
    for rotate in (False, True):
        truth = StaticBaseTruth(rotate=rotate, drift_s=eps_s, nav_drift_n=(eps_n, 0.0, 0.0))
        _, pn, pe, _ = fly(truth, 1.0, nav=PlatformNavigator(PlatformNavigatorParams(lat_deg=40.0), hand))
        assert float(np.max(np.hypot(pn, pe))) < 0.01  # uncompensated: kilometres
        truth = StaticBaseTruth(rotate=rotate, drift_s=eps_s, nav_drift_n=(eps_n, 0.0, 0.0))
        _, pn, pe, _ = fly(truth, 1.0)
        assert float(np.max(np.hypot(pn, pe))) > 500.0


def test_misalignment_is_torqued_out_by_the_pulse():
    """A platform handed over with φ = (20″, −30″, 1000″) ENU ends the 10 s pulse with only the
    earth-rate coupling of the azimuth error during the pulse: |δφE| ≈ ω_N δφU0 T/2."""
    phi = (20.0 * ARCSEC, -30.0 * ARCSEC, 1000.0 * ARCSEC)
    T = 10.0
    p = PlatformNavigatorParams(lat_deg=40.0, misalignment_arcsec=(20.0, -30.0, 1000.0), torque_out_s=T)
    nav = PlatformNavigator(p)
    truth = StaticBaseTruth(misalignment_enu=phi)
    for k in range(int(T / DT) + 4):
        f, th = truth.sense()
        o = nav.step(k * DT_NS, f, th).output
        assert o.torquing == (k * DT < T)
        truth.step(o.command_rate_n, DT)
    res = truth.misalignment_enu() / ARCSEC
    coupling = OMEGA * math.cos(LAT) * 1000.0 * T / 2.0
    assert abs(res[0]) == pytest.approx(coupling, rel=0.2)
    assert abs(res[1]) < 0.2 and abs(res[2]) < 0.2
    print(f"residual misalignment after the pulse (E, N, U) = {res.round(3)} arcsec; ω_N δφU0 T/2 = {coupling:.3f}")


def test_hand_off_from_the_alignment_estimate():
    """The alignment's level drifts, north drift, level biases and its misalignment propagated to
    the hand-off time (what the platform must be torqued back by) are what the navigator takes."""
    x = np.array([1e-5, 2e-5, 3e-4, 4e-8, 5e-4, 6e-4, 7e-8, 8e-8])
    z3, z8 = np.zeros(3), np.zeros(8)
    est = AlignmentEstimate(t=600.0, age_s=600.0, n_updates=600, x=x, P=np.eye(8), sigma=z8,
                            misalignment0_enu=x[:3], misalignment0_sigma_enu=z3,
                            misalignment_enu=np.array([1.5e-5, 2.5e-5, 3.1e-4]), misalignment_sigma_enu=z3,
                            north_drift=4e-8, north_drift_sigma=0.0, gyro_drift_xy=x[6:8],
                            gyro_drift_sigma_xy=np.zeros(2), accel_bias_xy=x[4:6],
                            accel_bias_sigma_xy=np.zeros(2), converged=True)
    h = HandOff.from_alignment(est, LAT, 0.1, 20.0)
    assert h == HandOff(LAT, 0.1, 20.0, (0.0, 0.0, 0.0), (7e-8, 8e-8, 0.0), 4e-8, (5e-4, 6e-4, 0.0),
                        (1.5e-5, 2.5e-5, 3.1e-4))
    nav = PlatformNavigator(PlatformNavigatorParams(lat_deg=40.0), h)
    assert (nav.lat, nav.lon, nav.height, nav.vn) == (LAT, 0.1, 20.0, 0.0)


# --------------------------------------------------------------------------- command rate
def test_command_rate_is_earth_plus_transport_rate_minus_drift_closed_form():
    lat, h, v = math.radians(40.0), 500.0, (120.0, -80.0, 3.0)
    eps_s, eps_n, psi = np.array([0.02, -0.01, 0.005]) * DEG_H, 0.004 * DEG_H, math.radians(30.0)
    nav = PlatformNavigator(PlatformNavigatorParams(lat_deg=40.0, height_m=h),
                            HandOff(lat, 0.2, h, velocity_n=v, gyro_drift_s=tuple(eps_s), north_drift=eps_n))
    out = nav.step(10**18, (0.0, 0.0, -gravity(lat)), psi).output
    rm, rn = radii(lat)
    earth = OMEGA * np.array([math.cos(lat), 0.0, -math.sin(lat)])
    transport = np.array([v[1] / (rn + h), -v[0] / (rm + h), -v[1] * math.tan(lat) / (rn + h)])
    drift_n = Rotation.from_euler("z", psi).apply(eps_s) + np.array([eps_n, 0.0, 0.0])
    np.testing.assert_allclose(out.command_rate_n, earth + transport - drift_n, rtol=0, atol=1e-15)
    assert out.velocity_n == v and (out.lat, out.lon, out.height) == (lat, 0.2, h)


# --------------------------------------------------------------------------- bad input
def test_bad_input_is_counted_and_never_integrated():
    g = gravity(LAT)
    good = [(k * DT_NS, (1e-3, -2e-3, -g), 0.1 * k) for k in range(6)]
    ref = PlatformNavigator(PlatformNavigatorParams(lat_deg=40.0))
    for s in good:
        expected = ref.step(*s).output
    nav = PlatformNavigator(PlatformNavigatorParams(lat_deg=40.0))
    bad = [
        (2 * DT_NS + 1, (math.nan, 0.0, -g), 0.0),       # NaN specific force
        (2 * DT_NS + 1, (0.0, math.inf, -g), 0.0),       # inf
        (2 * DT_NS + 1, (0.0, 0.0, -g), math.nan),       # NaN resolver
        (2 * DT_NS + 1, (0.0, 0.0, -g), None),           # missing resolver
    ]  # repeated and late stamps: the input policy's to drop (test_platform_navigator_node)
    for s in good[:3]:
        nav.step(*s)
    for s in bad:
        fed = nav.step(*s)
        assert not fed.used and fed.output is None and fed.why
    for s in good[3:]:
        out = nav.step(*s).output
    assert out == expected
    assert nav.counters(2) == {"accepted": 6, "rejected_nonfinite": 3, "rejected_out_of_order": 2,
                               "rejected_no_resolver": 1, "resets": 0}


def test_a_reset_restarts_from_the_hand_off():
    """The input policy's reset on a clock jump back: the next sample, however stamped, is
    the first of a new run from the hand-off values."""
    nav = PlatformNavigator(PlatformNavigatorParams(lat_deg=40.0))
    for k in range(5):
        nav.step(10**12 + k * DT_NS, (1e-2, 0.0, -gravity(LAT)), 0.0)
    assert nav.vn > 0.0
    nav.reset("clock jumped back on imu")
    out = nav.step(10**12 - 5 * 10**9, (0.0, 0.0, -gravity(LAT)), 0.0).output
    assert nav.resets == 1 and out.velocity_n == (0.0, 0.0, 0.0) and out.torquing
    assert nav.reset_reasons == ["clock jumped back on imu"]


# --------------------------------------------------------------------------- parameters
def test_parameter_table_maps_to_the_core_and_refuses_bad_values_by_name():
    p = PlatformNavigatorParams.from_values(defaults(PARAMS))
    assert p == PlatformNavigatorParams()
    assert HandOff.from_params(p).gyro_drift_s == (0.0, 0.0, 0.0)
    assert HandOff.from_params(PlatformNavigatorParams(misalignment_arcsec=(3600.0, 0, 0))).misalignment_enu[0] \
        == pytest.approx(math.radians(1.0))
    for name, value in (("torque_out_s", 0.0), ("lat_deg", 89.5), ("gyro_drift_deg_h", [0.1, 0.2]),
                        ("vertical_tau_s", math.nan), ("accel_bias_ug", [0, 0, math.inf])):
        with pytest.raises(ParameterError, match=name):
            PlatformNavigatorParams.from_values({**defaults(PARAMS), name: value})
