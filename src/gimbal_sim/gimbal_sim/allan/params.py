"""The fitted terms as parameters: a ``sensor_models`` file that simulates the sensor, and the
matching noise parameters of the filters.

Per-axis fits become one value per parameter (the models take one value for all axes):
the simulator gets the mean over the axes that detected the term (each axis is a noisy
estimate of the same kind of sensor), the filters get the largest (a filter told less noise
than an axis has is overconfident on that axis). Each file's header names the terms some axis
did not detect, with that axis's bound, and the values flagged as not determined by the
record, which are left out of the parameters (gimbal-allan also says so on stderr).

A record at rest shows no scale-factor error, asymmetry or misalignment (they scale and mix a
rate that is not there): the data sheet's 1σ figures, given as ``--scale-factor-ppm``,
``--scale-asymmetry-ppm`` and ``--misalignment-urad``, are written as the target's per-run
draws (``<target>_scale_factor_sigma_ppm``, ``_scale_asymmetry_sigma_ppm``,
``_misalignment_sigma_urad``); not given, they are not written and a scenario keeps its own.

Filters model the bias as a random walk of PSD ``q_b``: the Gauss-Markov term contributes
``2σ²/T`` at lags shorter than T and the rate random walk ``K²``, so ``q_b = 2σ²/T + K²``.
``gyro_bias_ekf`` takes it as ``2 σ_ekf² / τ_ekf``: τ_ekf is the fitted T (the longest τ of
the fit when there is no Gauss-Markov term) and σ_ekf = sqrt(q_b τ_ekf / 2).
``flexure_estimator`` takes two such gyros (its LGUs): their bias difference walks with
PSD 2 q_b. ``encoder_fusion_controller``'s drift walk density is sqrt(q_b).
"""
from __future__ import annotations

import math

import yaml

from gimbal_kinematics.maths.units import DEG, UG

from .analyze import Characterisation, axis_json, implausible

#: Sensors of ``sensor_models`` a gyro characterisation can be written for: parameter prefix.
GYRO_TARGETS = {"gimbal_gyro": "gimbal_gyro", "ins_gyro": "ins_gyro"}
ACCEL_TARGETS = {"platform_accel": "platform_accel"}


#: The data sheet's figures a record at rest cannot give: sensor_models parameter suffix ->
#: (gimbal-allan option, what it is). Written as the target's 1σ per-run draws.
DATASHEET = {"scale_factor_sigma_ppm": ("--scale-factor-ppm", "scale-factor error 1-sigma [ppm]"),
             "scale_asymmetry_sigma_ppm": ("--scale-asymmetry-ppm", "scale-factor asymmetry 1-sigma [ppm]"),
             "misalignment_sigma_urad": ("--misalignment-urad", "axis misalignment 1-sigma per element [urad]")}


def datasheet_params(target: str, values: dict[str, float | None] | None) -> dict[str, float]:
    """``sensor_models`` parameters of the data sheet's figures given (suffix -> value, None:
    not given) for ``target`` (a ``sensor_models`` prefix)."""
    return {f"{target}_{key}": float(v) for key, v in (values or {}).items() if v is not None}


def datasheet_header(values: dict[str, float | None] | None) -> list[str]:
    """The parameter files' lines on the terms a record at rest does not show."""
    given = {k: v for k, v in (values or {}).items() if v is not None}
    if given:
        return ["Scale factor, asymmetry and misalignment are not in a record at rest: from the data sheet, as",
                "1-sigma per-run draws: " + ", ".join(f"{DATASHEET[k][1]} {v:g}" for k, v in given.items()) + "."]
    return ["Scale factor, asymmetry and misalignment are not in a record at rest and are not set here (a",
            "scenario keeps its own): give the data sheet's 1-sigma with " + ", ".join(o for o, _ in DATASHEET.values())
            + "."]


def _usable(res, name: str) -> bool:
    """The axis detected term ``name`` and the record determines it (not flagged)."""
    return res.fit.terms[name].detected and name not in implausible(res)


def _terms(result: Characterisation, reduce) -> dict[str, float]:
    """SI value of each term over the axes that detected it (``reduce`` = mean or max); an axis
    that did not detect a term does not count as 0 in it (its value is unknown, below a bound),
    and a value flagged as not determined by the record (:func:`.analyze.implausible`) is left
    out too: it is no measurement to put into a filter. A term no axis gave a usable value
    for is 0: nothing to simulate or to tell a filter."""
    out = {}
    for name in ("quantization", "white", "gauss_markov", "rrw", "ramp"):
        values = [r.fit.terms[name].value for r in result.axes.values() if _usable(r, name)]
        out[name] = reduce(values) if values else 0.0
    tcs = [r.fit.tc for r in result.axes.values() if r.fit.tc is not None and _usable(r, "gauss_markov")]
    # the correlation time of the axes that have one (geometric mean: it is a scale)
    out["tc"] = math.exp(sum(math.log(t) for t in tcs) / len(tcs)) if tcs else None
    return out


def caveats(result: Characterisation) -> list[str]:
    """Header lines: terms an axis did not detect (with its bound) and fitted values flagged."""
    from_json = {axis: axis_json(res, result.field) for axis, res in result.axes.items()}
    lines = []
    for axis, doc in from_json.items():
        if doc["dead"]:
            lines.append(f"axis {axis}: dead (its output never changes); no term detected")
            continue
        missing = ", ".join(f"{key} < {bound:.3g}" if bound is not None else key
                            for key, bound in doc["not_detected"].items())
        if missing:
            lines.append(f"axis {axis}: not detected: {missing}")
        for key, why in doc["flagged"].items():
            lines.append(f"axis {axis}: FLAGGED {key}: {why}; left out of the values below")
    return lines


def _mean(values: list[float]) -> float:
    return sum(values) / len(values)


def bias_walk_psd(white_gm: float, tc: float | None, rrw: float) -> float:
    """``q_b`` [u²/s³]: 2σ²/T + K² (module docstring)."""
    return (2.0 * white_gm**2 / tc if tc else 0.0) + rrw**2


def sensor_models_params(result: Characterisation, target: str) -> dict:
    """``sensor_models`` parameters that simulate the characterised sensor as ``target``."""
    t = _terms(result, _mean)
    if result.is_gyro:
        if target not in GYRO_TARGETS:
            raise ValueError(f"--simulate-as {target!r}: a gyro can be simulated as {sorted(GYRO_TARGETS)}")
        p = GYRO_TARGETS[target]
        params = {
            f"{p}_arw_deg_rt_h": t["white"] * 60.0 / DEG,
            f"{p}_bi_deg_h": t["gauss_markov"] * 3600.0 / DEG,
            f"{p}_rrw_deg_h_rt_h": t["rrw"] * 3600.0 * 60.0 / DEG,
            f"{p}_quantum_deg": t["quantization"] * math.sqrt(12.0) / DEG,
        }
        if t["tc"]:  # without a Gauss-Markov term its correlation time stays as it was
            params[f"{p}_bi_tau_s"] = t["tc"]
        return params
    if target not in ACCEL_TARGETS:
        raise ValueError(f"--simulate-as {target!r}: an accelerometer can be simulated as {sorted(ACCEL_TARGETS)}")
    return {"platform_accel_noise_ug_rt_hz": t["white"] / UG}


def filter_params(result: Characterisation, target: str) -> dict[str, dict]:
    """Noise parameters of the filters that model this gyro: node -> parameters."""
    if not result.is_gyro:
        return {}
    return gyro_filter_params(*filter_noise(result), target)


def filter_noise(result: Characterisation) -> tuple[float, float, float]:
    """(white density N [u·√s], bias walk PSD q_b [u²/s], correlation time τ [s]) a filter is
    given for this sensor: each term the largest over the axes; τ is the fitted T, or the
    longest τ of the fit when there is no Gauss-Markov term."""
    t = _terms(result, max)
    return t["white"], bias_walk_psd(t["gauss_markov"], t["tc"], t["rrw"]), t["tc"] or result.tau_max_s


def gyro_filter_params(white: float, q_b: float, tau: float, target: str) -> dict[str, dict]:
    """The filters' noise parameters of a gyro of white noise density ``white`` [rad/√s] and
    bias walk PSD ``q_b`` [rad²/s³], ``gyro_bias_ekf`` modelling the walk as a Gauss-Markov
    bias of correlation time ``tau`` [s] (module docstring): node -> parameters."""
    t = {"white": white}
    sigma_ekf = math.sqrt(q_b * tau / 2.0)
    channel = "gyro" if target == "gimbal_gyro" else "roll"
    return {
        "gyro_bias_ekf": {f"{channel}_arw_deg_rt_h": t["white"] * 60.0 / DEG,
                          f"{channel}_bias_instability_deg_h": sigma_ekf * 3600.0 / DEG,
                          f"{channel}_bias_tau_s": tau},
        "flexure_estimator": {"lgu_arw_deg_rt_h": t["white"] * 60.0 / DEG,
                              "bias_diff_rw_deg_h_rt_h": math.sqrt(2.0 * q_b) * 3600.0 * 60.0 / DEG},
        "encoder_fusion_controller": {"kf_q_angle_deg_rt_s": t["white"] / DEG,
                                      "kf_q_drift_deg_s_rt_s": math.sqrt(q_b) / DEG},
    }


def ros_params_yaml(header: list[str], nodes: dict[str, dict]) -> str:
    lines = [f"# {h}" for h in header]
    for node, params in nodes.items():
        body = {node: {"ros__parameters": {k: float(v) for k, v in params.items()}}}
        lines.append(yaml.safe_dump(body, sort_keys=False, default_flow_style=False).rstrip())
    return "\n".join(lines) + "\n"


def sensor_models_yaml(result: Characterisation, target: str, source: str,
                       datasheet: dict[str, float | None] | None = None) -> str:
    """A ``--params-file`` for ``sensor_models`` that simulates the characterised sensor, with
    the data sheet's scale-factor and misalignment figures given (:data:`DATASHEET`)."""
    params = {**sensor_models_params(result, target), **datasheet_params(target, datasheet)}
    header = [f"sensor_models parameters fitted by gimbal-allan from {source}",
              f"({result.topic} {result.field}, axes {' '.join(result.axes)}: mean over the axes that detected "
              f"each term)."] + caveats(result)
    if result.is_gyro:
        header += ["Not simulated: the rate ramp (sensor_models has none); the turn-on bias, which one",
                   "record cannot separate from the earth rate and the mounting: keep the datasheet's."]
    else:
        header += ["Only the white noise is a parameter of sensor_models' platform accelerometer; its bias",
                   "instability and random walk are in the JSON."]
    header += datasheet_header(datasheet)
    return ros_params_yaml(header, {"sensor_models": params})


def filters_yaml(result: Characterisation, target: str, source: str) -> str:
    """The filters' noise parameters for this gyro (one ``ros__parameters`` block per node)."""
    nodes = filter_params(result, target)
    if not nodes:
        return (f"# gimbal-allan, {source}: no filter of this toolkit takes accelerometer noise parameters\n"
                f"# (platform_alignment's least squares has none); the fitted terms are in allan.json.\n")
    header = [f"Filter noise parameters fitted by gimbal-allan from {source} (largest over the axes).",
              *caveats(result),
              "The bias walk PSD q_b = 2 sigma_gm^2 / T + K^2 (Gauss-Markov and rate random walk):",
              "gyro_bias_ekf uses 2 sigma^2 / tau = q_b; flexure_estimator's LGU bias difference walks with",
              "2 q_b (two such gyros); encoder_fusion_controller's drift density is sqrt(q_b).",
              "The prior bias sigmas (*_bias_sigma_deg_h) are not set: a turn-on bias is not in one record."]
    return ros_params_yaml(header, nodes)


def set_arguments(params: dict) -> list[str]:
    """``sensor_models`` parameter values as ``gimbal-run --set`` arguments."""
    return [f"--set sensor_models.{k}={float(v)!r}" for k, v in params.items()]
