"""The ``free_gyro_positioning`` node's parameters and --help text, declared once in
:class:`FreeGyroPositioningNodeParams`. The mapping to the core's parameters is
:meth:`.free_gyro_positioning.FreeGyroPositioningParams.from_values`.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from gimbal_kinematics.params.table import CLOCK_JUMP_ALIASES, SHARED, TimedParams, declaration, param, same_as

INF = math.inf


@dataclass(frozen=True)
class FreeGyroPositioningNodeParams(TimedParams):
    """Paper 4 free-gyro positioning and directional system: integrates the nadir angles of two free gyros over
    each fix window, fixes latitude/longitude from them (eq. 1) with an FDOP-scaled covariance, and the heading
    from the gyro azimuths (Fig. 4) and from the earth rate (eq. 3-4). Publishes sensor_msgs/NavSatFix on
    /free_gyro_positioning/fix; no fix for degenerate geometry.
    """

    sim_rate_hz: float = param(10.0, "simulation rate, to turn read-out stamps into lockstep steps",
        1.0, 100000.0, unit="Hz")
    progress_every_steps: int = same_as(SHARED["progress_every_steps"])
    wait_for_subscribers: int = same_as(SHARED["wait_for_subscribers"])
    spin_nadir_deg: tuple[float, ...] = param((60.0, 50.0), "nadir angles (gyro a, gyro b) of the spin axes at the "
        "reference position and time, each in (0, 180); with the azimuths they define the inertial spin axes",
        unit="deg")
    spin_azimuth_deg: tuple[float, ...] = param((-40.0, 50.0), "azimuths from north toward east (gyro a, gyro b) of "
        "the spin axes at the reference position and time", unit="deg")
    spin_reference_lat_deg: float = param(35.0, "latitude where the spin axes had those angles (e.g. where the gyros "
        "were set; the fix does not use it)", -90.0, 90.0, unit="deg")
    spin_reference_lon_deg: float = param(129.0, "longitude of that reference", -180.0, 180.0, unit="deg")
    spin_reference_time_s: float = param(0.0, "sim time of that reference (inertial frame: Greenwich on x_i at t = "
        "0); in free timing the stamps' time base, e.g. an epoch time", -1e10, 1e10, unit="s")
    nadir_noise_arcsec: float = param(5.0, "1-sigma of one read-out nadir angle (pickoff noise)",
        1e-9, INF, unit="arcsec")
    fix_interval_s: float = param(10.0, "nadir integration window per fix", 1e-6, INF, unit="s")
    min_samples: int = param(5, "fewest read-outs in a window for a fix", 3, 10**9)
    heading_window_s: float = param(60.0, "earth-rate heading averaging window", 1e-6, INF, unit="s")
    triad_arw_deg_rt_h: float = param(0.002, "body triad angle random walk, for the earth-rate heading sigma",
        1e-12, INF, unit="deg/sqrt(h)")
    spin_rate_arw_deg_rt_h: float = param(0.0, "angle random walk of the spin-axis rate sensors whose integrated "
        "outputs (since spin_reference_time_s) are the read-outs, for the fix sigma (0: angle pickoffs)",
        0.0, INF, unit="deg/sqrt(h)")
    max_fdop: float = param(20.0, "FDOP above which the geometry counts as degenerate and no fix is published (>= "
        "sqrt(2))", 1.0, INF, unit="-")
    height_m: float = param(0.0, "height above the ellipsoid reported as altitude and used for the metric covariance "
        "(free gyros do not observe it)", -1e4, 1e5, unit="m")
    height_sigma_m: float = param(100.0, "1-sigma of that height (the vertical element of the NavSatFix covariance)",
        0.0, INF, unit="m")
    velocity_input: bool = param(False, "take the ship's NED ground velocity from /free_gyro/velocity "
        "(geometry_msgs/Vector3Stamped [m/s], one per read-out, same stamp) for the transport rate of the earth-rate "
        "heading (false: the ship is at rest)")
    predict_error: bool = param(False, "publish the linear error model's predicted errors of each fix on "
        "~/predicted_nadir, ~/predicted_position and ~/predicted_heading (paper 4 eq. 19-38)")
    error_triad_bias_deg_h: float = param(0.0, "model input: 1-sigma per axis of the triad's constant bias",
        0.0, INF, unit="deg/h")
    error_level_arcsec: float = param(0.0, "model input: 1-sigma of the vertical reference's constant roll and pitch "
        "errors", 0.0, INF, unit="arcsec")
    error_spin_drift_deg_h: float = param(0.0, "model input: 1-sigma per axis of each spin axis's constant drift "
        "since spin_reference_time_s", 0.0, INF, unit="deg/h")
    error_caging_arcsec: float = param(0.0, "model input: 1-sigma per axis of each rotor's uncaging error (its "
        "axis released away from where it was set)", 0.0, INF, unit="arcsec")
    error_gm_drift_deg_h: float = param(0.0, "model input: 1-sigma of each spin axis's first-order Gauss-Markov "
        "drift rate per axis", 0.0, INF, unit="deg/h")
    error_gm_drift_tau_s: float = param(300.0, "model input: correlation time of that Gauss-Markov drift",
        1e-6, INF, unit="s")
    clock_jump_s: float = param(1.0, "a read-out stamp this far behind the last one resets the node (bag loop)",
        1e-9, INF, unit="s", aliases=CLOCK_JUMP_ALIASES)


PARAMS, DESCRIPTION = declaration(FreeGyroPositioningNodeParams)
