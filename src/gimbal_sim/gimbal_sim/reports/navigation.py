"""The ``navigation`` report: paper 3's static navigation (§4.3, Fig. 8) from the bag.

Series (decoded one message at a time):

* ``/platform_navigator/fix`` and ``/platform_navigator/velocity``: the navigator's
  position (NavSatFix) and NED velocity;
* ``/truth/host/fix`` and ``/truth/host/velocity``: the vehicle's true position and
  velocity (interpolated to the navigator's stamps);
* ``/platform_servo/control_error``: the servo's eq. 1 control signals (level and azimuth);
* ``/truth/platform/gyro_bias``, ``/truth/platform/accel_bias``: the sensors' true biases;
* ``/platform_servo/torquer_current`` (a servo on DTGs): the torquer currents.

Figures: north, east and radial position error [m] and the north and east velocity error
[m/s] against time; the radial error at the end and its largest value, each as a rate in
n mile/h (error / elapsed hours, the unit of paper 3's 0.38 n mile/h CEP); the Schuler
period read off the run — the period of the sinusoid plus trend that best fits both
velocity errors, scanned over 40–160 min — beside the local 2π√(R/g) (84.4 min); the
control error (rms and largest |Δθ|, arc-seconds) of the four loops. On DTGs, the azimuth
torquer current per direction of rotation (its sign), mean [mA] and relative standard
deviation, leaving out the first ``TORQUER_SETTLE_S`` and that long after each reversal; after
a hand-off, also the navigator's torque-out of the handed misalignment (its ``torque_out_s``,
from the run's ``scenario.yaml``), whose command-rate pulse is in the currents.

After a prelude (``original_system``, ``upgraded``: the chained alignment run), the run
directory's ``hand_off.json`` (:mod:`.hand_off`) goes into the metrics as ``hand_off``, with
``sensor_biases_carried``: whether the navigation run's true sensor biases are the alignment
run's (to 1e-3 °/h and µg, the first samples of each: an in-run drift moves less in one step).
"""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import yaml

from gimbal_estimators.platform_navigator_params import PlatformNavigatorParams
from gimbal_kinematics.maths.earth import meridian_radius, normal_gravity, prime_vertical_radius
from gimbal_kinematics.maths.units import ARCSEC, NMI_M, UG

from ..bag.reader import BagError
from ..figures import save_stacked, stacked, style
from .hand_off import FIGURES_FILE
from .platform_servo import bag_summary, stream_columns, torquer_legs

FIX, VELOCITY = "/platform_navigator/fix", "/platform_navigator/velocity"
TRUTH_FIX, TRUTH_VELOCITY = "/truth/host/fix", "/truth/host/velocity"
CONTROL_ERROR = "/platform_servo/control_error"
GYRO_BIAS, ACCEL_BIAS = "/truth/platform/gyro_bias", "/truth/platform/accel_bias"
TORQUER = "/platform_servo/torquer_current"
LOOPS = ("azimuth", "inner_roll", "pitch", "outer_roll")
#: torquer samples left out at the start and after each reversal (the loops' transients) [s]
TORQUER_SETTLE_S = 5.0

_fix = lambda msg: (math.radians(msg.latitude), math.radians(msg.longitude), msg.altitude)  # noqa: E731
_vec = lambda msg: (msg.vector.x, msg.vector.y, msg.vector.z)  # noqa: E731


def schuler_period_s(lat: float, height: float = 0.0) -> float:
    """2π√(R/g) with R the Gaussian mean radius at ``lat`` [rad] and WGS-84 normal gravity."""
    r = math.sqrt(meridian_radius(lat) * prime_vertical_radius(lat)) + height
    return 2.0 * math.pi * math.sqrt(r / normal_gravity(lat, height))


def fitted_period_s(t: np.ndarray, series: np.ndarray, lo_s: float = 2400.0, hi_s: float = 9600.0) -> float | None:
    """The period [s] of a + b·t + c·sin(2πt/P) + d·cos(2πt/P) fitted to each column of
    ``series`` (N, m) that leaves the least squared residual, scanned over [lo_s, hi_s];
    None when the run is shorter than ``lo_s``."""
    if len(t) < 8 or t[-1] - t[0] < lo_s:
        return None
    periods = np.arange(lo_s, hi_s, 6.0)
    cost = np.empty(len(periods))
    tt = t - t[0]
    for i, p in enumerate(periods):
        w = 2.0 * math.pi / p
        design = np.column_stack([np.ones_like(tt), tt, np.sin(w * tt), np.cos(w * tt)])
        _, res, _, _ = np.linalg.lstsq(design, series, rcond=None)
        cost[i] = float(np.sum(res)) if len(res) else math.inf
    return float(periods[int(np.argmin(cost))])


def navigation_errors(bag_dir: Path) -> dict:
    """Time [s], position error (N, E) [m], radial [m], velocity error (N, E, D) [m/s], the
    control signals and the true biases, from the bag."""
    extract = {FIX: _fix, VELOCITY: _vec, TRUTH_FIX: _fix, TRUTH_VELOCITY: _vec,
               CONTROL_ERROR: lambda msg: tuple(msg.position), GYRO_BIAS: _vec, ACCEL_BIAS: _vec,
               TORQUER: lambda msg: tuple(msg.effort)}
    cols, contents = stream_columns(bag_dir, extract)
    t, fix = cols[FIX]
    tv, vel = cols[VELOCITY]
    t_truth, truth = cols[TRUTH_FIX]
    if len(t) == 0 or len(t_truth) == 0:
        raise BagError(f"{bag_dir}: the bag needs {FIX} and {TRUTH_FIX}")
    true_at = np.column_stack([np.interp(t, t_truth, truth[:, i]) for i in range(3)])
    tvt, vel_truth = cols[TRUTH_VELOCITY]
    lat0 = float(true_at[0, 0])
    rm, rn = meridian_radius(lat0) + true_at[:, 2], prime_vertical_radius(lat0) + true_at[:, 2]
    d_n = (fix[:, 0] - true_at[:, 0]) * rm
    d_e = np.remainder(fix[:, 1] - true_at[:, 1] + math.pi, 2.0 * math.pi) - math.pi
    d_e = d_e * rn * np.cos(true_at[:, 0])
    vel_true = np.column_stack([np.interp(tv, tvt, vel_truth[:, i]) for i in range(3)]) if len(tvt) else 0.0 * vel
    return {"t": t - t[0], "pos_ne": np.column_stack([d_n, d_e]), "radial": np.hypot(d_n, d_e),
            "t_vel": tv - t[0], "vel": vel - vel_true, "lat": lat0, "height": float(true_at[0, 2]),
            "control": cols[CONTROL_ERROR][1], "gyro_bias": cols[GYRO_BIAS][1], "accel_bias": cols[ACCEL_BIAS][1],
            "torquer": cols[TORQUER], "contents": contents}


def navigation_figures(e: dict, torquer_start_s: float = TORQUER_SETTLE_S) -> dict:
    """The report's figures (module docstring) from :func:`navigation_errors`; the torquer
    current's legs from ``torquer_start_s`` after the first sample."""
    t, radial = e["t"], e["radial"]
    hours = max(t[-1], 1e-9) / 3600.0
    i_max = int(np.argmax(radial))
    period = fitted_period_s(e["t_vel"], e["vel"][:, :2])
    control = e["control"] / ARCSEC
    out = {
        "duration_s": float(t[-1]),
        "final_position_error_m": {"north": float(e["pos_ne"][-1, 0]), "east": float(e["pos_ne"][-1, 1]),
                                   "radial": float(radial[-1])},
        "max_radial_error_m": float(radial[i_max]), "max_radial_error_at_s": float(t[i_max]),
        "final_radial_rate_nmi_h": float(radial[-1] / NMI_M / hours),
        "max_radial_rate_nmi_h": float(radial[i_max] / NMI_M / hours),
        "max_velocity_error_m_s": {"north": float(np.max(np.abs(e["vel"][:, 0]))),
                                   "east": float(np.max(np.abs(e["vel"][:, 1])))},
        "schuler_period_min": None if period is None else period / 60.0,
        "schuler_period_theory_min": schuler_period_s(e["lat"], e["height"]) / 60.0,
        "control_error_arcsec": {name: {"rms": float(np.sqrt(np.mean(control[:, i] ** 2))),
                                        "max": float(np.max(np.abs(control[:, i])))}
                                 for i, name in enumerate(LOOPS)} if control.size else {},
    }
    if len(e["gyro_bias"]):
        out["true_gyro_bias_deg_h"] = (np.degrees(e["gyro_bias"][0]) * 3600.0).tolist()
    if len(e["accel_bias"]):
        out["true_accel_bias_ug"] = (e["accel_bias"][0] / UG).tolist()
    if len(e["torquer"][0]):
        out["dtg_torquer_current"] = torquer_figures(*e["torquer"], start_s=torquer_start_s)
    return out


def torquer_figures(t: np.ndarray, current: np.ndarray, start_s: float = TORQUER_SETTLE_S) -> dict:
    """The azimuth torquer current's legs (module docstring) from the stamps [s] and the
    (x, y, z) currents [A], from ``start_s`` on; the level currents' largest magnitude [mA]."""
    i_z = current[:, 2]
    direction = np.sign(i_z)
    steady = t - t[0] >= start_s
    for t_rev in t[1:][direction[1:] != direction[:-1]]:
        steady &= ~((t >= t_rev) & (t < t_rev + TORQUER_SETTLE_S))
    return {"azimuth": torquer_legs(i_z, direction, steady),
            "level_max_abs_ma": float(1e3 * np.max(np.abs(current[:, :2])))}


def _torque_out_s(run_dir: Path) -> float:
    """The navigator's ``torque_out_s`` in the run's ``scenario.yaml`` (its default if unset)."""
    default = PlatformNavigatorParams().torque_out_s
    scenario = Path(run_dir) / "scenario.yaml"
    if not scenario.is_file():
        return default
    nodes = (yaml.safe_load(scenario.read_text()) or {}).get("nodes", {})
    nav = next((n.get("params", {}) for n in nodes.values() if n.get("executable") == "platform_navigator"), {})
    return float(nav.get("torque_out_s", default))


def _hand_off(path: Path, nav: dict) -> dict:
    """The prelude's hand-off figures, and whether the true biases are the same (module docstring)."""
    hand_off = json.loads(path.read_text())
    carried = [(hand_off[k], nav.get(k)) for k in ("true_gyro_bias_deg_h", "true_accel_bias_ug")]
    hand_off["sensor_biases_carried"] = all(b is not None and np.allclose(a, b, rtol=0.0, atol=1e-3)
                                            for a, b in carried)
    return hand_off


def _plot(e: dict, path: Path, title: str) -> None:
    fig, axes = stacked(2, 6.0)
    t_min = e["t"] / 60.0
    axes[0, 0].plot(t_min, e["pos_ne"][:, 0], label="north")
    axes[0, 0].plot(t_min, e["pos_ne"][:, 1], label="east")
    axes[0, 0].plot(t_min, e["radial"], label="radial", color="k")
    style(axes[0, 0], "position error [m]")
    axes[1, 0].plot(e["t_vel"] / 60.0, e["vel"][:, 0], label="north")
    axes[1, 0].plot(e["t_vel"] / 60.0, e["vel"][:, 1], label="east")
    style(axes[1, 0], "velocity error [m/s]")
    save_stacked(fig, axes, path, title, xlabel="time [min]")


def navigation_report(bag_dir: Path, report_dir: Path) -> dict:
    """Write ``navigation_errors.png``; return the figures (module docstring) and the bag summary."""
    e = navigation_errors(bag_dir)
    handed = (Path(bag_dir) / FIGURES_FILE).is_file()
    start = TORQUER_SETTLE_S + (_torque_out_s(bag_dir) if handed else 0.0)
    metrics = {"navigation": navigation_figures(e, start), **bag_summary(bag_dir, e["contents"])}
    if handed:
        metrics["hand_off"] = _hand_off(Path(bag_dir) / FIGURES_FILE, metrics["navigation"])
    report_dir.mkdir(parents=True, exist_ok=True)
    nav = metrics["navigation"]
    _plot(e, report_dir / "navigation_errors.png",
          f"static navigation: radial error {nav['final_radial_rate_nmi_h']:.2f} n mile/h at "
          f"{nav['duration_s'] / 3600.0:.2f} h")
    metrics["plots"] = ["navigation_errors.png"]
    return metrics


def rotation_comparison(runs: dict[str, Path], report_dir: Path) -> dict:
    """The variants' figures side by side and the radial-rate ratio rotation_off / rotation_on."""
    figures = {name: navigation_figures(navigation_errors(bag)) for name, bag in runs.items()}
    lines = [f"{'variant':<14}{'radial@end [m]':>16}{'rate [nmi/h]':>14}{'max rate':>10}{'Schuler [min]':>15}"]
    for name, f in figures.items():
        period = f["schuler_period_min"]
        lines.append(f"{name:<14}{f['final_position_error_m']['radial']:>16.1f}{f['final_radial_rate_nmi_h']:>14.3f}"
                     f"{f['max_radial_rate_nmi_h']:>10.3f}{'-' if period is None else f'{period:.1f}':>15}")
    out: dict = {"variants": figures}
    if {"rotation_on", "rotation_off"} <= set(figures):
        on, off = (figures[v]["final_radial_rate_nmi_h"] for v in ("rotation_on", "rotation_off"))
        out["rate_ratio_off_on"] = off / on if on > 0 else None
        lines.append(f"rotation_off / rotation_on radial rate: {out['rate_ratio_off_on']:.2f} (paper 3: 2 / 0.38)")
    report_dir.mkdir(parents=True, exist_ok=True)
    out["table"] = "\n".join(lines)
    return out
