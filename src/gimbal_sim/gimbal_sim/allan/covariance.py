"""Covariance between the overlapping Allan variance estimates of one curve, for a noise model.

Octave points of an overlapping Allan variance share data (a τ = 2m τ0 difference contains
the m τ0 ones), so their errors are correlated; weighting them as independent makes χ² count
one excursion of the record several times, which is how a spurious Gauss-Markov bump gets
"detected". This module gives the full covariance for the model the fit has reached, so the
fit can use generalised least squares.

For rate data ``y`` sampled every τ0, the estimate at τ = m τ0 is
``σ̂²(m) = 1/(2n) Σ_k d_m(k)²`` with ``d_m(k)`` the difference of two adjacent m-sample means
(allantools' ``oadev``: n = N + 1 - 2m terms). Each noise term is a linear filter of white
innovations of variance ``q``, so ``d_m(k) = Σ_c g_m(c) e(k + c)`` with a filter ``g_m`` of
(almost) finite length:

    white (N)           y = e,                q = N²/τ0,         g = h_m
    rate random walk K  y = Σ e,              q = K² τ0,         g = reverse cumulative sum of h_m
    quantisation Q      y = (x_k - x_{k-1})/τ0, x white of Q²:   q = Q²/τ0², g = h_m * [1, -1]
    Gauss-Markov σ, T   y = φ y + e, φ = e^{-τ0/T}, q = σ²(1-φ²), g = h_m * φ^j (truncated)

with ``h_m`` = (-1/m, ..., -1/m, 1/m, ..., 1/m) (2m taps). A rate ramp is deterministic and
adds no variance. For Gaussian data ``Cov(d², d'²) = 2 Cov(d, d')²``, hence

    Cov(σ̂²_i, σ̂²_j) = 1/(2 n_i n_j) Σ_δ r_ij(δ)² · #{k, l : l - k = δ},
    r_ij(δ) = Σ_terms q Σ_c g_i(c) g_j(c - δ).

The diagonal reproduces Greenhall's EDF (``Var = 2σ⁴/edf``); the test checks it against
``allantools.edf_greenhall``. Segments of a record split at gaps are independent and pooled
with the counts :func:`.fit.allan_curve` uses.
"""
from __future__ import annotations

import math

import numpy as np
from scipy.signal import fftconvolve

#: A Gauss-Markov filter is cut where φ^j falls below this.
GM_TAIL = 1e-4


def _h(m: int) -> np.ndarray:
    return np.concatenate([np.full(m, -1.0 / m), np.full(m, 1.0 / m)])


def _filters(m: int, tau0: float, coeffs: dict[str, float], tc: float | None) -> list[tuple[float, np.ndarray]]:
    """(q, g_m) of each term with a non-zero coefficient (module docstring)."""
    h = _h(m)
    out = []
    if coeffs.get("white", 0.0) > 0.0:
        out.append((coeffs["white"] ** 2 / tau0, h))
    if coeffs.get("rrw", 0.0) > 0.0:
        out.append((coeffs["rrw"] ** 2 * tau0, np.cumsum(h[::-1])[::-1][1:]))
    if coeffs.get("quantization", 0.0) > 0.0:
        out.append((coeffs["quantization"] ** 2 / tau0**2, np.convolve(h, [1.0, -1.0])))
    if coeffs.get("gauss_markov", 0.0) > 0.0 and tc:
        phi = math.exp(-tau0 / tc)
        taps = int(math.ceil(math.log(GM_TAIL) / math.log(phi))) if phi > 0.0 else 1
        out.append((coeffs["gauss_markov"] ** 2 * (1.0 - phi * phi), fftconvolve(h, phi ** np.arange(taps))))
    return out


def _pair_sum(fi, fj, n_i: int, n_j: int) -> float:
    """Σ_δ r_ij(δ)² · count(δ) for one segment (module docstring)."""
    len_i = max(len(g) for _, g in fi)
    len_j = max(len(g) for _, g in fj)
    r = np.zeros(len_i + len_j - 1)  # index δ + len_j - 1
    for (q, gi), (_, gj) in zip(fi, fj):
        # same term at both τ: Σ_c g_i(c) g_j(c - δ) is the cross-correlation
        z = fftconvolve(gi, gj[::-1])
        start = (len_j - 1) - (len(gj) - 1)
        r[start:start + len(z)] += q * z
    delta = np.arange(len(r)) - (len_j - 1)
    count = np.clip(np.minimum(n_i, n_j - delta) - np.maximum(0, -delta), 0, None)
    return float(np.sum(r * r * count))


def avar_covariance(segment_lengths: list[int], ms: list[int], tau0: float, coeffs: dict[str, float],
                    tc: float | None) -> np.ndarray:
    """(n, n) covariance of the pooled overlapping AVAR at the octave factors ``ms`` for the model
    ``coeffs`` (term name -> SI coefficient as in :data:`.fit.TERMS`; ``tc`` [s]).

    ``segment_lengths``: the samples in each evenly sampled segment; a segment contributes to
    the τ it is long enough for (2m + 1 samples), as in the pooled curve.
    """
    k = len(ms)
    total = np.zeros((k, k))
    counts = np.zeros(k)
    for length in segment_lengths:
        n_terms = [length + 1 - 2 * m if length >= 2 * m + 1 else 0 for m in ms]
        counts += n_terms
        filters = [_filters(m, tau0, coeffs, tc) if n else None for m, n in zip(ms, n_terms)]
        for i in range(k):
            for j in range(i, k):
                if filters[i] and filters[j]:
                    # each segment's Σ d² : Cov = 2 Σ_δ r² count, pooled by the summed counts below
                    c = 2.0 * _pair_sum(filters[i], filters[j], n_terms[i], n_terms[j])
                    total[i, j] += c
                    total[j, i] = total[i, j]
    # σ̂² = Σ d² / (2 Σ n): divide by (2 N_i)(2 N_j)
    norm = 2.0 * np.maximum(counts, 1.0)
    return total / np.outer(norm, norm)
