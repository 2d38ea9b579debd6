"""One log-log figure per axis: the measured ADEV with its confidence band, the fitted total,
and each fitted term as its own line with its value (and 1σ) in the legend."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..figures import pyplot, save
from .analyze import AxisResult, Characterisation, UNITS
from .fit import FLICKER_FACTOR

_COLORS = {"quantization": "tab:purple", "white": "tab:blue", "gauss_markov": "tab:orange", "rrw": "tab:red",
           "ramp": "tab:brown"}
_LABELS = {"quantization": "quantisation Q", "white": "random walk N", "gauss_markov": "Gauss-Markov σ",
           "rrw": "rate random walk K", "ramp": "ramp R"}


def _value_text(value: float, sigma: float, unit: str) -> str:
    return f"{value:.4g} ± {sigma:.2g} {unit}"


def plot_axis(result: Characterisation, res: AxisResult, path: Path) -> Path:
    """Write the figure of one axis to ``path`` (PNG); returns it."""
    plt = pyplot()
    units = UNITS[result.field]
    scale = units["adev"].per_si
    curve, fit = res.curve, res.fit
    taus = curve.taus
    fine = np.geomspace(taus[0], taus[-1], 200)
    lo, hi = curve.interval(fit.alpha)
    fig, ax = plt.subplots(figsize=(8.0, 5.6), constrained_layout=True)
    ax.fill_between(taus, lo * scale, hi * scale, color="0.8", label="ADEV 68 % confidence (Greenhall EDF)")
    ax.loglog(taus, curve.adev * scale, "ko", ms=4, label="overlapping ADEV (allantools)")
    ax.loglog(fine, np.sqrt(fit.total_avar(fine)) * scale, "k-", lw=1.5, label="fitted total")
    for name, avar in fit.term_avar(fine).items():
        est = fit.terms[name]
        u = units[name]
        label = f"{_LABELS[name]} = {_value_text(est.value * u.per_si, est.sigma * u.per_si, u.text)}"
        if name == "gauss_markov":
            label += f", T = {fit.tc:.4g} ± {fit.tc_sigma:.2g} s"
        ax.loglog(fine, np.sqrt(avar) * scale, "--", color=_COLORS[name], lw=1.2, label=label)
    f = units["flicker"]
    ax.axhline(fit.flicker_floor * FLICKER_FACTOR * scale, color="0.5", lw=0.8, ls=":",
               label=f"floor: B = min ADEV / 0.664 = {fit.flicker_floor * f.per_si:.4g} {f.text} "
                     f"at τ = {fit.flicker_tau:.4g} s")
    ax.set_xlabel("averaging time τ [s]")
    ax.set_ylabel(f"Allan deviation [{units['adev'].text}]")
    ax.set_title(f"{result.topic} {result.field}.{res.axis}: {result.duration_s / 3600.0:.3g} h at "
                 f"{result.sample_rate_hz:.4g} Hz")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7, loc="best")
    save(fig, path)
    return path


def plot_all(result: Characterisation, out_dir: Path) -> list[Path]:
    """One PNG per analysed axis, ``adev_<axis>.png`` in ``out_dir``."""
    return [plot_axis(result, res, Path(out_dir) / f"adev_{axis}.png") for axis, res in result.axes.items()]
