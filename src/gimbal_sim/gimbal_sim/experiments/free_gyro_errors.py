"""Paper 4's error study: the linear error model
(:mod:`gimbal_estimators.free_gyro_error_model`, eq. 8–38) against seeded Monte Carlo through
the simulated free-gyro sensor and the positioning core, one error source at a time and all
together, plus the FDOP circle and a sailing ship::

    python -m gimbal_sim.experiments.free_gyro_errors --seeds 200

Variants (:data:`VARIANTS`): ``pickoff`` (the scenario's sensor: 5″ pickoff noise and the
0.002 °/√h triad, no other source), ``triad_bias``, ``levelling``, ``spin_drift`` (that
source on top of ``pickoff``), ``all`` (every source) and ``sailing`` (``pickoff`` on a ship
sailing ``course_deg`` at ``speed_m_s``, the core given its velocity). The drifting free
gyro (``--variants drift``, :data:`DRIFT_VARIANTS`): ``caging``, ``gm_drift``,
``rate_sensors`` (the spin-axis rate sensors' integrated random walk) and ``suppression`` (the
gimbal-lock suppression with a guard gyro b enters: a bias, scored as the mean against the
model's bias, :func:`suppression_bias`), each on top of ``pickoff``, and ``drifting`` with
every source. Each run draws its
random constants from its seed (the triad bias and the spin drift in the sensor, the
levelling error here) and runs ``heading_window_s + fix_interval_s``: its last fix carries
the first earth-rate heading, so every run gives one independent sample of all six outputs
(nadir a, b, north, east, free-gyro heading, earth-rate heading), scored against the model's
σ at that fix. The FDOP circle pools every fix of every run.

Runs on the core engine only: the scenario's sensor takes a fixed levelling error (no per-run
draw) and its report carries neither the nadir errors nor the model's σ.
"""
from __future__ import annotations

import argparse
import math
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from gimbal_estimators.free_gyro_error_model import (
    IN_SPIN_A, IN_SPIN_B, ErrorSources, FixErrorModel, circle_probability, suppression_spin_rates_i)
from gimbal_estimators.free_gyro_positioning import FreeGyroPositioningParams
from gimbal_kinematics.maths.free_gyro import dcm_ni, nadir_angle
from gimbal_kinematics.maths.rotations import euler321_to_dcm
from gimbal_kinematics.maths.units import DEG_H
from gimbal_kinematics.maths.units import ARCSEC

from ..campaign.experiment import ExperimentCampaign, run_metrics
from ..campaign.runner_cli import add_engine_arguments, campaign_dir, run_for_cli
from ..campaign.spec import CampaignSpec
from ..reports.free_gyro_errors import circle_plot, ratio_plot
from ..world.sensors.free_gyro_sensor import FreeGyroSensorParams, sailing_position
from ..world.sensors.gyro import GyroParams
from .free_gyro import make_spin_axes, run_free_gyro_experiment, simulate_truth

#: Outputs, in the order of a fix's ``errors`` and ``sigma`` (rad, m).
OUTPUTS = ("nadir_a", "nadir_b", "north_m", "east_m", "heading", "heading_earth_rate")
#: variant -> the error sources it turns on (besides the pickoff noise and triad ARW)
VARIANTS = {"pickoff": (), "triad_bias": ("triad_bias",), "levelling": ("levelling",),
            "spin_drift": ("spin_drift",), "all": ("triad_bias", "levelling", "spin_drift"), "sailing": (),
            "caging": ("caging",), "gm_drift": ("gm_drift",), "rate_sensors": ("rate_sensors",),
            "suppression": ("suppression",),
            "drifting": ("triad_bias", "levelling", "spin_drift", "caging", "gm_drift", "rate_sensors", "suppression")}
#: The drifting free gyro's variants (its truth terms and the rate sensors; ``--variants drift``).
DRIFT_VARIANTS = ("pickoff", "spin_drift", "caging", "gm_drift", "rate_sensors", "suppression", "drifting")
DEFAULTS: dict[str, Any] = {
    "lat_deg": 35.0, "lon_deg": 129.0, "profile": "paper5_ship", "rate_hz": 10.0, "fix_interval_s": 10.0,
    "heading_window_s": 60.0, "nadir_deg": [60.0, 50.0], "azimuth_deg": [-40.0, 50.0],
    "pickoff_noise_arcsec": 5.0, "triad_arw_deg_rt_h": 0.002, "triad_bias_deg_h": 0.05,
    "level_error_arcsec": 10.0, "spin_drift_deg_h": 0.5, "speed_m_s": 10.0, "course_deg": 70.0,
    # the drifting free gyro (docs/results/paper4.md, "A free gyro that drifts", argues each figure)
    "caging_arcsec": 10.0, "gm_drift_deg_h": 0.5, "gm_drift_tau_s": 300.0, "spin_rate_arw_deg_rt_h": 0.01,
    "lock_guard_deg": 20.0, "lock_suppression_rate_deg_h": 5.0}
#: The ``suppression`` variant's guard [deg]: wide enough that gyro b (set at nadir 50° on a ship
#: rolling 5° and pitching 3°) enters it, so that the suppression acts; the default guard
#: (``lock_guard_deg``) is never reached at the scenario's nadir angles.
SUPPRESSION_GUARD_DEG = 52.0
_CACHE: dict[str, Any] = {}   # per process: the runs of a campaign share the truth and the model


def _truth(options: dict) -> list:
    key = repr(sorted(options.items()))
    if _CACHE.get("key") != key:
        duration = options["heading_window_s"] + options["fix_interval_s"] + 1.0 / options["rate_hz"]
        _CACHE.clear()
        _CACHE.update(key=key, truth=simulate_truth(options["profile"], options["lat_deg"], options["lon_deg"],
                                                    duration, options["rate_hz"]))
    return _CACHE["truth"]


def error_sources(variant: str, options: dict) -> ErrorSources:
    """The σ of ``variant``'s error sources (the model's input)."""
    on = VARIANTS[variant]
    return ErrorSources(triad_bias_deg_h=options["triad_bias_deg_h"] if "triad_bias" in on else 0.0,
                        level_error_arcsec=options["level_error_arcsec"] if "levelling" in on else 0.0,
                        spin_drift_deg_h=options["spin_drift_deg_h"] if "spin_drift" in on else 0.0,
                        pickoff_noise_arcsec=options["pickoff_noise_arcsec"],
                        triad_arw_deg_rt_h=options["triad_arw_deg_rt_h"],
                        caging_arcsec=options["caging_arcsec"] if "caging" in on else 0.0,
                        gm_drift_deg_h=options["gm_drift_deg_h"] if "gm_drift" in on else 0.0,
                        gm_drift_tau_s=options["gm_drift_tau_s"],
                        spin_rate_arw_deg_rt_h=options["spin_rate_arw_deg_rt_h"] if "rate_sensors" in on else 0.0)


def suppression_setting(variant: str, options: dict) -> tuple[float, float]:
    """(guard [deg], rate [°/h]) of ``variant``'s gimbal-lock suppression: (0, 0) when off, the
    wide :data:`SUPPRESSION_GUARD_DEG` in ``suppression``, the option's guard otherwise."""
    if "suppression" not in VARIANTS[variant]:
        return 0.0, 0.0
    guard = SUPPRESSION_GUARD_DEG if variant == "suppression" else options["lock_guard_deg"]
    return guard, options["lock_suppression_rate_deg_h"]


def sensor_params(variant: str, seed: int, options: dict, u_a, u_b) -> FreeGyroSensorParams:
    """The sensor of ``variant`` for ``seed``: the levelling error drawn here from the seed
    (the sensor takes it as a fixed bias), the other constants drawn by the sensor."""
    src = error_sources(variant, options)
    level = np.random.default_rng([int(seed) & 0xFFFFFFFF, 25]).standard_normal(2) * src.level_error_arcsec
    triad = GyroParams(arw_deg_rt_h=src.triad_arw_deg_rt_h, bias_sigma_deg_h=src.triad_bias_deg_h)
    sailing = variant == "sailing"
    guard, rate = suppression_setting(variant, options)
    return FreeGyroSensorParams(u_a, u_b, pickoff_noise_arcsec=src.pickoff_noise_arcsec,
                                spin_drift_sigma_deg_h=src.spin_drift_deg_h, level_bias_arcsec=tuple(level),
                                triad=triad, speed_m_s=options["speed_m_s"] if sailing else 0.0,
                                course_deg=options["course_deg"], caging_error_arcsec=src.caging_arcsec,
                                gm_drift_sigma_deg_h=src.gm_drift_deg_h, gm_drift_tau_s=src.gm_drift_tau_s,
                                lock_guard_deg=guard, lock_suppression_rate_deg_h=rate,
                                spin_rate_arw_deg_rt_h=src.spin_rate_arw_deg_rt_h)


def _circular_mean(angles: np.ndarray) -> float:
    return math.atan2(float(np.mean(np.sin(angles))), float(np.mean(np.cos(angles))))


def fix_model(truth: Sequence, fix, u_a, u_b, lat: float, lon: float, heading_window_s: float) -> FixErrorModel:
    """The linear model at ``fix``: the ship's mean attitude over the fix's read-outs and its
    mean yaw rate over the earth-rate window (from the truth sequence), the drift elapsed
    since the spin axes were set at t = 0, the fix's read-out count."""
    dt = truth[1].t - truth[0].t
    half = 0.5 * (fix.n_samples - 1) * dt + 0.25 * dt
    e = np.array([tr.euler for tr in truth if abs(tr.t - fix.t) <= half])
    window = [tr.euler[2] for tr in truth if abs(tr.t - fix.heading_earth_rate_t) <= 0.5 * heading_window_s + 1e-9]
    yaw_rate = math.remainder(window[-1] - window[0], math.tau) / heading_window_s if len(window) > 1 else 0.0
    return FixErrorModel(u_a, u_b, lat, lon, fix.t, roll=float(np.mean(e[:, 0])), pitch=float(np.mean(e[:, 1])),
                         heading=_circular_mean(e[:, 2]), drift_elapsed_s=fix.t, samples_per_fix=fix.n_samples,
                         heading_window_s=heading_window_s, yaw_rate_rad_s=yaw_rate, sample_interval_s=dt)


def suppression_bias(truth: Sequence, fix, model: FixErrorModel, u_a, u_b, guard_deg: float,
                     rate_deg_h: float) -> np.ndarray:
    """The model's bias (6,) of :data:`OUTPUTS` at ``fix`` from the gimbal-lock suppression: each
    nominal axis's precession (:func:`suppression_spin_rates_i`) accumulated over the truth's
    attitude history up to each read-out of the fix window, averaged over the window, through
    the fix map's spin columns (a suppression moves the true axis as a drift does)."""
    if guard_deg <= 0.0 or rate_deg_h <= 0.0:
        return np.zeros(len(OUTPUTS))
    key = ("suppression", guard_deg, rate_deg_h, id(truth))
    if key not in _CACHE:
        lat, lon = model.lat, model.lon
        C = np.array([euler321_to_dcm(*tr.euler).T @ dcm_ni(lat, lon, tr.t) for tr in truth])
        dt = truth[1].t - truth[0].t
        cum = [np.cumsum(suppression_spin_rates_i(u, C, guard_deg, rate_deg_h * DEG_H) * dt, axis=0)
               for u in (u_a, u_b)]
        _CACHE[key] = (np.array([tr.t for tr in truth]), cum)
    times, cum = _CACHE[key]
    dt = times[1] - times[0]
    sel = np.abs(times - fix.t) <= 0.5 * (fix.n_samples - 1) * dt + 0.25 * dt
    eps_a, eps_b = (np.mean(c[sel], axis=0) for c in cum)
    return model.H[:, IN_SPIN_A] @ eps_a + model.H[:, IN_SPIN_B] @ eps_b


def campaign_run(variant: str, seed: int, options: dict) -> dict:
    """One seeded run of ``variant`` (:data:`CAMPAIGN`'s core run): per fix its time, the six
    output errors (:data:`OUTPUTS`; nadir errors as the fix sees them, against the nominal
    spin axes at the true position), the model's σ of each, its north/east covariance [m²],
    eq. 38's FDOP·σ_θ radius [m] and the probability of that circle under the covariance."""
    truth = _truth(options)
    u_a, u_b = make_spin_axes(options["lat_deg"], options["lon_deg"], 0.0, tuple(options["nadir_deg"]),
                              tuple(options["azimuth_deg"]))
    sp = sensor_params(variant, seed, options, u_a, u_b)
    cp = FreeGyroPositioningParams(u_a, u_b, nadir_noise_arcsec=options["pickoff_noise_arcsec"],
                                   fix_interval_s=options["fix_interval_s"],
                                   heading_window_s=options["heading_window_s"],
                                   triad_arw_deg_rt_h=options["triad_arw_deg_rt_h"])
    lat0, lon0 = math.radians(options["lat_deg"]), math.radians(options["lon_deg"])
    run = run_free_gyro_experiment(seed, truth, options["lat_deg"], options["lon_deg"], sp, cp)
    sources = error_sources(variant, options)
    fixes = []
    for k, fix in enumerate(run.fixes):
        lat, lon = sailing_position(lat0, lon0, sp.velocity_n, fix.t)
        key = (variant, round(fix.t, 6), fix.n_samples, round(fix.heading_earth_rate_t, 6)
               if math.isfinite(fix.heading_earth_rate_t) else None)
        if key not in _CACHE:
            model = fix_model(truth, fix, u_a, u_b, lat, lon, options["heading_window_s"])
            _CACHE[key] = (model.predict(sources),
                           suppression_bias(truth, fix, model, u_a, u_b, sp.lock_guard_deg,
                                            sp.lock_suppression_rate_deg_h))
        pred, bias = _CACHE[key]
        nadir = [fix.nadir[j] - nadir_angle(u, lat, lon, fix.t) for j, u in enumerate((u_a, u_b))]
        errors = [*nadir, *run.errors_ne_m[k], run.heading_errors[k], run.heading_er_errors[k]]
        r = pred.position_fdop_m
        fixes.append({"t": fix.t, "errors": [float(x) for x in errors], "bias": [float(x) for x in bias],
                      "sigma": [float(x) for x in np.sqrt(np.diag(pred.cov)[[0, 1, 2, 3, 4, 5]])],
                      "cov_ne_m2": pred.cov_ne_m.tolist(), "fdop_radius_m": r,
                      "p_circle": circle_probability(pred.cov_ne_m, r), "fdop": pred.fdop})
    return {"fixes": fixes, "withheld_fixes": run.degenerate}


CAMPAIGN = ExperimentCampaign(name="free_gyro_errors", variants=tuple(VARIANTS), defaults=DEFAULTS, run=campaign_run)


def _last(runs: Sequence[dict]) -> tuple[np.ndarray, np.ndarray]:
    """(n, 6) errors and σ of each run's last fix (the one with the earth-rate heading)."""
    last = [r["fixes"][-1] for r in runs]
    return np.array([f["errors"] for f in last]), np.array([f["sigma"] for f in last])


def _last_bias(runs: Sequence[dict]) -> np.ndarray:
    """(6,) the model's mean bias at the last fixes (0 where the run has none)."""
    return np.mean([r["fixes"][-1].get("bias", [0.0] * len(OUTPUTS)) for r in runs], axis=0)


def variant_table(runs: Sequence[dict]) -> dict[str, Any]:
    """One variant's figures: per output the Monte Carlo std, mean and RMS of the last fixes'
    errors against the model's σ (their ratio std/σ and mean/σ), the position drms, and the
    FDOP circle over every fix: fraction inside eq. 38's radius against the probability the
    covariance implies and the paper's 1 − e⁻¹, with the fraction's standard error taking the
    runs as the independent units (``se_runs``: the fixes of a run share its random constants,
    and every run has the same number of fixes)."""
    err, sig = _last(runs)
    bias = _last_bias(runs)
    out: dict[str, Any] = {"n_fixes": len(err)}
    for j, name in enumerate(OUTPUTS):
        x, s = err[:, j], float(np.sqrt(np.mean(sig[:, j] ** 2)))
        std = float(np.std(x, ddof=1))
        mean = float(np.mean(x))
        b = float(bias[j])
        out[name] = {"mc_std": std, "mc_mean": mean, "model_sigma": s, "ratio": std / s if s > 0 else math.nan,
                     "mean_over_sigma": mean / s if s > 0 else math.nan, "model_bias": b,
                     "bias_ratio": mean / b if abs(b) > 3.0 * s / math.sqrt(len(x)) else math.nan}
    ne = err[:, 2:4] - np.mean(err[:, 2:4], axis=0)
    out["position_drms_m"] = {"mc": float(math.sqrt(np.mean(np.sum(ne**2, axis=1)))),
                              "model": float(math.sqrt(np.mean(sig[:, 2] ** 2 + sig[:, 3] ** 2)))}
    out["position_drms_m"]["ratio"] = out["position_drms_m"]["mc"] / out["position_drms_m"]["model"]
    every = [f for r in runs for f in r["fixes"]]
    inside = [math.hypot(*f["errors"][2:4]) <= f["fdop_radius_m"] for f in every]
    per_run = [np.mean([math.hypot(*f["errors"][2:4]) <= f["fdop_radius_m"] for f in r["fixes"]]) for r in runs]
    out["fdop_circle"] = {"n_fixes": len(every), "fraction": float(np.mean(inside)),
                          "se_runs": float(np.std(per_run, ddof=1) / math.sqrt(len(runs))),
                          "implied": float(np.mean([f["p_circle"] for f in every])), "paper": 1.0 - math.exp(-1.0),
                          "fdop": float(np.mean([f["fdop"] for f in every]))}
    return out


def _fmt(v: float, unit: str) -> str:
    return f"{v:.3g} m" if unit == "m" else f"{v / ARCSEC:.3g}″"


def format_tables(by_variant: dict[str, list[dict]]) -> str:
    """The Monte Carlo against the model, per variant and output, and the FDOP circle."""
    lines = ["| variant | fixes | output | MC std | model σ | std/σ | mean/σ | MC mean / model bias |",
             "|---|---:|---|---|---|---|---|---|"]
    tables = {v: variant_table(runs) for v, runs in by_variant.items()}
    for v, t in tables.items():
        for name in OUTPUTS:
            f, unit = t[name], ("m" if name.endswith("_m") else "″")
            lines.append(f"| {v} | {t['n_fixes']} | {name} | {_fmt(f['mc_std'], unit)} "
                         f"| {_fmt(f['model_sigma'], unit)} | {f['ratio']:.3f} | {f['mean_over_sigma']:+.3f} "
                         + (f"| {_fmt(f['mc_mean'], unit)} / {_fmt(f['model_bias'], unit)} = {f['bias_ratio']:.3f} |"
                            if math.isfinite(f["bias_ratio"]) else "| |"))
        d = t["position_drms_m"]
        lines.append(f"| {v} | {t['n_fixes']} | position drms | {d['mc']:.3g} m | {d['model']:.3g} m "
                     f"| {d['ratio']:.3f} | | |")
    lines += ["", "| variant | fixes | FDOP | inside FDOP·σ_θ ± its 1σ (runs independent) | covariance implies "
                  "| paper (1 − e⁻¹) |", "|---|---:|---|---|---|---|"]
    for v, t in tables.items():
        c = t["fdop_circle"]
        lines.append(f"| {v} | {c['n_fixes']} | {c['fdop']:.3f} | {c['fraction']:.3f} ± {c['se_runs']:.3f} "
                     f"| {c['implied']:.3f} | {c['paper']:.3f} |")
    return "\n".join(lines)


def main(argv: Sequence[str] | None = None) -> None:
    """``python -m gimbal_sim.experiments.free_gyro_errors``: the study, printed."""
    ap = argparse.ArgumentParser(prog="python -m gimbal_sim.experiments.free_gyro_errors",
                                 description="Paper 4 error study: Monte Carlo of the free-gyro sensor and "
                                             "positioning cores against the linear error model, per error source, "
                                             "all together and sailing; the FDOP circle. Core engine only.")
    ap.add_argument("--seeds", type=int, default=200, help="seeded runs per variant (one scored fix each)")
    ap.add_argument("--variants", help=f"comma-separated, of {', '.join(VARIANTS)} (default all); 'drift': "
                                       f"the drifting free gyro's, {', '.join(DRIFT_VARIANTS)}")
    ap.add_argument("--speed-m-s", type=float, default=DEFAULTS["speed_m_s"], help="sailing variant's speed [m/s]")
    ap.add_argument("--course-deg", type=float, default=DEFAULTS["course_deg"], help="its course [deg]")
    ap.add_argument("--plots", metavar="DIR", help="write the ratio and FDOP-circle plots here")
    add_engine_arguments(ap, graph=False)
    a = ap.parse_args(argv)
    if a.seeds < 2:
        ap.error("--seeds must be >= 2")
    if not (0.0 <= a.speed_m_s < math.inf and math.isfinite(a.course_deg)):
        ap.error("--speed-m-s must be finite and >= 0, --course-deg finite")
    options = {**DEFAULTS, "speed_m_s": a.speed_m_s, "course_deg": a.course_deg}
    variants = (DRIFT_VARIANTS if a.variants == "drift" else tuple(a.variants.split(","))) if a.variants else ()
    spec = CampaignSpec(scenario="", experiment=CAMPAIGN.name, seeds=tuple(range(1, a.seeds + 1)), engine="core",
                        variants=variants, options=tuple(options.items()))
    with campaign_dir(a.out) as out:
        result = run_for_cli(ap, a, spec, out, CAMPAIGN)
        by_variant = {v: [m for _, m in runs] for v, runs in run_metrics(result).items()}
    print(f"free_gyro_errors: {a.seeds} seeds per variant, options {options}\n{format_tables(by_variant)}")
    if a.plots:
        out_dir = Path(a.plots)
        out_dir.mkdir(parents=True, exist_ok=True)
        ratio_plot(out_dir / "free_gyro_errors_ratio.png", {v: variant_table(r) for v, r in by_variant.items()},
                   OUTPUTS)
        written = [out_dir / "free_gyro_errors_ratio.png"]
        for v, runs in by_variant.items():
            written.append(out_dir / f"free_gyro_errors_circle_{v}.png")
            circle_plot(written[-1], runs, v)
        print("plots:", ", ".join(str(p) for p in written))


if __name__ == "__main__":
    main()
