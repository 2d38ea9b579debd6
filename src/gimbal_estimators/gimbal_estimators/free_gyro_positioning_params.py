"""The ``free_gyro_positioning`` node's parameter table and --help text, readable without ROS
(the node declares them; the config generator and the scenario checks read them). The
mapping to the core's parameters is
:meth:`.free_gyro_positioning.FreeGyroPositioningParams.from_values`.
"""
from __future__ import annotations

import math

from gimbal_kinematics.params import CLOCK_JUMP_ALIASES, TIMING_PARAM, Param

DESCRIPTION = (
    "Paper 4 free-gyro positioning and directional system: integrates the nadir angles of two free "
    "gyros over each fix window, fixes latitude/longitude from them (eq. 1) with an FDOP-scaled "
    "covariance, and the heading from the gyro azimuths (Fig. 4) and from the earth rate (eq. 3-4). "
    "Publishes sensor_msgs/NavSatFix on /free_gyro_positioning/fix; no fix for degenerate geometry."
)
INF = math.inf

PARAMS = (
    TIMING_PARAM,
    Param("sim_rate_hz", 10.0, "simulation rate [Hz], to turn read-out stamps into lockstep steps", 1.0, 100000.0),
    Param("progress_every_steps", 10, "report on ~/progress (time of the next step needed) every N steps; "
          "vehicle_dynamics waits for and paces on it", 1, 10**6),
    Param("wait_for_subscribers", 0, "matched subscriptions each output needs before ~/progress reports ready",
          0, 1000),
    Param("spin_nadir_deg", [60.0, 50.0], "nadir angles (gyro a, gyro b) of the spin axes at the reference "
          "position and time [deg], each in (0, 180); with the azimuths they define the inertial spin axes"),
    Param("spin_azimuth_deg", [-40.0, 50.0], "azimuths from north toward east (gyro a, gyro b) of the spin axes "
          "at the reference position and time [deg]"),
    Param("spin_reference_lat_deg", 35.0, "latitude where the spin axes had those angles [deg] (e.g. where "
          "the gyros were set; the fix does not use it)", -90.0, 90.0),
    Param("spin_reference_lon_deg", 129.0, "longitude of that reference [deg]", -180.0, 180.0),
    Param("spin_reference_time_s", 0.0, "sim time of that reference [s] (inertial frame: Greenwich on x_i "
          "at t = 0); in free timing the stamps' time base, e.g. an epoch time", -1e10, 1e10),
    Param("nadir_noise_arcsec", 5.0, "1-sigma of one read-out nadir angle [arcsec] (pickoff noise)", 1e-9, INF),
    Param("fix_interval_s", 10.0, "nadir integration window per fix [s]", 1e-6, INF),
    Param("min_samples", 5, "fewest read-outs in a window for a fix", 3, 10**9),
    Param("heading_window_s", 60.0, "earth-rate heading averaging window [s]", 1e-6, INF),
    Param("triad_arw_deg_rt_h", 0.002, "body triad angle random walk [deg/sqrt(h)], for the earth-rate heading "
          "sigma", 1e-12, INF),
    Param("max_fdop", 20.0, "FDOP above which the geometry counts as degenerate and no fix is published [-] "
          "(>= sqrt(2))", 1.0, INF),
    Param("height_m", 0.0, "height above the ellipsoid reported as altitude and used for the metric covariance "
          "[m] (free gyros do not observe it)", -1e4, 1e5),
    Param("height_sigma_m", 100.0, "1-sigma of that height [m] (the vertical element of the NavSatFix "
          "covariance)", 0.0, INF),
    Param("velocity_input", False, "take the ship's NED ground velocity from /free_gyro/velocity "
          "(geometry_msgs/Vector3Stamped [m/s], one per read-out, same stamp) for the transport rate of the "
          "earth-rate heading (false: the ship is at rest)"),
    Param("predict_error", False, "publish the linear error model's predicted errors of each fix on "
          "~/predicted_nadir, ~/predicted_position and ~/predicted_heading (paper 4 eq. 19-38)"),
    Param("error_triad_bias_deg_h", 0.0, "model input: 1-sigma per axis of the triad's constant bias [deg/h]",
          0.0, INF),
    Param("error_level_arcsec", 0.0, "model input: 1-sigma of the vertical reference's constant roll and pitch "
          "errors [arcsec]", 0.0, INF),
    Param("error_spin_drift_deg_h", 0.0, "model input: 1-sigma per axis of each spin axis's constant drift since "
          "spin_reference_time_s [deg/h]", 0.0, INF),
    Param("clock_jump_s", 1.0, "a read-out stamp this far [s] behind the last one resets the node "
          "(bag loop)", 1e-9, INF, aliases=CLOCK_JUMP_ALIASES),
)
