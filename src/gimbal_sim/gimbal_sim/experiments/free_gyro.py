"""Free-gyro positioning experiment (paper 4, docs/spec.md §3.4): the simulated ship and free-gyro
sensor feed :class:`gimbal_estimators.free_gyro_positioning.FreeGyroPositioning`, and the fixes
are scored against the true site; a seeded Monte Carlo checks the fix errors against the
claimed FDOP²σ² covariance (the command: scenario ``free_gyro_positioning``'s runs on the one
engine, :data:`CAMPAIGN`)::

    python -m gimbal_sim.experiments.free_gyro --runs 200

Angles rad (degrees at the CLI and in ``*_deg`` arguments), distances m, times s.
"""
from __future__ import annotations

import argparse
import math
from typing import NamedTuple, Sequence

import numpy as np

from gimbal_estimators.free_gyro_positioning import FreeGyroPositioning, FreeGyroPositioningParams
from gimbal_kinematics.maths.earth import meridian_radius, prime_vertical_radius
from gimbal_kinematics.maths.free_gyro import spin_axes_for_site_deg
from gimbal_kinematics.maths.units import ARCSEC

from ..world.sensors.free_gyro_sensor import FreeGyroSensor, FreeGyroSensorParams, sailing_position
from ..world.vehicle import VehicleConfig, VehicleCore
from ..core.core_loop import run_stages
from ..campaign.spec import CampaignSpec
from ..campaign.experiment import ExperimentCampaign, GraphEquivalent, run_metrics
from ..campaign.runner_cli import add_engine_arguments, campaign_dir, run_for_cli
from .engine_runs import run_on_engine

_NAN = float("nan")


class FreeGyroRun(NamedTuple):
    """Fixes of one simulated run and their errors against truth.

    ``fixes``: the valid :class:`FreeGyroFix` list; ``errors_ne_m`` (k, 2) north/east errors
    [m]; ``cov_ne_m`` (k, 2, 2) the fixes' covariances; ``nees`` (k,); ``heading_errors``
    (k,) free-gyro heading minus the true window-mean heading [rad];
    ``heading_er_errors`` (k,) earth-rate heading errors [rad] (NaN before the first
    earth-rate window); ``degenerate`` count of withheld fixes and their ``reasons``.
    """

    fixes: list
    errors_ne_m: np.ndarray
    cov_ne_m: np.ndarray
    nees: np.ndarray
    heading_errors: np.ndarray
    heading_er_errors: np.ndarray
    degenerate: int
    reasons: list


def make_spin_axes(lat_deg: float, lon_deg: float, t: float = 0.0,
                   nadir_deg: tuple[float, float] = (60.0, 50.0),
                   azimuth_deg: tuple[float, float] = (-40.0, 50.0)) -> tuple[tuple, tuple]:
    """Inertial spin axes (u_a_i, u_b_i) with the given nadir angles and azimuths [deg] at
    the site and time t [s] (default: a well-conditioned pair, Δα = 90°, FDOP = √2)."""
    return spin_axes_for_site_deg(lat_deg, lon_deg, nadir_deg, azimuth_deg, t)


def simulate_truth(profile: str = "paper5_ship", lat_deg: float = 35.0, lon_deg: float = 129.0,
                   duration_s: float = 60.0, rate_hz: float = 10.0, profile_params: dict | None = None) -> list:
    """``VehicleTruth`` list from ``gimbal_sim``'s host-only vehicle at a fixed site."""
    pp = {"lat_deg": lat_deg, "lon_deg": lon_deg}
    pp.update(profile_params or {})
    core = VehicleCore(VehicleConfig(profile=profile, profile_params=pp, plant="host_only",
                                     sim_rate_hz=rate_hz, duration_s=duration_s))
    out: list = []
    run_stages(core, [], controlled=False, observer=lambda bus: out.append(bus.truth))
    return out


def run_free_gyro_experiment(seed: int, truth: Sequence, lat_deg: float, lon_deg: float, sensor_params,
                             core_params: FreeGyroPositioningParams | None = None) -> FreeGyroRun:
    """Feed a truth sequence through ``FreeGyroSensor`` (seeded) into the core; compare the
    fixes with the true site: (lat, lon), where the host-only vehicle stays, or the sailing
    ship's position at the fix time (``sensor_params.speed_m_s`` > 0; the core is then given
    the ship's velocity)."""
    lat, lon = math.radians(lat_deg), math.radians(lon_deg)
    dt = truth[1].t - truth[0].t
    sensor = FreeGyroSensor(sensor_params, np.random.default_rng([int(seed) & 0xFFFFFFFF, 8]), dt)
    if core_params is None:
        core_params = FreeGyroPositioningParams(
            sensor_params.u_a_i, sensor_params.u_b_i, nadir_noise_arcsec=max(sensor_params.pickoff_noise_arcsec, 1e-6),
            triad_arw_deg_rt_h=max(sensor_params.triad.arw_deg_rt_h, 1e-9))
    core = FreeGyroPositioning(core_params)
    rm = meridian_radius(lat) + core_params.height_m
    rn = (prime_vertical_radius(lat) + core_params.height_m) * math.cos(lat)
    fixes, errs, covs, nees, hd, hd_er, reasons = [], [], [], [], [], [], []
    yaw_hist: list[tuple[float, float]] = []
    sailing = sensor_params.speed_m_s > 0.0
    for tr in truth:
        s = sensor.update_from_truth(tr, lat, lon, dt)
        yaw_hist.append((tr.t, tr.euler[2]))
        if sailing:
            core.on_velocity(s.t, s.velocity_n)
        core.on_level(s.t, s.roll, s.pitch)
        core.on_body_rates(s.t, s.omega_ib_b)
        fix = core.on_spin_axes(s.t, s.spin_a_b, s.spin_b_b).output
        if fix is None:
            continue
        if not fix.valid:
            reasons.append(fix.reason)
            continue
        lat_t, lon_t = sailing_position(lat, lon, sensor_params.velocity_n, fix.t) if sailing else (lat, lon)
        e = np.array([(fix.lat - lat_t) * rm, math.remainder(fix.lon - lon_t, math.tau) * rn])
        fixes.append(fix)
        errs.append(e)
        covs.append(fix.cov_ne_m)
        nees.append(float(e @ np.linalg.solve(fix.cov_ne_m, e)))
        # true window-mean heading: circular mean of the yaw over the fix window's read-outs
        half = 0.5 * (fix.n_samples - 1) * dt + 0.25 * dt
        ys = [y for (tt, y) in yaw_hist[-fix.n_samples - 2:] if abs(tt - fix.t) <= half]
        mean_yaw = math.atan2(sum(math.sin(y) for y in ys), sum(math.cos(y) for y in ys))
        hd.append(math.remainder(fix.heading - mean_yaw, math.tau))
        if math.isfinite(fix.heading_earth_rate):
            T = core_params.heading_window_s
            ys = [y for (tt, y) in yaw_hist if fix.heading_earth_rate_t - T / 2 <= tt <= fix.heading_earth_rate_t + T / 2]
            mean_yaw = math.atan2(sum(math.sin(y) for y in ys), sum(math.cos(y) for y in ys))
            hd_er.append(math.remainder(fix.heading_earth_rate - mean_yaw, math.tau))
        else:
            hd_er.append(_NAN)
    return FreeGyroRun(fixes, np.array(errs).reshape(-1, 2), np.array(covs).reshape(-1, 2, 2), np.array(nees),
                       np.array(hd), np.array(hd_er), len(reasons), reasons)


class FdopMonteCarlo(NamedTuple):
    """Pooled Monte Carlo of fix errors: ``empirical_cov_ne_m`` vs ``predicted_cov_ne_m``
    (mean of the fixes' FDOP²σ² covariances) [m²], ``trace_ratio`` = empirical/predicted
    drms², ``variance_ratios`` (north, east), ``mean_nees`` (2 if consistent), the predicted
    ``fdop``, ``n_runs`` and ``n_fixes``; ``heading_error_std`` / ``heading_sigma_mean``
    [rad] for the free-gyro heading."""

    empirical_cov_ne_m: np.ndarray
    predicted_cov_ne_m: np.ndarray
    trace_ratio: float
    variance_ratios: np.ndarray
    mean_nees: float
    fdop: float
    n_runs: int
    n_fixes: int
    heading_error_std: float
    heading_sigma_mean: float


def _setup(options: dict) -> tuple:
    """(truth, sensor params, core params) of an FDOP Monte Carlo's options (every run shares
    the ship truth; only the sensor noise is seeded)."""
    u_a, u_b = make_spin_axes(options["lat_deg"], options["lon_deg"], 0.0, tuple(options["nadir_deg"]),
                              tuple(options["azimuth_deg"]))
    rate_hz, fix_interval_s = options["rate_hz"], options["fix_interval_s"]
    duration = options["fixes_per_run"] * fix_interval_s + 1.0 / rate_hz
    truth = simulate_truth(options["profile"], options["lat_deg"], options["lon_deg"], duration, rate_hz)
    sp = FreeGyroSensorParams(u_a, u_b, pickoff_noise_arcsec=options["pickoff_noise_arcsec"])
    cp = FreeGyroPositioningParams(u_a, u_b, nadir_noise_arcsec=options["pickoff_noise_arcsec"],
                                   fix_interval_s=fix_interval_s, heading_window_s=max(60.0, duration))
    return truth, sp, cp


#: The options of an FDOP Monte Carlo and their defaults (paper 4's ship at 35° N).
FDOP_DEFAULTS = {"fixes_per_run": 1, "lat_deg": 35.0, "lon_deg": 129.0, "profile": "paper5_ship", "rate_hz": 10.0,
                 "fix_interval_s": 10.0, "nadir_deg": [60.0, 50.0], "azimuth_deg": [-40.0, 50.0],
                 "pickoff_noise_arcsec": 5.0}
_SETUPS: dict[str, tuple] = {}   # per process: a campaign's runs share one truth


def campaign_run(variant: str, seed: int, options: dict) -> dict:
    """The campaign engine's core run (:data:`CAMPAIGN`): one seeded run of the free-gyro
    sensor and positioning cores on the shared ship truth; every fix's north/east error [m],
    FDOP²σ² covariance [m²], NEES and FDOP, the heading errors and claimed σ [rad]."""
    key = repr(sorted(options.items()))
    if key not in _SETUPS:
        _SETUPS.clear()
        _SETUPS[key] = _setup(options)
    truth, sp, cp = _SETUPS[key]
    run = run_free_gyro_experiment(seed, truth, options["lat_deg"], options["lon_deg"], sp, cp)
    return {"fixes": len(run.fixes), "withheld_fixes": run.degenerate,
            "errors_ne_m": run.errors_ne_m.tolist(), "cov_ne_m": run.cov_ne_m.tolist(), "nees": run.nees.tolist(),
            "fdop": [f.fdop for f in run.fixes], "heading_error_rad": run.heading_errors.tolist(),
            "heading_sigma_rad": [f.heading_sigma for f in run.fixes]}


def graph_translate(options: dict) -> tuple[float, tuple]:
    """The scenario ``free_gyro_positioning`` set up as :func:`_setup` sets the cores: a run of
    ``fixes_per_run`` fix windows, the site in the ship, the sensors and the estimator's spin
    reference, the spin-axis geometry and pickoff noise in the sensors and in the estimator
    alike (the ship keeps the scenario's mean heading)."""
    duration = options["fixes_per_run"] * options["fix_interval_s"] + 1.0 / options["rate_hz"]
    nadir, azimuth, noise = list(options["nadir_deg"]), list(options["azimuth_deg"]), options["pickoff_noise_arcsec"]
    lat, lon = options["lat_deg"], options["lon_deg"]
    return duration, (("vehicle_dynamics.profile_params", f"{{lat_deg: {lat!r}, lon_deg: {lon!r}, mean_heading_deg: 40.0}}"),
                      ("sensor_models.free_gyro_site_lat_deg", lat), ("sensor_models.free_gyro_site_lon_deg", lon),
                      ("free_gyro_positioning.spin_reference_lat_deg", lat),
                      ("free_gyro_positioning.spin_reference_lon_deg", lon),
                      ("sensor_models.free_gyro_nadir_deg", nadir), ("free_gyro_positioning.spin_nadir_deg", nadir),
                      ("sensor_models.free_gyro_azimuth_deg", azimuth),
                      ("free_gyro_positioning.spin_azimuth_deg", azimuth),
                      ("sensor_models.free_gyro_pickoff_noise_arcsec", noise),
                      ("free_gyro_positioning.nadir_noise_arcsec", noise),
                      ("free_gyro_positioning.fix_interval_s", options["fix_interval_s"]),
                      ("free_gyro_positioning.heading_window_s", max(60.0, duration)))


#: FDOP over seeded runs as a campaign, a declaration: scenario ``free_gyro_positioning``
#: (paper 4's ship and site; its sensor noise drawn from the sensor node's streams) on the
#: one engine (each run's bag and ``free_gyro`` report) or in the node graph; the table pools
#: the runs' reports (:func:`pooled_reports`). :func:`run_fdop_monte_carlo` is the cores'
#: own Monte Carlo in one process (the tests' reference).
CAMPAIGN = ExperimentCampaign(
    name="free_gyro", variants=("",), defaults=FDOP_DEFAULTS, run=None,
    graph=GraphEquivalent("free_gyro_positioning", {"": None},
                          ("fixes_per_run", "lat_deg", "lon_deg", "nadir_deg", "azimuth_deg", "pickoff_noise_arcsec",
                           "fix_interval_s"), graph_translate))


def pooled(runs: Sequence[dict]) -> FdopMonteCarlo:
    """Pooled error statistics of runs' figures (:func:`campaign_run`) against FDOP²σ²."""
    e = np.vstack([np.asarray(r["errors_ne_m"], dtype=float).reshape(-1, 2) for r in runs])
    emp = e.T @ e / len(e)  # zero-mean errors by construction: no mean is estimated
    pred = np.mean(np.concatenate([np.asarray(r["cov_ne_m"], dtype=float).reshape(-1, 2, 2) for r in runs]), axis=0)
    cat = lambda key: np.concatenate([np.asarray(r[key], dtype=float) for r in runs])  # noqa: E731
    return FdopMonteCarlo(
        empirical_cov_ne_m=emp, predicted_cov_ne_m=pred, trace_ratio=float(np.trace(emp) / np.trace(pred)),
        variance_ratios=np.diag(emp) / np.diag(pred), mean_nees=float(np.mean(cat("nees"))),
        fdop=float(np.mean(cat("fdop"))), n_runs=len(runs), n_fixes=len(e),
        heading_error_std=float(np.std(cat("heading_error_rad"))),
        heading_sigma_mean=float(np.mean(cat("heading_sigma_rad"))),
    )


def pooled_reports(reports: Sequence[dict]) -> FdopMonteCarlo:
    """:func:`pooled` from graph runs' ``free_gyro`` reports, which keep each run's fixes
    pooled already (empirical and claimed covariance, NEES and heading statistics over its n
    fixes): weighted by n, the same sums over every fix."""
    pos = [r["free_gyro"]["position"] for r in reports]
    n = np.array([p["n_fixes"] for p in pos], dtype=float)
    w = lambda values: np.tensordot(n, np.asarray(values, dtype=float), axes=1) / n.sum()  # noqa: E731
    emp, pred = w([p["empirical_cov_ne_m2"] for p in pos]), w([p["claimed_cov_ne_m2"] for p in pos])
    head = [r["free_gyro"]["heading"] for r in reports]
    hn = np.array([h["n"] for h in head], dtype=float)
    hw = lambda values: float(np.dot(hn, values) / hn.sum())  # noqa: E731
    mean = hw([h["mean_error_arcsec"] for h in head])
    std = math.sqrt(max(hw([h["rms_error_arcsec"] ** 2 for h in head]) - mean * mean, 0.0))
    return FdopMonteCarlo(
        empirical_cov_ne_m=emp, predicted_cov_ne_m=pred, trace_ratio=float(np.trace(emp) / np.trace(pred)),
        variance_ratios=np.diag(emp) / np.diag(pred), mean_nees=float(w([p["mean_nees"] for p in pos])),
        fdop=float(np.mean([r["free_gyro"]["fdop_mean"] for r in reports])), n_runs=len(reports),
        n_fixes=int(n.sum()), heading_error_std=std * ARCSEC,
        heading_sigma_mean=hw([h["mean_sigma_arcsec"] for h in head]) * ARCSEC)


def run_fdop_monte_carlo(n_runs: int = 200, *, first_seed: int = 1, **options) -> FdopMonteCarlo:
    """``n_runs`` seeded runs (the same ship truth, new sensor noise each) of
    ``fixes_per_run`` fix windows each, in this process; pooled error statistics against
    FDOP²σ² (``options``: :data:`FDOP_DEFAULTS`)."""
    unknown = set(options) - set(FDOP_DEFAULTS)
    if unknown:
        raise TypeError(f"unknown options {sorted(unknown)}")
    opts = {**FDOP_DEFAULTS, **options}
    return pooled([campaign_run("", first_seed + i, opts) for i in range(n_runs)])


def format_table(mc: FdopMonteCarlo) -> str:
    emp, pred = mc.empirical_cov_ne_m, mc.predicted_cov_ne_m
    return "\n".join([
        f"{mc.n_runs} runs, {mc.n_fixes} fixes, FDOP {mc.fdop:.4f}",
        f"  empirical cov (N, E) [m²]: {np.round(emp, 2).tolist()}",
        f"  FDOP²σ² cov  (N, E) [m²]: {np.round(pred, 2).tolist()}",
        f"  trace ratio {mc.trace_ratio:.4f}, variance ratios {np.round(mc.variance_ratios, 4).tolist()}, "
        f"mean NEES {mc.mean_nees:.3f} (2 if consistent)",
        f"  free-gyro heading error std / claimed σ: {mc.heading_error_std / mc.heading_sigma_mean:.3f}",
    ])


def main(argv: Sequence[str] | None = None) -> None:
    """``python -m gimbal_sim.experiments.free_gyro``: the FDOP Monte Carlo, printed."""
    ap = argparse.ArgumentParser(prog="python -m gimbal_sim.experiments.free_gyro",
                                 description="Free-gyro FDOP Monte Carlo (paper 4): seeded runs of the free-gyro "
                                             "sensor and positioning cores on a rolling ship; empirical north/east "
                                             "fix-error covariance against the claimed FDOP²σ². The runs go "
                                             "through gimbal-campaign's engine (--jobs, --scheduler, --out, "
                                             "--resume).")
    ap.add_argument("--runs", type=int, default=200, help="seeded runs")
    ap.add_argument("--fixes-per-run", type=int, default=1, help="fix windows per run")
    ap.add_argument("--lat-deg", type=float, default=35.0)
    ap.add_argument("--lon-deg", type=float, default=129.0)
    ap.add_argument("--nadir-deg", type=float, nargs=2, default=(60.0, 50.0), help="spin axes' nadir angles [deg]")
    ap.add_argument("--azimuth-deg", type=float, nargs=2, default=(-40.0, 50.0), help="their azimuths [deg]")
    ap.add_argument("--pickoff-noise-arcsec", type=float, default=5.0)
    add_engine_arguments(ap, graph=True)
    a = ap.parse_args(argv)
    if a.runs < 1 or a.fixes_per_run < 1:
        ap.error("--runs and --fixes-per-run must be >= 1")
    options = {**FDOP_DEFAULTS, "fixes_per_run": a.fixes_per_run, "lat_deg": a.lat_deg, "lon_deg": a.lon_deg,
               "nadir_deg": list(a.nadir_deg), "azimuth_deg": list(a.azimuth_deg),
               "pickoff_noise_arcsec": a.pickoff_noise_arcsec}
    spec = CampaignSpec(scenario="", experiment=CAMPAIGN.name, seeds=tuple(range(1, a.runs + 1)), engine=a.engine,
                        mode=a.mode, options=tuple(options.items()))
    with campaign_dir(a.out) as out:
        runs = [m for _, m in run_metrics(run_for_cli(ap, a, spec, out, CAMPAIGN, run_on_engine))[""]]
    print(format_table(pooled_reports(runs)))


if __name__ == "__main__":
    main()
