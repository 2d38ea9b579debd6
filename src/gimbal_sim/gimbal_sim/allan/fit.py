"""IEEE Std 952 noise terms fitted jointly to an overlapping Allan variance (numpy, scipy, allantools).

Rate data ``y`` [u] (u = rad/s for a gyro, m/s² for an accelerometer) sampled every τ0 [s].
The Allan variance of the sum of independent noise terms is the sum of their Allan
variances (IEEE Std 952-1997, annex C), each linear in its squared coefficient::

    quantisation     3 Q² / τ²              Q [u·s]     (an angle quantum δ gives Q = δ/√12)
    white (ARW/VRW)  N² / τ                 N [u·√s]
    Gauss-Markov     σ² g(τ/T)              σ [u], correlation time T [s]
    rate random walk K² τ / 3               K [u/√s]
    rate ramp        R² τ² / 2              R [u/s]

with, for the first-order Gauss-Markov bias b' = -b/T + w of stationary RMS σ,
``g(x) = (2/x) [1 - (3 - 4e^{-x} + e^{-2x}) / (2x)]``: g → 2x/3 for x ≪ 1 (a rate random
walk of K² = 2σ²/T), g → 2/x for x ≫ 1 (white noise of N² = 2σ²T), maximum 0.3811 at
x = 1.893 (the bump a correlation time shows at τ ≈ 1.89 T). The flicker ("bias
instability") floor of IEEE 952, σ² = (2 ln 2/π) B², is reported as read off the curve:
B = min ADEV / 0.664.

The fit (:func:`fit_noise_terms`) is generalised least squares on the AVAR with non-negative
coefficients (``scipy.optimize.nnls`` on the whitened system). Neighbouring octave points of
an overlapping ADEV share data, so their errors correlate (0.5 to 0.9 between neighbours):
the first pass weights them as independent, with the variance ``2 σ⁴ / edf`` of Greenhall's
equivalent degrees of freedom (``allantools.edf_greenhall``, overlapping estimator) for the
noise type that dominates there; later passes use the full covariance of the points under
the fitted model (:mod:`.covariance`), iterated until the model settles. The correlation time
is found by minimising χ² over log T (profile). Terms are chosen by forward selection: from
none, the term whose χ² drop most exceeds the χ² quantile of ``1 - ALPHA`` for the parameters
it adds (two for the Gauss-Markov σ and T), scaled by the reduced χ² of the model with every
candidate term when above 1, is added
while one does, and only if it passes the same test with the covariance of the model without
it (the null hypothesis). A term the data do not support is reported as not detected, with
the 1σ it could have had. Uncertainties are the 1σ of the linearised fit, ``(Jᵀ C⁻¹ J)⁻¹``
over the coefficients and log T, scaled up by the reduced χ² when it exceeds 1.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import allantools
import numpy as np
from scipy.optimize import minimize_scalar, nnls
from scipy.stats import chi2 as chi2_dist

from .covariance import avar_covariance

#: Term names in column order of the design matrix.
TERMS = ("quantization", "white", "gauss_markov", "rrw", "ramp")
#: Flicker floor: σ_min = sqrt(2 ln 2 / π) B ≈ 0.664 B (IEEE Std 952, C.1.3).
FLICKER_FACTOR = math.sqrt(2.0 * math.log(2.0) / math.pi)
#: Where the Gauss-Markov Allan variance peaks: τ = GM_PEAK_X · T, value GM_PEAK_G · σ².
GM_PEAK_X = 1.8926
GM_PEAK_G = 0.38114
#: Significance of the test that keeps a term: its χ² drop must exceed the χ² quantile of
#: 1 - ALPHA for the parameters it adds.
ALPHA = 0.01
#: Added to the correlation matrix's diagonal before it is inverted (adjacent octave points
#: of a rate random walk correlate at 0.89; neighbours of neighbours higher still).
CORR_JITTER = 1e-9
#: Noise types (allantools' α for frequency data) the EDF table holds.
ALPHAS = (2, 1, 0, -1, -2)
#: A fitted correlation time within this factor of either end of its range is not identified.
TC_EDGE = 1.25
#: Correlation times an undetected Gauss-Markov term's bound is the largest 1σ over (log-spaced).
GM_BOUND_POINTS = 9


def gm_unit_avar(taus: np.ndarray, tc: float) -> np.ndarray:
    """Allan variance of a first-order Gauss-Markov process of unit stationary variance.

    ``taus`` (n,) [s], ``tc`` correlation time T [s]; returns g(τ/T) (n,) (module docstring).
    A series replaces the closed form below x = 0.05, where it cancels to round-off.
    """
    x = np.asarray(taus, dtype=float) / float(tc)
    out = np.empty_like(x)
    small = x < 0.05
    xs = x[small]
    out[small] = 2.0 * xs / 3.0 - xs**2 / 2.0 + 7.0 * xs**3 / 30.0 - xs**4 / 12.0
    xl = x[~small]
    # 3 - 4e^{-x} + e^{-2x} = expm1(-2x) - 4 expm1(-x): no cancellation of the leading 1s
    out[~small] = (2.0 / xl) * (1.0 - (np.expm1(-2.0 * xl) - 4.0 * np.expm1(-xl)) / (2.0 * xl))
    return out


def term_basis(taus: np.ndarray, tc: float | None) -> np.ndarray:
    """Design matrix (n, 5): the unit-coefficient AVAR of each term of :data:`TERMS` at ``taus``
    [s]; the Gauss-Markov column is zero when ``tc`` is None."""
    t = np.asarray(taus, dtype=float)
    gm = gm_unit_avar(t, tc) if tc is not None else np.zeros_like(t)
    return np.column_stack([3.0 / t**2, 1.0 / t, gm, t / 3.0, t**2 / 2.0])


def slope_alpha(taus: np.ndarray, avar: np.ndarray) -> np.ndarray:
    """Noise type α (allantools' convention for frequency data) whose AVAR slope matches the
    local log-log slope μ of ``avar``: α = -μ - 1 within [-2, 1], and α = 2 (white phase,
    i.e. quantisation) where μ < -1.5. A rate ramp (μ = 2) is given α = -2."""
    lt, la = np.log(taus), np.log(np.maximum(avar, 1e-300))
    mu = np.gradient(la, lt) if len(taus) > 1 else np.zeros(1)
    alpha = np.clip(np.rint(-mu - 1.0), -2, 1)
    return np.where(mu < -1.5, 2, alpha).astype(int)


@dataclass
class AllanCurve:
    """Overlapping Allan variance of one axis, pooled over the record's segments.

    ``taus`` (n,) [s]; ``avar`` (n,) [u²]; ``terms`` (n,) the number of second differences
    summed at each τ; ``edf`` maps α of :data:`ALPHAS` to the (n,) equivalent degrees of
    freedom (summed over segments, which are independent); ``tau0`` [s]; ``n_samples``;
    ``segment_lengths``: the samples of each segment.
    """

    taus: np.ndarray
    avar: np.ndarray
    terms: np.ndarray
    edf: dict[int, np.ndarray]
    tau0: float
    n_samples: int
    segment_lengths: list[int] = field(default_factory=list)

    @property
    def adev(self) -> np.ndarray:
        return np.sqrt(self.avar)

    def edf_for(self, alpha: np.ndarray) -> np.ndarray:
        """EDF at each τ for the noise type ``alpha`` (n,) there."""
        return np.array([self.edf[int(a)][i] for i, a in enumerate(alpha)])

    def interval(self, alpha: np.ndarray, ci: float = 0.6827) -> tuple[np.ndarray, np.ndarray]:
        """(low, high) ADEV confidence interval at each τ (chi-square, allantools)."""
        edf = self.edf_for(alpha)
        lo, hi = zip(*(allantools.confidence_interval(d, e, ci=ci) for d, e in zip(self.adev, edf)))
        return np.array(lo), np.array(hi)


def _edf(alpha: int, m: int, n_phase: int) -> float:
    try:
        return float(allantools.edf_greenhall(alpha, 2, m, n_phase, overlapping=True))
    except NotImplementedError:
        # Greenhall's white-phase case has no formula for the last few m; white frequency's
        # EDF is the nearest conservative stand-in there.
        return float(allantools.edf_greenhall(0, 2, m, n_phase, overlapping=True))


def allan_curve(segments: list[np.ndarray], tau0: float, tau_max: float) -> AllanCurve:
    """Pooled overlapping Allan variance at octave τ = 2^k τ0 ≤ ``tau_max``.

    ``segments``: contiguous, evenly sampled pieces of one axis (each (n_s,) [u]), e.g. a
    record split at its gaps. Each τ pools the squared second differences of every segment
    long enough for it (at least 2m + 1 samples), weighted by their count.
    """
    if tau0 <= 0.0 or not math.isfinite(tau0):
        raise ValueError(f"tau0 must be > 0, got {tau0}")
    ms = []
    m = 1
    while m * tau0 <= tau_max * (1.0 + 1e-9):
        ms.append(m)
        m *= 2
    rate = 1.0 / tau0
    sums = np.zeros(len(ms))
    counts = np.zeros(len(ms))
    edf = {a: np.zeros(len(ms)) for a in ALPHAS}
    for seg in segments:
        seg = np.asarray(seg, dtype=float)
        usable = [m for m in ms if len(seg) >= 2 * m + 1]
        if not usable:
            continue
        taus_s, dev, _, ns = allantools.oadev(seg, rate=rate, data_type="freq",
                                              taus=np.array(usable, dtype=float) * tau0)
        for t, d, n in zip(taus_s, dev, ns):
            i = ms.index(int(round(t / tau0)))
            sums[i] += d * d * n
            counts[i] += n
            for a in ALPHAS:
                edf[a][i] += _edf(a, ms[i], len(seg) + 1)
    keep = counts > 0
    if keep.sum() < 3:
        raise ValueError("fewer than 3 octave τ values have data: the record is too short")
    return AllanCurve(taus=np.array(ms, dtype=float)[keep] * tau0, avar=sums[keep] / counts[keep],
                      terms=counts[keep], edf={a: v[keep] for a, v in edf.items()}, tau0=tau0,
                      n_samples=int(sum(len(s) for s in segments)),
                      segment_lengths=[len(s) for s in segments])


@dataclass
class TermEstimate:
    """A fitted coefficient [SI] and its 1σ; ``detected`` False means the fit dropped it and
    ``sigma`` is what it could have been (the term at 0 with the others kept)."""

    value: float
    sigma: float
    detected: bool


@dataclass
class NoiseFit:
    """Result of :func:`fit_noise_terms`; every value in SI (u = unit of the rate data).

    ``terms``: quantization Q [u·s], white N [u·√s], gauss_markov σ [u], rrw K [u/√s],
    ramp R [u/s]; ``tc``/``tc_sigma``: Gauss-Markov correlation time and its 1σ [s] (None
    when no Gauss-Markov term was detected); ``flicker_floor``: B = min ADEV / 0.664 [u] at
    ``flicker_tau`` [s], with ``flicker_sigma`` from the ADEV confidence interval there.
    ``model``: fitted total AVAR at the curve's τ; ``alpha``: noise type used per τ.
    """

    terms: dict[str, TermEstimate]
    tc: float | None
    tc_sigma: float | None
    flicker_floor: float
    flicker_sigma: float
    flicker_tau: float
    chi2: float
    dof: int
    model: np.ndarray
    alpha: np.ndarray
    coefficients: np.ndarray = field(repr=False)

    def term_avar(self, taus: np.ndarray) -> dict[str, np.ndarray]:
        """Each detected term's AVAR at ``taus`` [s] (for the plot)."""
        basis = term_basis(np.asarray(taus, dtype=float), self.tc)
        return {name: basis[:, j] * self.coefficients[j] for j, name in enumerate(TERMS)
                if self.terms[name].detected}

    def total_avar(self, taus: np.ndarray) -> np.ndarray:
        return term_basis(np.asarray(taus, dtype=float), self.tc) @ self.coefficients


def _solve(A: np.ndarray, y: np.ndarray, wh: np.ndarray, cols: list[int]) -> tuple[np.ndarray, float]:
    """NNLS of ``y ≈ A[:, cols] c`` whitened by ``wh`` (n, n): χ² = |wh (y - A c)|²; returns the
    full coefficient vector and χ²."""
    c = np.zeros(A.shape[1])
    if cols:
        B = wh @ A[:, cols]
        scale = np.linalg.norm(B, axis=0)
        scale[scale == 0.0] = 1.0
        sol, _ = nnls(B / scale, wh @ y, maxiter=50 * len(cols))
        c[cols] = sol / scale
    r = wh @ (y - A @ c)
    return c, float(r @ r)


def _best_tc(taus, y, wh, cols, tc_bounds) -> tuple[float, np.ndarray, float]:
    """Gauss-Markov correlation time minimising χ² (grid, then bounded refinement on log T)."""
    lo, hi = (math.log(b) for b in tc_bounds)

    def chi2(log_tc: float) -> float:
        return _solve(term_basis(taus, math.exp(log_tc)), y, wh, cols)[1]

    grid = np.linspace(lo, hi, 48)
    values = [chi2(g) for g in grid]
    k = int(np.argmin(values))
    a, b = grid[max(k - 1, 0)], grid[min(k + 1, len(grid) - 1)]
    res = minimize_scalar(chi2, bounds=(a, b), method="bounded", options={"xatol": 1e-4})
    log_tc = float(res.x) if res.fun <= values[k] else float(grid[k])
    c, x2 = _solve(term_basis(taus, math.exp(log_tc)), y, wh, cols)
    return math.exp(log_tc), c, x2


def _fit_cols(curve: AllanCurve, wh: np.ndarray, cols: list[int], tc_bounds) -> tuple[float | None, np.ndarray, float]:
    if 2 in cols:
        tc, c, x2 = _best_tc(curve.taus, curve.avar, wh, cols, tc_bounds)
        # A correlation time at an edge of its range is not identified: at the long end the
        # term is a rate random walk, at the short end white noise, which the other columns
        # already are. The Gauss-Markov term is then left out.
        if tc_bounds[0] * TC_EDGE < tc < tc_bounds[1] / TC_EDGE:
            return tc, c, x2
        cols = [k for k in cols if k != 2]
    c, x2 = _solve(term_basis(curve.taus, None), curve.avar, wh, cols)
    return None, c, x2


def fit_noise_terms(curve: AllanCurve, terms: tuple[str, ...] = TERMS, iterations: int = 8) -> NoiseFit:
    """Fit the IEEE 952 terms named in ``terms`` to ``curve`` jointly (module docstring)."""
    unknown = set(terms) - set(TERMS)
    if unknown:
        raise ValueError(f"unknown terms {sorted(unknown)}; known: {list(TERMS)}")
    taus, y = curve.taus, curve.avar
    n = len(taus)
    if not np.any(y > 0.0):
        return dead_fit(curve)
    # A correlation time is identifiable only if its bump (1.89 T) and some roll-off past it
    # lie inside the curve; a longer one is indistinguishable from rate random walk.
    tc_bounds = (curve.tau0, taus[-1] / 4.0)
    cols = [TERMS.index(t) for t in terms]
    if tc_bounds[1] <= tc_bounds[0] * 2.0 and 2 in cols:
        cols.remove(2)
    alpha = np.zeros(n, dtype=int)
    model = y.copy()
    # first weights: independent points of Greenhall's EDF; then the model's full covariance
    wh = np.diag(np.sqrt(curve.edf_for(alpha) / (2.0 * np.maximum(model, 1e-6 * y.max()) ** 2)))
    for _ in range(iterations):
        active, tc, c = _select(curve, wh, cols, tc_bounds)
        new_model = term_basis(taus, tc) @ c
        new_alpha = slope_alpha(taus, new_model)
        done = np.allclose(new_model, model, rtol=1e-4, atol=0.0) and np.array_equal(new_alpha, alpha)
        model, alpha = new_model, new_alpha
        if done:
            break
        wh = _whitening(curve, c, tc, model)
    return _finish(curve, tc, c, active, wh, alpha, model, tc_bounds if 2 in cols else None)


def dead_fit(curve: AllanCurve) -> NoiseFit:
    """An output that never changes (every Allan variance 0): no term is detected, and none
    could have been (bound 0)."""
    n = len(curve.taus)
    zero = np.zeros(n)
    return NoiseFit(terms={t: TermEstimate(0.0, 0.0, False) for t in TERMS}, tc=None, tc_sigma=None,
                    flicker_floor=0.0, flicker_sigma=0.0, flicker_tau=float(curve.taus[0]), chi2=0.0, dof=max(n, 1),
                    model=zero, alpha=np.zeros(n, dtype=int), coefficients=np.zeros(len(TERMS)))


def term_dof(j: int) -> int:
    """Parameters a term adds: the Gauss-Markov term its σ and its correlation time."""
    return 2 if TERMS[j] == "gauss_markov" else 1


def _select(curve: AllanCurve, wh, cols: list[int], tc_bounds) -> tuple[list[int], float | None, np.ndarray]:
    """Forward selection: from no term, add the candidate whose χ² drop exceeds its threshold
    (:func:`drop_threshold`, times :func:`_misfit_scale`) by the
    most among those that also pass the test under the null, while one does (module
    docstring).
    Adding, not removing: terms that mimic another together (a ramp and a long correlation
    time look like a rate random walk over a short record) are never both needed."""
    active: list[int] = []
    tc, c, x2 = None, np.zeros(len(TERMS)), _solve(term_basis(curve.taus, None), curve.avar, wh, [])[1]
    scale = _misfit_scale(curve, wh, cols, tc_bounds)
    while True:
        trials = []
        for j in (k for k in cols if k not in active):
            tc_j, c_j, x2_j = _fit_cols(curve, wh, sorted(active + [j]), tc_bounds)
            if j == 2 and tc_j is None:
                continue  # no identifiable correlation time: nothing new
            trials.append(((x2 - x2_j) / scale - drop_threshold(j), j, tc_j, c_j, x2_j))
        # the best candidate that passes both tests; none: the model is complete
        passing = (t for t in sorted(trials, key=lambda t: -t[0])
                   if t[0] > 0.0 and _supported_under_null(curve, cols, sorted(active + [t[1]]), t[1], tc, c,
                                                           tc_bounds))
        best = next(passing, None)
        if best is None:
            break
        _, j, tc, c, x2 = best
        active = sorted(active + [j])
    return active, tc, c


def _misfit_scale(curve: AllanCurve, wh, cols: list[int], tc_bounds) -> float:
    """The reduced χ² of the model with every candidate term, when above 1: the misfit no
    selection can remove (a smaller model's would count a missing term as noise)."""
    x2 = _fit_cols(curve, wh, cols, tc_bounds)[2]
    return max(1.0, x2 / max(len(curve.taus) - sum(term_dof(k) for k in cols), 1))


def _supported_under_null(curve: AllanCurve, cols: list[int], active: list[int], j: int, tc_r, c_r,
                          tc_bounds) -> bool:
    """Term ``j`` still passes the test when the points' covariance is that of the model without
    it (the null hypothesis): a covariance that already holds the term would weight the τ where
    it shows as better known, and so argue for it. The first term has no null model to test."""
    if not np.any(c_r > 0.0):
        return True
    wh0 = _whitening(curve, c_r, tc_r, term_basis(curve.taus, tc_r) @ c_r)
    _, _, x2_with = _fit_cols(curve, wh0, active, tc_bounds)
    _, _, x2_without = _fit_cols(curve, wh0, [k for k in active if k != j], tc_bounds)
    return x2_without - x2_with >= drop_threshold(j) * _misfit_scale(curve, wh0, cols, tc_bounds)


def drop_threshold(j: int) -> float:
    """χ² rise below which term ``j`` is not supported by the data."""
    return float(chi2_dist.ppf(1.0 - ALPHA, term_dof(j)))


def _whitening(curve: AllanCurve, c: np.ndarray, tc: float | None, model: np.ndarray) -> np.ndarray:
    """``wh`` with whᵀwh = C⁻¹, C the covariance of the curve's points under the fitted model
    (:mod:`.covariance`)."""
    coeffs = {name: math.sqrt(c[j]) for j, name in enumerate(TERMS) if c[j] > 0.0}
    ms = [int(round(t / curve.tau0)) for t in curve.taus]
    cov = avar_covariance(curve.segment_lengths, ms, curve.tau0, coeffs, tc)
    d = np.sqrt(np.diag(cov))
    if not np.all(d > 0.0):
        return np.diag(1.0 / np.maximum(model, 1e-300))
    corr = cov / np.outer(d, d) + CORR_JITTER * np.eye(len(d))
    return np.linalg.inv(np.linalg.cholesky(corr)) / d[None, :]


def _gm_grid(tc_bounds) -> np.ndarray:
    """The correlation times an undetected Gauss-Markov term is bounded over: those the fit
    could have identified (inside ``tc_bounds``, off its edges); empty if there are none."""
    if tc_bounds is None or tc_bounds[1] / TC_EDGE <= tc_bounds[0] * TC_EDGE:
        return np.array([])
    return np.geomspace(tc_bounds[0] * TC_EDGE, tc_bounds[1] / TC_EDGE, GM_BOUND_POINTS)


def _finish(curve: AllanCurve, tc, c, active, wh, alpha, model, tc_bounds=None) -> NoiseFit:
    taus, y = curve.taus, curve.avar
    active = [j for j in active if c[j] > 0.0]
    if 2 not in active:
        tc = None
    dof = max(len(taus) - len(active) - (1 if tc is not None else 0), 1)
    r = wh @ (y - model)
    chi2 = float(r @ r)
    scale = max(1.0, chi2 / dof)
    basis = term_basis(taus, tc if tc is not None else 1.0)

    def covariance(cols: list[int], basis: np.ndarray = basis) -> np.ndarray:
        J = [basis[:, j] for j in cols]
        if tc is not None:
            h = 1e-4  # numeric ∂model/∂log T
            dg = (gm_unit_avar(taus, tc * math.exp(h)) - gm_unit_avar(taus, tc * math.exp(-h))) / (2 * h)
            J.append(dg * c[2])
        J = np.column_stack(J)
        # columns differ by many orders of magnitude: invert the normalised information matrix
        Jw = wh @ J
        d = np.linalg.norm(Jw, axis=0)
        d[d == 0.0] = 1.0
        Jn = Jw / d
        return np.linalg.pinv(Jn.T @ Jn) / np.outer(d, d) * scale

    cov = covariance(active)
    out: dict[str, TermEstimate] = {}
    for j, name in enumerate(TERMS):
        if j in active:
            var_c = cov[active.index(j), active.index(j)]
            amp = math.sqrt(c[j])
            out[name] = TermEstimate(amp, math.sqrt(max(var_c, 0.0)) / (2.0 * amp), True)
        else:
            cols_j = sorted(active + [j])
            if j == 2 and tc is None:
                # no fitted correlation time: the largest 1σ over every one the fit could have
                # identified (a Gauss-Markov term of any such T below the bound goes unseen);
                # NaN when the τ range identifies none
                grid = _gm_grid(tc_bounds)
                sig = max((math.sqrt(max(float(covariance(cols_j, term_basis(taus, t))[cols_j.index(j),
                                                                                     cols_j.index(j)]), 0.0))
                           for t in grid), default=float("nan"))
            else:
                sig = math.sqrt(max(covariance(cols_j)[cols_j.index(j), cols_j.index(j)], 0.0))
            out[name] = TermEstimate(0.0, math.sqrt(sig), False)
    tc_sigma = math.sqrt(max(cov[-1, -1], 0.0)) * tc if tc is not None else None
    adev = np.sqrt(y)
    k = int(np.argmin(adev))
    lo, hi = curve.interval(alpha)
    return NoiseFit(terms=out, tc=tc, tc_sigma=tc_sigma, flicker_floor=float(adev[k] / FLICKER_FACTOR),
                    flicker_sigma=float((hi[k] - lo[k]) / 2.0 / FLICKER_FACTOR), flicker_tau=float(taus[k]),
                    chi2=chi2, dof=dof, model=model, alpha=alpha, coefficients=c.copy())
