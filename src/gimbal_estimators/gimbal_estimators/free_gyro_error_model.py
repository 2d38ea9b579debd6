"""Linear error model of the free-gyro positioning and directional system (paper 4 §3).

Paper 4 derives (i) the attitude-error dynamics of the gyro and body frames (eq. 8–21),
(ii) the perturbation of the nadir angle and the heading along the mechanisation
(eq. 22–29) and (iii) the position error through the perturbation matrix W and FDOP
(eq. 30–38). This module is that model, mapped onto the project's mechanisation
(:mod:`gimbal_estimators.free_gyro_positioning`) and the error sources its sensor simulates:
the body triad's constant bias, the vertical reference's constant levelling error, the
spin axes' constant drift, the pickoff noise and the triad's angle random walk.

Symbols and signs (paper)
-------------------------
δ(·) = computed − true (eq. 13). ξ: gyro-frame attitude error, Ĉ_g^b = (I − Ξ) C_g^b
(eq. 8), resolved in b. γ: body attitude error, Ĉ_b^n = (I − Γ) C_b^n (eq. 20–21), in n.
A computed vector is then v̂ = v − (error angle) × v.

1. Attitude-error dynamics (eq. 16–20), re-derived from eq. 8–18 (the OCR of eq. 19–20 is
   garbled; the derivation gives the form below)::

       ξ̇ = −ω_ib^b × ξ − C_g^b δω_ig^g + δω_ib^b        (eq. 19)
       γ̇ = −ω_in^n × γ − C_b^n δω_ib^b + δω_in^n        (eq. 20)

   The paper leaves the gyro frame's orientation about the spin axis open; we take g ≡ i
   (the nominal gyro frame of an ideal free gyro is inertially fixed), so δω_ig^g is the
   spin-axis drift resolved in i: the computed axis is held fixed while the true one drifts
   at d, δω_ig = −d. :func:`propagate_attitude_error` integrates both equations with the
   inputs held constant (random constants). The spin axis in n is C_b^n C_g^b u^g, so its
   error angle is η = γ + C_b^n ξ, and eq. 19 + 20 give

       η̇ = −ω_in^n × η + δω_in^n − C_g^n δω_ig^g,

   in which the triad error δω_ib^b cancels: the nadir angle does not depend on the triad
   when C_b^n and C_g^b are both computed from it. For a constant drift and δω_in^n = 0 it
   is η(t) = C_i^n ε(t), ε = d (t − t_set): :func:`spin_drift_error_cov_i`.

2. Nadir and heading chain (eq. 22–29). Eq. 22–26 perturb the spin-axis rate and integrate
   the tilting rate's error into δθ; with angle pickoffs those integrals telescope, so we
   perturb the angles themselves. For an error angle η (any frame whose third axis is down,
   azimuth α of the axis in it, nadir angle θ)::

       δθ = η_1 sin α − η_2 cos α,       δα = −η_3 + cot θ (η_1 cos α + η_2 sin α),

   the integrals of eq. 25 and eq. 23 (their sign conventions are not legible; these are
   checked against the nonlinear geometry in the tests). A displacement of the site by
   north/east arcs (δN, δE) turns NED by ρ = (δE, −δN, −tan φ δE) (the position part of
   δω_in^n after eq. 21), which gives eq. 31's rows δθ = cos α δN + sin α δE and
   δα = tan φ δE + cot θ (cos α δE − sin α δN).

   In the project the spin axes are read by angle pickoffs in the body and levelled by an
   external vertical reference (roll, pitch), not by an attitude integrated from the triad:
   the levelling error γ is the reference's, constant, and the triad reaches only the
   earth-rate heading (eq. 3–4, 29, :func:`gimbal_kinematics.maths.free_gyro.heading_error`).
   The fix solves θ(û_i, x̂) = θ_measured with the nominal spin axes û_i: a drift enters as
   eq. 30's gyro-vector error δu (nominal − true = −η × u), a levelling error as an error
   of the measured θ. The free-gyro heading is ψ = α − ζ (Fig. 4), combined over the two
   gyros with weights sin²θ as the core does.

   Earth-rate heading (eq. 3–4, 27–29): δψ = (ω_ly δω_lx − ω_lx δω_ly)/(ω_lx² + ω_ly²) of
   the levelled rate averaged over the heading window, whose error is the triad error plus
   the levelling error turning the levelled rate (eq. 28's −Γ C_b^n ω_b). The core removes
   the level rates but not the yaw rate, so that ω holds the earth rate and the ship's mean
   yaw rate over the window: a levelling error couples the yaw rate into the heading
   (:func:`earth_rate_heading_jacobian`). White triad noise averages to (N/√T)/(Ω cos φ).

3. Position (eq. 30–38): W δx = e_θ with W from
   :func:`gimbal_kinematics.maths.free_gyro.fix_geometry`. The paper assumes i.i.d. nadir errors
   (eq. 34) to get cov = σ² (WᵀW)⁻¹ and fd = FDOP σ (eq. 38). A levelling error is common
   to both gyros and correlates their nadir errors; the model carries the full
   cov = W⁻¹ Σ_θ W⁻ᵀ and reports eq. 38's FDOP σ_θ beside it. The paper's "about 0.63" for
   the FDOP circle (after eq. 38) is 1 − e⁻¹: for a circular distribution FDOP σ = drms =
   √2 σ per axis (:func:`fdop_circle_probability`).

The drifting free gyro and the rate sensors (paper 4's closing section, §2.3). The spin-axis
error η's i-frame part ε is a sum of independent vectors ⊥ u, each isotropic in that plane, so
its covariance is a scalar times (I − u uᵀ) (:func:`spin_axis_error_variance`):

* uncaging error c, a random constant: σ_c²;
* constant drift d: (σ_d t)²;
* first-order Gauss–Markov drift rate (σ_m, τ), stationary from t = 0: the variance of its
  integral, 2 σ_m² τ² (t/τ − 1 + e^{−t/τ}) (σ_m² t² for t ≪ τ, 2 σ_m² τ t for t ≫ τ);
* the spin-axis rate sensors' integrated white noise N, a random walk: N² t per axis at one
  read-out, and over a fix window of n read-outs Δt apart, the variance of the window mean,
  N² (t_first + Δt (n − 1)(2n − 1)/(6n)) (≈ N² (t̄ − T/6)), since the fix uses the window mean.

Eq. 19 carries each alike: a drift turns the true axis (the fix's nominal axis errs, eq. 30's
δu), a read-out error turns the measured one (eq. 22–26's δθ); the two maps differ only in
sign, and the covariance does not see the sign. The gimbal-lock suppression is not a random
input: where it acts it precesses the axis away from the outer gimbal axis, a bias
(:func:`suppression_spin_error_i`, from the ship's attitude history).

Not modelled: the clock error δt of eq. 30; the velocity/position feedback δω_in^n of
eq. 20 (kept as an input of the dynamics, zero in the fix map); white levelling noise; the
attitude's variation within a window (the map is taken at the window-mean attitude, and
only the mean yaw rate of the ship's rates enters the earth-rate heading).

SI inside (rad, rad/s, s, m); the error sources' σ in °/h, ″ and °/√h at the edge.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, NamedTuple

import numpy as np
from scipy.integrate import quad
from scipy.special import erf

from gimbal_kinematics.maths.earth import OMEGA_IE, earth_rate_n, meridian_radius, prime_vertical_radius
from gimbal_kinematics.maths.free_gyro import (
    FixGeometry, Vector3, dcm_ni, fix_geometry, gyro_vector_n, heading_error, unit_vector)
from gimbal_kinematics.maths.rotations import dcm_from_rotation_vector, euler321_to_dcm, skew, unskew
from gimbal_kinematics.maths.units import ARCSEC, DEG_H, DEG_RT_H
from gimbal_kinematics.maths.validate import finite, nonneg_finite, of_type, positive

from gimbal_kinematics.maths.kalman import check_state, predict, symmetrize

from .free_gyro_drift import (  # noqa: F401  (the drift model's pieces, re-exported)
    gauss_markov_integral_variance, random_walk_window_time, suppression_spin_error_i, suppression_spin_rates_i)


#: Names of the outputs of :class:`FixErrorModel`, in order.
OUTPUTS = ("nadir_a", "nadir_b", "north_m", "east_m", "heading", "heading_earth_rate")
#: Names of the random-constant error inputs of :class:`FixErrorModel`, in order.
INPUTS = ("level_roll", "level_pitch", "spin_a_x", "spin_a_y", "spin_a_z", "spin_b_x", "spin_b_y", "spin_b_z",
          "triad_bias_x", "triad_bias_y", "triad_bias_z")
#: Slices and indices of :data:`OUTPUTS`: the two nadir errors, the north/east position
#: error, the free-gyro heading and the earth-rate heading.
OUT_NADIR, OUT_POSITION_NE, OUT_HEADING, OUT_HEADING_EARTH_RATE = slice(0, 2), slice(2, 4), 4, 5
#: Slices of :data:`INPUTS`: the level error (roll, pitch), each spin axis's drift error
#: (a, then b), the body triad's bias.
IN_LEVEL, IN_SPIN_A, IN_SPIN_B, IN_TRIAD_BIAS = slice(0, 2), slice(2, 5), slice(5, 8), slice(8, 11)
N_INPUTS = IN_TRIAD_BIAS.stop


def _matrix(name: str, value: object, shape: tuple[int, ...]) -> np.ndarray:
    a = np.asarray(value, dtype=float)
    if a.shape != shape:
        raise ValueError(f"{name} must have shape {shape}, got {a.shape}")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name} contains NaN or inf")
    return a


def _covariance(name: str, value: object, n: int) -> np.ndarray:
    """A (n, n) covariance: ``kalman.check_state``'s checks, and positive semi-definite."""
    _, P = check_state(np.zeros(n), value, name)
    if np.min(np.linalg.eigvalsh(symmetrize(P))) < -1e-9 * max(float(np.max(np.abs(P))), 1e-300):
        raise ValueError(f"{name}: covariance is not positive semi-definite")
    return P


# --- 1. attitude-error dynamics (eq. 8–21) ------------------------------------------------------
#: Augmented state z = [ξ_a, ξ_b, γ (states), δω_ig,a^i, δω_ig,b^i, δω_ib^b, δω_in^n (constant inputs)],
#: as slices: the two spin axes' error angles and the level frame's, then the inputs (all of
#: them: :data:`CONSTANT_INPUTS`).
XI_A, XI_B, GAMMA = slice(0, 3), slice(3, 6), slice(6, 9)
D_OMEGA_A, D_OMEGA_B, D_OMEGA_IB, D_OMEGA_IN = slice(9, 12), slice(12, 15), slice(15, 18), slice(18, 21)
CONSTANT_INPUTS = slice(D_OMEGA_A.start, D_OMEGA_IN.stop)
N_ATTITUDE = D_OMEGA_IN.stop


class AttitudeSample(NamedTuple):
    """Nominal motion at one time: ``omega_ib_b`` (3,) body inertial rate [rad/s],
    ``omega_in_n`` (3,) navigation-frame inertial rate [rad/s], ``C_bi`` (3, 3) maps i to b
    (the paper's C_g^b with g ≡ i), ``C_nb`` (3, 3) maps b to NED (the paper's C_b^n)."""

    omega_ib_b: np.ndarray
    omega_in_n: np.ndarray
    C_bi: np.ndarray
    C_nb: np.ndarray


@dataclass(frozen=True)
class AttitudeError:
    """Mean ``z`` (21,) and covariance ``P`` (21, 21) of the augmented attitude-error state
    (:data:`N_ATTITUDE`): ξ_a, ξ_b [rad] (b), γ [rad] (n), then the constant inputs δω_ig,a,
    δω_ig,b [rad/s] (i), δω_ib^b [rad/s] (b), δω_in^n [rad/s] (n)."""

    z: np.ndarray
    P: np.ndarray

    def __post_init__(self) -> None:
        object.__setattr__(self, "z", _matrix("z", self.z, (N_ATTITUDE,)))
        object.__setattr__(self, "P", _covariance("P", self.P, N_ATTITUDE))

    def spin_axis_errors_n(self, C_nb: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Error angles η_k = γ + C_b^n ξ_k (3,) [rad] of the two spin axes in NED (``C_nb``
        (3, 3) maps b to n)."""
        C = _matrix("C_nb", C_nb, (3, 3))
        return self.z[GAMMA] + C @ self.z[XI_A], self.z[GAMMA] + C @ self.z[XI_B]

    def spin_axis_error_covs_n(self, C_nb: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Covariances (3, 3) [rad²] of η_a, η_b."""
        C = _matrix("C_nb", C_nb, (3, 3))
        out = []
        for xi in (XI_A, XI_B):
            T = np.zeros((3, N_ATTITUDE))
            T[:, xi] = C
            T[:, GAMMA] = np.eye(3)
            out.append(T @ self.P @ T.T)
        return out[0], out[1]


def attitude_error_matrix(s: AttitudeSample) -> np.ndarray:
    """A (21, 21) of ż = A z (eq. 19 for each gyro, eq. 20; inputs constant)."""
    w_b = _matrix("omega_ib_b", s.omega_ib_b, (3,))
    w_n = _matrix("omega_in_n", s.omega_in_n, (3,))
    C_bi = _matrix("C_bi", s.C_bi, (3, 3))
    C_nb = _matrix("C_nb", s.C_nb, (3, 3))
    A = np.zeros((N_ATTITUDE, N_ATTITUDE))
    # eq. 19: ξ̇ = −ω_ib^b × ξ − C_g^b δω_ig^g + δω_ib^b
    for xi, d_omega in ((XI_A, D_OMEGA_A), (XI_B, D_OMEGA_B)):
        A[xi, xi] = -skew(w_b)
        A[xi, d_omega] = -C_bi
        A[xi, D_OMEGA_IB] = np.eye(3)
    A[GAMMA, GAMMA] = -skew(w_n)      # eq. 20: γ̇ = −ω_in^n × γ − C_b^n δω_ib^b + δω_in^n
    A[GAMMA, D_OMEGA_IB] = -C_nb
    A[GAMMA, D_OMEGA_IN] = np.eye(3)
    return A


def expm_augmented(Om: np.ndarray) -> np.ndarray:
    """expm of Ω = [[S, B], [0, 0]] with S block-diagonal of three skew (3, 3) blocks (the
    form of A and of its Magnus commutator): [[e^S, φ(S) B], [0, I]], each block's e^S by
    Rodrigues and φ(S) = ∫₀¹ e^{S s} ds = I + (1 − cos θ)/θ² S + (θ − sin θ)/θ³ S²."""
    Phi = np.eye(N_ATTITUDE)
    for k in (XI_A, XI_B, GAMMA):
        S = Om[k, k]
        a = unskew(S)
        t2 = float(a @ a)
        if t2 < 1e-8:
            c1, c2 = 0.5 - t2 / 24.0, 1.0 / 6.0 - t2 / 120.0
        else:
            t = math.sqrt(t2)
            c1, c2 = (1.0 - math.cos(t)) / t2, (t - math.sin(t)) / (t2 * t)
        Phi[k, k] = dcm_from_rotation_vector(a)
        Phi[k, CONSTANT_INPUTS] = (np.eye(3) + c1 * S + c2 * (S @ S)) @ Om[k, CONSTANT_INPUTS]
    return Phi


def propagate_attitude_error(state: AttitudeError, t0: float, t1: float,
                             trajectory: Callable[[float], AttitudeSample],
                             max_step_s: float = 1.0) -> AttitudeError:
    """``state`` at ``t0`` [s] propagated to ``t1`` [s] along the nominal motion
    ``trajectory(t)``: steps of at most ``max_step_s``, each z ← Φ z, P ← Φ P Φᵀ with the
    fourth-order Magnus transition Φ = exp(dt (A₁ + A₂)/2 + √3 dt² [A₂, A₁]/12), A₁, A₂ at
    the step's two Gauss points (the exponential in closed form, :func:`expm_augmented`)."""
    t0, t1 = finite("t0", t0), finite("t1", t1)
    if t1 < t0:
        raise ValueError(f"t1 must be >= t0, got {t1} < {t0}")
    n = max(1, math.ceil((t1 - t0) / positive("max_step_s", max_step_s) - 1e-9))
    dt = (t1 - t0) / n
    c = math.sqrt(3.0) / 6.0
    z, P = state.z.copy(), state.P.copy()
    for k in range(n):
        A1 = attitude_error_matrix(trajectory(t0 + (k + 0.5 - c) * dt))
        A2 = attitude_error_matrix(trajectory(t0 + (k + 0.5 + c) * dt))
        Phi = expm_augmented(0.5 * dt * (A1 + A2) + (math.sqrt(3.0) / 12.0) * dt * dt * (A2 @ A1 - A1 @ A2))
        z, P = predict(z, P, Phi, np.zeros_like(P))
    return AttitudeError(z, P)


def spin_drift_error_cov_i(u_i: Vector3, sigma_drift_rad_s: float, elapsed_s: float) -> np.ndarray:
    """Covariance (3, 3) [rad²] of a spin axis's error angle ε = d (t − t_set) in i after
    ``elapsed_s`` of a constant drift d with σ per axis ⊥ u (the sensor draws d ⊥ u):
    (σ t)² (I − u uᵀ), the solution of the η equation (module doc) for constant d."""
    u = np.array(unit_vector(u_i, "u_i"))
    s = nonneg_finite("sigma_drift_rad_s", sigma_drift_rad_s) * finite("elapsed_s", elapsed_s)
    return s * s * (np.eye(3) - np.outer(u, u))


# --- 2. nadir, azimuth and heading chain (eq. 22–29) --------------------------------------------
def nadir_azimuth_sensitivity(theta: float, azimuth: float) -> np.ndarray:
    """(2, 3) map of an error angle η (paper sign: v̂ = v − η × v; frame with third axis
    down) to (δθ, δα) of an axis at nadir angle θ and azimuth α [rad] (eq. 23–26)."""
    ca, sa = math.cos(azimuth), math.sin(azimuth)
    cot = math.cos(theta) / math.sin(theta)
    return np.array([[sa, -ca, 0.0], [cot * ca, cot * sa, -1.0]])


def level_error_angle_l(pitch: float) -> np.ndarray:
    """(3, 2) map of the vertical reference's (δroll, δpitch) [rad] to the levelling error
    angle γ [rad] in the heading-only frame l (paper sign): levelling with roll + δr,
    pitch + δp turns a vector by g = δr (cos p, 0, −sin p) + δp (0, 1, 0), and γ = −g."""
    cp, sp = math.cos(pitch), math.sin(pitch)
    return -np.array([[cp, 0.0], [0.0, 1.0], [-sp, 0.0]])


def earth_rate_heading_jacobian(lat: float, roll: float, pitch: float, heading: float,
                                yaw_rate: float = 0.0) -> np.ndarray:
    """(5,) derivatives of the earth-rate heading (eq. 3–4) with respect to (δroll, δpitch)
    [rad/rad] and the triad error δω_ib^b (3,) [rad/(rad/s)] (eq. 29, through
    :func:`gimbal_kinematics.maths.free_gyro.heading_error`).

    ``yaw_rate`` [rad/s] is the ship's mean yaw rate over the heading window: the core
    removes the level rates but not the yaw rate, which stays on the levelled vertical, and a
    levelling error Γ turns it into the horizontal (eq. 28's −Γ C_b^n ω_b term with the
    ship's rate in ω_b): δψ ≈ tilt · ψ̇ / (Ω cos φ), far above tan φ · tilt once ψ̇ ≳ Ω.
    """
    w_n = earth_rate_n(lat) + np.array([0.0, 0.0, finite("yaw_rate", yaw_rate)])
    w_b = euler321_to_dcm(roll, pitch, heading).T @ w_n
    cols = [heading_error(w_b, (0.0, 0.0, 0.0), roll, pitch, 1.0, 0.0),
            heading_error(w_b, (0.0, 0.0, 0.0), roll, pitch, 0.0, 1.0)]
    cols += [heading_error(w_b, e, roll, pitch) for e in np.eye(3)]
    return np.array(cols)


@dataclass(frozen=True)
class ErrorSources:
    """σ of the error sources, at the edge's units (validated, immutable).

    Random constants per run: ``triad_bias_deg_h`` per axis of the triad bias [°/h];
    ``level_error_arcsec`` of the vertical reference's roll and pitch errors [″];
    ``spin_drift_deg_h`` per axis ⊥ u of each spin axis's drift [°/h] (as the sensor's
    ``spin_drift_sigma_deg_h``). White: ``pickoff_noise_arcsec`` per axis per read-out [″];
    ``triad_arw_deg_rt_h`` the triad's angle random walk [°/√h]. The drifting free gyro:
    ``caging_arcsec`` per axis ⊥ u of the uncaging error [″] (random constant),
    ``gm_drift_deg_h`` and ``gm_drift_tau_s`` the Gauss–Markov drift's σ [°/h] and correlation
    time [s], ``spin_rate_arw_deg_rt_h`` the spin-axis rate sensors' angle random walk [°/√h]
    (their outputs integrated since the axes were set).
    """

    triad_bias_deg_h: float = 0.0
    level_error_arcsec: float = 0.0
    spin_drift_deg_h: float = 0.0
    pickoff_noise_arcsec: float = 0.0
    triad_arw_deg_rt_h: float = 0.0
    caging_arcsec: float = 0.0
    gm_drift_deg_h: float = 0.0
    gm_drift_tau_s: float = 300.0
    spin_rate_arw_deg_rt_h: float = 0.0

    def __post_init__(self) -> None:
        for name in ("triad_bias_deg_h", "level_error_arcsec", "spin_drift_deg_h", "pickoff_noise_arcsec",
                     "triad_arw_deg_rt_h", "caging_arcsec", "gm_drift_deg_h", "spin_rate_arw_deg_rt_h"):
            nonneg_finite(name, getattr(self, name))
        positive("gm_drift_tau_s", self.gm_drift_tau_s)

    def spin_axis_error_variance(self, elapsed_s: float, rate_walk_s: float | None = None) -> float:
        """Variance [rad²] per axis ⊥ u of a spin axis's error ``elapsed_s`` after it was set
        (module doc): uncaging + constant drift + Gauss–Markov drift + the integrated rate
        sensors' random walk over ``rate_walk_s`` (default ``elapsed_s``)."""
        t = nonneg_finite("elapsed_s", elapsed_s)
        tw = t if rate_walk_s is None else nonneg_finite("rate_walk_s", rate_walk_s)
        return ((self.caging_arcsec * ARCSEC) ** 2 + (self.spin_drift_deg_h * DEG_H * t) ** 2
                + gauss_markov_integral_variance(self.gm_drift_deg_h * DEG_H, self.gm_drift_tau_s, t)
                + (self.spin_rate_arw_deg_rt_h * DEG_RT_H) ** 2 * tw)


class ErrorPrediction(NamedTuple):
    """Predicted errors of one fix: ``cov`` (6, 6) of :data:`OUTPUTS` (nadir errors as the
    fix sees them [rad], north/east position error [m], free-gyro heading and earth-rate
    heading [rad]); ``geometry`` the fix's ``FixGeometry`` (W, FDOP, eq. 31–37) and
    ``height_m``."""

    cov: np.ndarray
    geometry: FixGeometry
    height_m: float

    @property
    def fdop(self) -> float:
        """FDOP of the geometry (eq. 37, arc form)."""
        return self.geometry.fdop

    @property
    def sigma_nadir(self) -> np.ndarray:
        """σ (2,) [rad] of θ_a, θ_b."""
        return np.sqrt(np.diag(self.cov)[OUT_NADIR])

    @property
    def nadir_correlation(self) -> float:
        """Correlation coefficient of the two nadir errors (eq. 34 assumes 0)."""
        s = self.sigma_nadir
        c = self.cov[OUT_NADIR, OUT_NADIR]
        return float(c[0, 1] / (s[0] * s[1])) if s[0] > 0.0 and s[1] > 0.0 else 0.0

    @property
    def cov_ne_m(self) -> np.ndarray:
        """Covariance (2, 2) [m²] of the north/east fix error."""
        return self.cov[OUT_POSITION_NE, OUT_POSITION_NE]

    @property
    def position_drms_m(self) -> float:
        """drms [m] = √trace of :attr:`cov_ne_m` (the model's full covariance)."""
        return math.sqrt(float(np.trace(self.cov_ne_m)))

    @property
    def position_fdop_m(self) -> float:
        """Eq. 38, fd = FDOP σ_θ [m] (``FixGeometry.position_error_m``), with σ_θ the RMS of
        the two nadir σ: equal to :attr:`position_drms_m` only for i.i.d. nadir errors."""
        return self.geometry.position_error_m(math.sqrt(float(np.mean(np.diag(self.cov)[OUT_NADIR]))), self.height_m)

    @property
    def sigma_heading(self) -> float:
        """σ [rad] of the free-gyro heading ψ = α − ζ."""
        return math.sqrt(float(self.cov[OUT_HEADING, OUT_HEADING]))

    @property
    def sigma_heading_earth_rate(self) -> float:
        """σ [rad] of the earth-rate heading (eq. 3–4)."""
        return math.sqrt(float(self.cov[OUT_HEADING_EARTH_RATE, OUT_HEADING_EARTH_RATE]))


# --- 3. the fix: sources to nadir, heading and position ---------------------------------------
class FixErrorModel:
    """First-order map of the error sources to one fix's errors (module doc, eq. 19–38).

    The nominal fix: spin axes ``u_a_i``, ``u_b_i`` (unit, inertial), true site ``lat``,
    ``lon`` [rad] and height ``height_m``, fix time ``t`` [s] (the window's mean time),
    ship attitude ``roll``, ``pitch``, ``heading`` [rad] (the window means; the ship at
    rest), ``drift_elapsed_s`` since the spin axes were set (ε = d · that),
    ``samples_per_fix`` read-outs averaged, and the earth-rate heading's window
    ``heading_window_s`` [s] and the ship's mean ``yaw_rate_rad_s`` over it. With
    ``sample_interval_s`` [s] (the read-outs' spacing) the rate sensors' random walk is taken
    over the window mean (:func:`random_walk_window_time`); 0 takes it at the fix time.

    ``H`` (6, 11) maps the random constants :data:`INPUTS` (δroll, δpitch [rad]; ε_a, ε_b
    [rad] in i; δω_ib^b [rad/s]) to :data:`OUTPUTS`; ``H_white`` (6, 4) maps one fix's
    averaged pickoff errors (nadir of a, b; horizontal of a, b) [rad].
    """

    def __init__(self, u_a_i: Vector3, u_b_i: Vector3, lat: float, lon: float, t: float, *,
                 roll: float = 0.0, pitch: float = 0.0, heading: float = 0.0, drift_elapsed_s: float = 0.0,
                 samples_per_fix: int = 1, heading_window_s: float = 60.0, yaw_rate_rad_s: float = 0.0,
                 height_m: float = 0.0, omega_ie: float = OMEGA_IE, sample_interval_s: float = 0.0) -> None:
        self.u = (np.array(unit_vector(u_a_i, "u_a_i")), np.array(unit_vector(u_b_i, "u_b_i")))
        self.sample_interval_s = nonneg_finite("sample_interval_s", sample_interval_s)
        self.lat, self.lon, self.t = finite("lat", lat), finite("lon", lon), finite("t", t)
        self.roll, self.pitch, self.heading = finite("roll", roll), finite("pitch", pitch), finite("heading", heading)
        self.drift_elapsed_s = nonneg_finite("drift_elapsed_s", drift_elapsed_s)
        if not isinstance(samples_per_fix, int) or isinstance(samples_per_fix, bool) or samples_per_fix < 1:
            raise ValueError(f"samples_per_fix must be an int >= 1, got {samples_per_fix!r}")
        self.samples_per_fix = samples_per_fix
        self.heading_window_s = positive("heading_window_s", heading_window_s)
        self.yaw_rate_rad_s = finite("yaw_rate_rad_s", yaw_rate_rad_s)
        self.height_m = finite("height_m", height_m)
        self.geometry = fix_geometry(self.u[0], self.u[1], self.lat, self.lon, self.t, omega_ie=omega_ie)
        C_ni = dcm_ni(self.lat, self.lon, self.t, omega_ie)
        u_n = [gyro_vector_n(u, self.lat, self.lon, self.t, omega_ie) for u in self.u]
        self.nadir = np.array([math.atan2(math.hypot(v[0], v[1]), v[2]) for v in u_n])
        self.azimuth = np.array([math.atan2(v[1], v[0]) for v in u_n])
        self.H, self.H_white = self._build(C_ni)

    def _position(self, e_theta: np.ndarray) -> np.ndarray:
        """(2, m) north/east arcs [rad] of nadir errors (2, m) through W (eq. 31–32)."""
        d = np.linalg.solve(self.geometry.W, e_theta)  # (δφ, δλ)
        return np.vstack([d[0], math.cos(self.lat) * d[1]])

    def _build(self, C_ni: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        th, al = self.nadir, self.azimuth
        zeta = al - self.heading
        L = level_error_angle_l(self.pitch)
        S_model = [nadir_azimuth_sensitivity(th[k], al[k]) for k in (0, 1)]   # in n, at α
        S_meas = [nadir_azimuth_sensitivity(th[k], zeta[k]) for k in (0, 1)]  # in l, at ζ
        # Random constants: e_θ = S_θ(ζ) γ_l − S_θ(α) C_ni ε (module doc §2).
        E = np.zeros((2, N_INPUTS))   # nadir errors
        Z = np.zeros((2, N_INPUTS))   # δα_model(ε) − δζ_measured(γ), per gyro, before the position term
        for k, spin in enumerate((IN_SPIN_A, IN_SPIN_B)):
            E[k, IN_LEVEL] = S_meas[k][0] @ L
            E[k, spin] = -S_model[k][0] @ C_ni
            Z[k, IN_LEVEL] = -S_meas[k][1] @ L
            Z[k, spin] = S_model[k][1] @ C_ni
        # White pickoff: nadir parts enter e_θ, horizontal parts enter ζ as n_h / sin θ.
        Ew = np.hstack([np.eye(2), np.zeros((2, 2))])
        Zw = np.hstack([np.zeros((2, 2)), -np.diag(1.0 / np.sin(th))])
        rows, rows_w = [E], [Ew]
        x, xw = self._position(E), self._position(Ew)
        rm = meridian_radius(self.lat) + self.height_m
        rn = prime_vertical_radius(self.lat) + self.height_m
        rows += [x * np.array([[rm], [rn]])]
        rows_w += [xw * np.array([[rm], [rn]])]
        # Free-gyro heading: α(û, x̂) − ζ_measured, weights sin²θ (as the core combines them).
        cot, tan_lat = np.cos(th) / np.sin(th), math.tan(self.lat)
        A = np.array([[-cot[k] * math.sin(al[k]), tan_lat + cot[k] * math.cos(al[k])] for k in (0, 1)])
        w = np.sin(th) ** 2 / np.sum(np.sin(th) ** 2)
        rows += [w @ (Z + A @ x)]
        rows_w += [w @ (Zw + A @ xw)]
        J = earth_rate_heading_jacobian(self.lat, self.roll, self.pitch, self.heading, self.yaw_rate_rad_s)
        er = np.zeros(N_INPUTS)
        er[IN_LEVEL], er[IN_TRIAD_BIAS] = J[0:2], J[2:5]
        rows += [er]
        rows_w += [np.zeros(4)]
        return np.vstack(rows), np.vstack(rows_w)

    def input_covariance(self, sources: ErrorSources) -> np.ndarray:
        """(11, 11) [rad², rad²/s²] covariance of :data:`INPUTS` for ``sources``."""
        P = np.zeros((N_INPUTS, N_INPUTS))
        P[IN_LEVEL, IN_LEVEL] = (sources.level_error_arcsec * ARCSEC) ** 2 * np.eye(2)
        t = self.drift_elapsed_s
        half = 0.5 * self.sample_interval_s * (self.samples_per_fix - 1)
        tw = random_walk_window_time(max(t - half, 0.0), self.samples_per_fix, self.sample_interval_s)
        var = sources.spin_axis_error_variance(t, tw)
        for spin, u in ((IN_SPIN_A, self.u[0]), (IN_SPIN_B, self.u[1])):
            P[spin, spin] = spin_drift_error_cov_i(u, 1.0, 1.0) * var
        P[IN_TRIAD_BIAS, IN_TRIAD_BIAS] = (sources.triad_bias_deg_h * DEG_H) ** 2 * np.eye(3)
        return P

    def predict(self, sources: ErrorSources) -> ErrorPrediction:
        """Predicted covariance of :data:`OUTPUTS` for ``sources``: H P Hᵀ + the window-averaged
        pickoff noise (σ²/n per axis) + the triad ARW on the earth-rate heading,
        (N/√T)/(Ω cos φ) (eq. 29 for white rate noise averaged over T)."""
        of_type("sources", sources, ErrorSources)
        cov = self.H @ self.input_covariance(sources) @ self.H.T
        s_pick = sources.pickoff_noise_arcsec * ARCSEC / math.sqrt(self.samples_per_fix)
        cov += s_pick**2 * self.H_white @ self.H_white.T
        arw = sources.triad_arw_deg_rt_h * DEG_RT_H
        h = OUT_HEADING_EARTH_RATE
        cov[h, h] += (arw / math.sqrt(self.heading_window_s) / (OMEGA_IE * math.cos(self.lat))) ** 2
        return ErrorPrediction(symmetrize(cov), self.geometry, self.height_m)


# --- FDOP circle (eq. 38) ------------------------------------------------------------------------
def circle_probability(P: np.ndarray, radius: float) -> float:
    """Pr(|x| ≤ ``radius``) for a 2-D Gaussian x ~ N(0, P), P (2, 2): exact.

    |x|² = λ₁ z₁² + λ₂ z₂² with the eigenvalues λ₁ ≥ λ₂ of P (a generalised χ²), so
    Pr = ∫ φ(z) erf(√((r² − λ₁ z²) / (2 λ₂))) dz over |z| ≤ r/√λ₁ (scipy ``quad``).
    """
    P = _covariance("P", P, 2)
    r = nonneg_finite("radius", radius)
    lam2, lam1 = np.clip(np.linalg.eigvalsh(P), 0.0, None)
    if lam1 == 0.0:
        return 1.0
    a = r / math.sqrt(lam1)
    if lam2 <= 1e-15 * lam1:
        return float(erf(a / math.sqrt(2.0)))

    def inner(z: float) -> float:
        return math.exp(-0.5 * z * z) * float(erf(math.sqrt(max(r * r - lam1 * z * z, 0.0) / (2.0 * lam2))))

    value, _ = quad(inner, 0.0, a, epsabs=1e-13, epsrel=1e-11, limit=200)
    return 2.0 * value / math.sqrt(2.0 * math.pi)


def fdop_circle_probability(P: np.ndarray) -> float:
    """Probability that a fix with covariance P (2, 2) lies inside the FDOP σ circle of
    eq. 38, whose radius is √trace P (= drms): 1 − e⁻¹ ≈ 0.632 for a circular P (the paper's
    "about 0.63"), up to erf(1/√2) ≈ 0.683 for a degenerate (1-D) one."""
    P = _covariance("P", P, 2)
    return circle_probability(P, math.sqrt(max(float(np.trace(P)), 0.0)))


# --- the node's prediction per fix ---------------------------------------------------------------
class FixPredictor:
    """The predicted errors of each fix of a running positioning core: the spin axes
    ``u_a_i``, ``u_b_i``, the error sources ``sources``, the spin axes' setting time
    ``t_set`` [s] (drift elapsed = fix time − t_set), ``heading_window_s`` [s] and
    ``height_m``. :meth:`add_level` takes every read-out's roll and pitch [rad];
    :meth:`predict` the model at a fix's estimated position, mean time, window-mean attitude
    and heading. The ship's yaw rate over the earth-rate window is taken as 0 (the core does
    not keep it): a levelling error's coupling of a turning ship's yaw rate is left out."""

    def __init__(self, u_a_i: Vector3, u_b_i: Vector3, sources: ErrorSources, *, t_set: float = 0.0,
                 heading_window_s: float = 60.0, height_m: float = 0.0) -> None:
        of_type("sources", sources, ErrorSources)
        self.u = (unit_vector(u_a_i, "u_a_i"), unit_vector(u_b_i, "u_b_i"))
        self.sources = sources
        self.t_set = finite("t_set", t_set)
        self.heading_window_s = positive("heading_window_s", heading_window_s)
        self.height_m = finite("height_m", height_m)
        self.clear()

    def clear(self) -> None:
        """Forget the attitude of the read-outs so far (a fix window closed, or a reset)."""
        self._sum = [0.0, 0.0, 0]

    def add_level(self, roll: float, pitch: float) -> None:
        if math.isfinite(roll) and math.isfinite(pitch):
            self._sum = [self._sum[0] + roll, self._sum[1] + pitch, self._sum[2] + 1]

    def predict(self, lat: float, lon: float, t: float, heading: float, samples: int) -> ErrorPrediction:
        """:class:`ErrorPrediction` of a fix at (``lat``, ``lon``) [rad], mean time ``t`` [s],
        heading [rad] from ``samples`` read-outs; clears the attitude sums."""
        n = max(self._sum[2], 1)
        roll, pitch = self._sum[0] / n, self._sum[1] / n
        self.clear()
        model = FixErrorModel(self.u[0], self.u[1], lat, lon, t, roll=roll, pitch=pitch, heading=heading,
                              drift_elapsed_s=max(t - self.t_set, 0.0), samples_per_fix=samples,
                              heading_window_s=self.heading_window_s, height_m=self.height_m)
        return model.predict(self.sources)


def fix_predictor(values: dict, params) -> FixPredictor | None:
    """The ``free_gyro_positioning`` node's error model of its fixes from its parameter
    ``values`` and core ``params`` (:class:`.free_gyro_positioning.FreeGyroPositioningParams`);
    None unless ``predict_error``."""
    if not values["predict_error"]:
        return None
    sources = ErrorSources(values["error_triad_bias_deg_h"], values["error_level_arcsec"],
                           values["error_spin_drift_deg_h"], params.nadir_noise_arcsec, params.triad_arw_deg_rt_h,
                           caging_arcsec=values["error_caging_arcsec"], gm_drift_deg_h=values["error_gm_drift_deg_h"],
                           gm_drift_tau_s=values["error_gm_drift_tau_s"],
                           spin_rate_arw_deg_rt_h=params.spin_rate_arw_deg_rt_h)
    return FixPredictor(params.u_a_i, params.u_b_i, sources, t_set=values["spin_reference_time_s"],
                        heading_window_s=params.heading_window_s, height_m=params.height_m)
