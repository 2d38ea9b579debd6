"""From an Imu field's samples to the fitted noise terms per axis, and their JSON form.

:func:`analyze` checks what it is given (non-finite samples, sampling, record length against
the longest τ), computes the pooled overlapping Allan variance of each axis and fits the
IEEE Std 952 terms (:mod:`.fit`). :func:`to_json` converts the SI results into the units
of the configuration edge: deg/√h, deg/h, deg/h/√h, deg, deg/h² for a gyro; SI names for
an accelerometer (m/s/√s is m/s²/√Hz).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from gimbal_kinematics.maths.units import DEG

from .fit import FLICKER_FACTOR, AllanCurve, NoiseFit, allan_curve, dead_fit, fit_noise_terms
from .stream import AXES, ImuField, Sampling, sampling

#: Non-finite samples above this fraction refuse the record.
MAX_NONFINITE_FRACTION = 0.01
#: The record must last at least this many times the longest τ.
MIN_DURATION_PER_TAU = 10.0
#: Octave τ values the fit needs at least: up to six unknowns (five coefficients and the
#: correlation time) leave four degrees of freedom.
MIN_OCTAVES = 10
#: A detected term whose 1σ exceeds this fraction of its value is flagged as not determined.
MAX_RELATIVE_SIGMA = 0.5
#: An undetected term's bound: this many of the 1σ it could have had.
BOUND_SIGMAS = 2.0


class AnalysisError(ValueError):
    """The record cannot be characterised as asked; ``option`` names the option at fault."""

    def __init__(self, message: str, option: str = "") -> None:
        super().__init__(message)
        self.option = option


@dataclass(frozen=True)
class Unit:
    """How one term is written at the edge: JSON key, unit text, factor from SI."""

    key: str
    text: str
    per_si: float


#: field -> term -> Unit. Gyro SI: rad/s; accelerometer SI: m/s².
UNITS: dict[str, dict[str, Unit]] = {
    "angular_velocity": {
        "quantization": Unit("quantization_deg", "deg", 1.0 / DEG),
        "white": Unit("arw_deg_rt_h", "deg/√h", 60.0 / DEG),
        "gauss_markov": Unit("bias_instability_deg_h", "deg/h", 3600.0 / DEG),
        "rrw": Unit("rrw_deg_h_rt_h", "deg/h/√h", 3600.0 * 60.0 / DEG),
        "ramp": Unit("rate_ramp_deg_h2", "deg/h²", 3600.0**2 / DEG),
        "flicker": Unit("flicker_floor_deg_h", "deg/h", 3600.0 / DEG),
        "adev": Unit("adev_deg_h", "deg/h", 3600.0 / DEG),
    },
    "linear_acceleration": {
        "quantization": Unit("quantization_m_s", "m/s", 1.0),
        "white": Unit("vrw_m_s2_rt_hz", "m/s²/√Hz", 1.0),
        "gauss_markov": Unit("bias_instability_m_s2", "m/s²", 1.0),
        "rrw": Unit("accel_rw_m_s3_rt_hz", "m/s³/√Hz", 1.0),
        "ramp": Unit("ramp_m_s3", "m/s³", 1.0),
        "flicker": Unit("flicker_floor_m_s2", "m/s²", 1.0),
        "adev": Unit("adev_m_s2", "m/s²", 1.0),
    },
}
#: Term -> the short name of its uncertainty key (``arw_sigma`` ...).
SIGMA_PREFIX = {"quantization": "quantization", "white": "arw", "gauss_markov": "bias_instability",
                "rrw": "rrw", "ramp": "rate_ramp"}
ACCEL_SIGMA_PREFIX = {"quantization": "quantization", "white": "vrw", "gauss_markov": "bias_instability",
                      "rrw": "accel_rw", "ramp": "ramp"}


@dataclass
class AxisResult:
    axis: str
    curve: AllanCurve
    fit: NoiseFit
    #: the output never changes (not one sample differs): nothing is fitted
    dead: bool = False


def implausible(res: AxisResult) -> dict[str, str]:
    """Detected terms the record cannot pin down: term -> why. A 1σ above
    :data:`MAX_RELATIVE_SIGMA` of the value means the record is too short (or the τ range too
    narrow) for it; a correlation time needs its bump (1.89 T) well inside the τ range."""
    out = {}
    taus = res.curve.taus
    for name, est in res.fit.terms.items():
        if est.detected and not est.sigma <= MAX_RELATIVE_SIGMA * est.value:
            out[name] = (f"not determined by this record (1σ {est.sigma / est.value:.0%} of the value, tau "
                         f"{taus[0]:.3g}-{taus[-1]:.3g} s)")
    tc = res.fit.tc
    if tc is not None and not (res.fit.tc_sigma is not None and res.fit.tc_sigma <= MAX_RELATIVE_SIGMA * tc):
        out.setdefault("gauss_markov", f"correlation time {tc:.3g} s not determined by this record")
    return out


@dataclass
class Characterisation:
    """What :func:`analyze` found: the record's facts and one :class:`AxisResult` per axis."""

    topic: str
    field: str
    msgtype: str
    sample_rate_hz: float
    duration_s: float
    tau_max_s: float
    sampling: Sampling
    stamp_source: str
    messages: int
    nonfinite_dropped: int
    skipped_axes: dict[str, str]
    axes: dict[str, AxisResult] = field(default_factory=dict)

    @property
    def is_gyro(self) -> bool:
        return self.field == "angular_velocity"


def choose_axes(data: ImuField, requested: list[str] | None) -> tuple[list[str], dict[str, str]]:
    """Axes to analyse and the skipped ones with why. Refuses an absent field (REP 145) and an
    axis the user asked for that the messages mark as unmeasured."""
    n = data.count
    if data.absent:
        raise AnalysisError(f"{data.topic}: {data.field} is not provided ({data.field}_covariance[0] = -1 in "
                            f"{data.absent} of {n} messages, REP 145); pick another --field or topic", "--field")
    marked = {a: int(c) for a, c in zip(AXES, data.unmeasured) if c}
    if requested:
        bad = [a for a in requested if a in marked]
        if bad:
            raise AnalysisError(f"--axes {' '.join(bad)}: marked unmeasured on {data.topic} (variance >= 1e6 on "
                                f"its diagonal in {', '.join(str(marked[a]) for a in bad)} of {n} messages)",
                                "--axes")
        axes = [a for a in AXES if a in requested]
        skipped = {a: "not asked for (--axes)" for a in AXES if a not in requested}
    else:
        axes = [a for a in AXES if a not in marked]
        skipped = {a: f"unmeasured: variance >= 1e6 on its diagonal in {marked[a]} of {n} messages"
                   for a in marked}
    if not axes:
        raise AnalysisError(f"{data.topic}: no measured axis left to analyse", "--axes")
    return axes, skipped


def minimum_tau_max(tau0: float) -> float:
    """The shortest longest-τ [s] that gives the fit :data:`MIN_OCTAVES` octave points."""
    return 2.0 ** (MIN_OCTAVES - 1) * tau0


def _check_length(topic: str, duration: float, tau0: float, tau_max_s: float | None) -> None:
    """Refuse a τ range the fit cannot use and a record too short for the range asked, naming
    the minimum record length."""
    least = minimum_tau_max(tau0)
    if tau_max_s is not None:
        if not (math.isfinite(tau_max_s) and tau_max_s > 0.0):
            raise AnalysisError(f"--tau-max-s must be > 0, got {tau_max_s}", "--tau-max-s")
        if tau_max_s < least:
            raise AnalysisError(f"--tau-max-s {tau_max_s:g} s gives fewer than {MIN_OCTAVES} octave tau values above "
                                f"the sample interval {tau0:g} s; ask for at least {least:.6g} s", "--tau-max-s")
    need = MIN_DURATION_PER_TAU * max(tau_max_s or least, least)
    if duration < need:
        asked = f"the longest tau asked for ({tau_max_s:g} s)" if tau_max_s else \
            f"the shortest tau range the fit can use ({MIN_OCTAVES} octaves: up to {least:.6g} s at {1 / tau0:.6g} Hz)"
        raise AnalysisError(f"{topic}: the record lasts {duration:.6g} s; the minimum length is {need:.6g} s "
                            f"({MIN_DURATION_PER_TAU:g} x {asked})", "--tau-max-s" if tau_max_s else "BAG")


def analyze(data: ImuField, axes: list[str] | None = None, tau_max_s: float | None = None,
            gaps: str = "split") -> Characterisation:
    """Characterise ``data`` (see the module docstring); ``gaps`` is "split" or "refuse"."""
    if gaps not in ("split", "refuse"):
        raise AnalysisError(f"--gaps must be split or refuse, got {gaps!r}", "--gaps")
    if data.count < 3:
        raise AnalysisError(f"{data.topic}: {data.count} messages, too few to analyse", "--topic")
    use, skipped = choose_axes(data, axes)
    cols = [AXES.index(a) for a in use]
    finite = np.all(np.isfinite(data.values[:, cols]), axis=1)
    dropped = int((~finite).sum())
    if dropped > MAX_NONFINITE_FRACTION * data.count:
        raise AnalysisError(f"{data.topic}: {dropped} of {data.count} samples ({100.0 * dropped / data.count:.2f} %) "
                            f"are not finite, over the {100 * MAX_NONFINITE_FRACTION:g} % that may be dropped",
                            "BAG")
    # dropping copies the samples; a clean record is used as it is
    stamps, values = (data.stamps_ns[finite], data.values[finite]) if dropped else (data.stamps_ns, data.values)
    try:
        samp = sampling(stamps)
    except ValueError as exc:
        raise AnalysisError(f"{data.topic}: {exc}", "BAG") from exc
    if samp.backwards:
        raise AnalysisError(f"{data.topic}: the {data.stamp_source} stamps go backwards {samp.backwards} time(s) "
                            f"(first near t = {samp.breaks_at_s[0]:.6g} s): the samples are not in time order",
                            "BAG")
    if not samp.regular and gaps == "refuse":
        raise AnalysisError(f"{data.topic}: the sampling breaks ({samp.describe()}, first at t = "
                            f"{samp.breaks_at_s[0]:.6g} s); --gaps split analyses the evenly sampled segments",
                            "--gaps")
    tau0 = samp.tau0
    duration = float((stamps[-1] - stamps[0]) * 1e-9) + tau0
    _check_length(data.topic, duration, tau0, tau_max_s)
    longest = max(b - a for a, b in samp.segments) * tau0
    if tau_max_s is None:
        tau_max_s = duration / MIN_DURATION_PER_TAU
    result = Characterisation(topic=data.topic, field=data.field, msgtype=data.msgtype, sample_rate_hz=1.0 / tau0,
                              duration_s=duration, tau_max_s=min(tau_max_s, longest / 2.0), sampling=samp,
                              stamp_source=data.stamp_source, messages=data.count, nonfinite_dropped=dropped,
                              skipped_axes=skipped)
    for axis, col in zip(use, cols):
        segments = [values[a:b, col] for a, b in samp.segments]
        try:
            curve = allan_curve(segments, tau0, result.tau_max_s)
        except ValueError as exc:
            raise AnalysisError(f"{data.topic} axis {axis}: {exc}", "--tau-max-s") from exc
        dead = not np.ptp(values[:, col])
        result.axes[axis] = AxisResult(axis, curve, dead_fit(curve) if dead else fit_noise_terms(curve), dead)
    return result


def _num(x: float | None) -> float | None:
    return None if x is None or not math.isfinite(x) else float(x)


def axis_json(res: AxisResult, field_name: str) -> dict:
    """One axis's terms in edge units, each with its 1σ (``<name>_sigma``)."""
    units = UNITS[field_name]
    prefix = SIGMA_PREFIX if field_name == "angular_velocity" else ACCEL_SIGMA_PREFIX
    fit = res.fit
    out: dict = {}
    for term in ("white", "gauss_markov", "rrw", "quantization", "ramp"):
        est = fit.terms[term]
        out[units[term].key] = est.value * units[term].per_si if est.detected else None
        out[f"{prefix[term]}_sigma"] = _num(est.sigma * units[term].per_si)
        if term == "gauss_markov":
            out["bias_tau_s"] = _num(fit.tc)
            out["bias_tau_sigma"] = _num(fit.tc_sigma)
    out["dead"] = res.dead
    out["not_detected"] = {units[t].key: _num(BOUND_SIGMAS * fit.terms[t].sigma * units[t].per_si)
                           for t in ("white", "gauss_markov", "rrw", "quantization", "ramp")
                           if not fit.terms[t].detected}
    out["flagged"] = {units[t].key: why for t, why in implausible(res).items()}
    f = units["flicker"]
    out[f.key] = fit.flicker_floor * f.per_si
    out["flicker_floor_sigma"] = fit.flicker_sigma * f.per_si
    out["flicker_floor_tau_s"] = fit.flicker_tau
    out["detected"] = [units[t].key for t in ("white", "gauss_markov", "rrw", "quantization", "ramp")
                       if fit.terms[t].detected]
    out["fit"] = {"chi2": fit.chi2, "dof": fit.dof}
    a = units["adev"]
    lo, hi = res.curve.interval(fit.alpha)
    out["adev"] = {"tau_s": res.curve.taus.tolist(), a.key: (res.curve.adev * a.per_si).tolist(),
                   "low": (lo * a.per_si).tolist(), "high": (hi * a.per_si).tolist(),
                   "edf": res.curve.edf_for(fit.alpha).tolist(),
                   "fitted": (np.sqrt(fit.model) * a.per_si).tolist()}
    return out


def to_json(result: Characterisation) -> dict:
    """The characterisation as the JSON document of ``gimbal-allan --json``."""
    s = result.sampling
    units = UNITS[result.field]
    return {
        "topic": result.topic,
        "field": result.field,
        "sample_rate_hz": result.sample_rate_hz,
        "duration_s": result.duration_s,
        "units": {u.key: u.text for u in units.values()} | {"bias_tau_s": "s"},
        "flicker_factor": FLICKER_FACTOR,
        "messages": result.messages,
        "stamps": result.stamp_source,
        "nonfinite_dropped": result.nonfinite_dropped,
        "tau_max_s": result.tau_max_s,
        "sampling": {"segments": len(s.segments), "gaps": s.gaps, "early": s.early, "repeated": s.stalled,
                     "longest_gap_s": s.longest_gap_s, "jitter_rms": s.jitter_rms, "breaks_at_s": s.breaks_at_s},
        "skipped_axes": result.skipped_axes,
        "axes": {axis: axis_json(res, result.field) for axis, res in result.axes.items()},
    }
