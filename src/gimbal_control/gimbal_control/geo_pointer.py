"""Geo-pointing: keep the LOS on a geographic target through the controller's
operator input. Pure Python, no rclpy; the node is :mod:`.geo_pointer_node`.

Each step takes the gimbal attitude estimate Ĉ_nm (the gyro-bias EKF's), the INS attitude
C_nb and the measured turret angle ψt, and returns a LOS rate command (q, r) [rad/s] in the
sight frame, the operator input of ``los_rate_controller`` (added to its stabilisation
reference, so the controller itself is unchanged):

* the direction u_n to the target from the sight pivot (INS position + lever arm), exact on
  the WGS-84 ellipsoid (:func:`gimbal_kinematics.maths.geo_pointing.los_to_target`);
* the aim: u_n itself, or, when the joints cannot reach it
  (:func:`~gimbal_kinematics.maths.geo_pointing.joint_angles_for_los` with the gimbal limits), the
  LOS of the joints stopped at the limit. The turret here is the vehicle's (paper 1's
  revolving turret follows its own profile), so the pointer cannot hand azimuth over to it:
  it stops at the limit and counts the steps (``azimuth_limited_steps``,
  ``elevation_limited_steps``; ``singular_steps`` at el_b = ±90°);
* feed-forward: the rate of the aim in inertial space, ω_ie + (v_n × u_n) / R. The target is
  fixed to the earth, which turns at the earth rate ω_ie, while the rate loop holds the LOS
  inertially: without it the LOS would lag the target by |ω_ie × u| / k (up to 73 µrad at
  k = 1/s). A vehicle moving at v_n (NED, over the ground) turns the direction to the target
  relative to the earth: d = r_T − r_P changes at −v, so u = d/R turns at
  u × du/dt = (v × u) / R (the lever arm's motion with the vehicle's rotation is left out);
* feedback: k times the error angles in the estimated sight frame, the law of
  :func:`.los_hold.sight_frame_error` (the LOS-hold outer loop's), the sum limited per axis
  to ``max_rate_rad_s`` (below the controller's operator rate limit, which refuses more).

The vehicle position is the parameter ``vehicle_llh`` (paper 1's land vehicle keeps its site:
its profile moves the attitude, not the position, and its simulated INS publishes no
position) until :meth:`GeoPointer.set_vehicle` gives an INS position (and velocity), which
each following step uses: the direction, the earth rate at its latitude, the budget. A
position that is not finite, or within ``min_range_m`` of the target, is counted
(``rejected_fixes``) and not used.

The 1σ pointing-error budget (:func:`~gimbal_kinematics.maths.geo_pointing.pointing_budget`) from
the INS attitude and position accuracy, the target's position accuracy and the range comes
with every step.

Bad input: a target nearer than ``min_range_m`` (one at the vehicle's own position has no
direction) or non-finite is refused at construction (``GeoPointerParams``) and, as a new
target on :meth:`GeoPointer.set_target`, counted (``rejected_targets``) and not used.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from gimbal_kinematics.maths.earth import earth_rate_n
from gimbal_kinematics.maths.geo_pointing import (
    MIN_RANGE_M, GimbalLimits, JointSolution, PointingBudget, PointingSigmas, check_geodetic, joint_angles_for_los,
    los_to_target, pointing_budget,
)
from gimbal_kinematics.maths.sighting_chain import dcm_bm
from gimbal_kinematics.params.table import ParameterError
from gimbal_kinematics.maths.rotations import quat_to_dcm
from gimbal_kinematics.maths.units import DEG
from gimbal_kinematics.maths.validate import positive

from .los_hold import sight_frame_error

COUNTERS = ("rejected_targets", "rejected_fixes", "azimuth_limited_steps", "elevation_limited_steps",
            "singular_steps")


@dataclass(frozen=True)
class GeoPointerParams:
    """Target and vehicle (lat, lon [rad], h [m] WGS-84), gain k [1/s], rate limit
    [rad/s], gimbal limits, input 1σ errors, lever arm [m] (body), earth rate in the
    feed-forward, minimum range [m]."""

    target_llh: tuple[float, float, float]
    vehicle_llh: tuple[float, float, float]
    gain_1_s: float = 1.0
    max_rate_rad_s: float = 5.0 * DEG
    limits: GimbalLimits = GimbalLimits()
    sigmas: PointingSigmas = PointingSigmas()
    lever_arm_b: tuple[float, float, float] = (0.0, 0.0, 0.0)
    earth_rate: bool = True
    min_range_m: float = MIN_RANGE_M

    def __post_init__(self) -> None:
        for name in ("gain_1_s", "max_rate_rad_s"):
            positive(name, getattr(self, name))
        # a target the sight cannot point at is refused here, naming it
        los_to_target(check_geodetic("vehicle", self.vehicle_llh), check_geodetic("target", self.target_llh),
                      np.eye(3), self.lever_arm_b, self.min_range_m)

    @classmethod
    def from_values(cls, v: dict) -> GeoPointerParams:
        """From a ``geo_pointer`` node's values (degrees at the edge); :class:`ParameterError`
        names the parameter refused."""
        def llh(name: str) -> tuple[float, float, float]:
            x = v[name]
            if len(x) != 3 or not all(math.isfinite(float(c)) for c in x):
                raise ParameterError(f"parameter {name} must be 3 finite numbers (lat, lon [deg], h [m]), got {x!r}")
            return (float(x[0]) * DEG, float(x[1]) * DEG, float(x[2]))

        target, vehicle = llh("target_llh_deg"), llh("vehicle_llh_deg")
        def sigmas_of(name: str, n: int) -> list[float]:
            x = [float(c) for c in v[name]]
            if len(x) != n:
                raise ValueError(f"{name} must be {n} numbers, got {x}")
            return x

        try:
            limits = GimbalLimits(v["azimuth_min_deg"] * DEG, v["azimuth_max_deg"] * DEG,
                                  v["elevation_min_deg"] * DEG, v["elevation_max_deg"] * DEG)
            att = [s * DEG for s in sigmas_of("ins_attitude_sigma_deg", 3)]
            sigmas = PointingSigmas(*att, *sigmas_of("vehicle_position_sigma_m", 2),
                                    *sigmas_of("target_position_sigma_m", 2))
        except ValueError as exc:
            raise ParameterError(f"parameter {exc}") from exc
        try:
            return cls(target, vehicle, v["gain_1_s"], v["max_rate_deg_s"] * DEG, limits, sigmas,
                       tuple(v["lever_arm_b_m"]), v["earth_rate"], v["min_range_m"])
        except ValueError as exc:
            raise ParameterError(f"parameter target_llh_deg: {exc}") from exc


@dataclass
class PointerOutput:
    """One step: the rate command (q, r) [rad/s], the error angles (elevation, azimuth)
    [rad] of the aim in the estimated sight frame, the joint solution, the budget, the
    direction to the target and the aim (the LOS the pointer steers to: the direction, or
    where the joints stop at a limit), unit vectors in NED."""

    command: tuple[float, float]
    error: tuple[float, float]
    solution: JointSolution
    budget: PointingBudget
    los_n: np.ndarray = field(repr=False)
    aim_n: np.ndarray = field(repr=False)


class GeoPointer:
    """The pointing law of the module docstring; :meth:`step` once per attitude estimate."""

    def __init__(self, params: GeoPointerParams) -> None:
        self.params = params
        self.target_llh = params.target_llh
        self.vehicle_llh = params.vehicle_llh
        self.vehicle_vel_n = np.zeros(3)
        self.counts = dict.fromkeys(COUNTERS, 0)
        self._psi_m = 0.0

    def set_target(self, target_llh) -> bool:
        """A new target (lat, lon [rad], h [m]); False (counted) if it is not finite or too
        near the vehicle, and the old one stays."""
        p = self.params
        try:
            target = check_geodetic("target", target_llh)
            los_to_target(self.vehicle_llh, target, np.eye(3), p.lever_arm_b, p.min_range_m)
        except ValueError:
            self.counts["rejected_targets"] += 1
            return False
        self.target_llh = target
        return True

    def fix_error(self, vehicle_llh) -> str | None:
        """Why the INS position (lat, lon [rad], h [m]) cannot be used (not finite, out of
        range, or within ``min_range_m`` of the target), or None; counts nothing."""
        try:
            los_to_target(check_geodetic("vehicle", vehicle_llh), self.target_llh, np.eye(3),
                          self.params.lever_arm_b, self.params.min_range_m)
        except ValueError as exc:
            return str(exc)
        return None

    def take_target(self, target_llh, has_fix: bool = True) -> bool:
        """A target as a receiver reports it: :meth:`set_target`, or refused and counted
        (``rejected_targets``) when the receiver has no fix."""
        if not has_fix:
            self.counts["rejected_targets"] += 1
            return False
        return self.set_target(target_llh)

    def check_fix(self, vehicle_llh) -> bool:
        """Whether an INS position can be used (:meth:`fix_error`); one that cannot is counted
        (``rejected_fixes``)."""
        if self.fix_error(vehicle_llh) is None:
            return True
        self.counts["rejected_fixes"] += 1
        return False

    def set_vehicle(self, vehicle_llh, velocity_n=None) -> bool:
        """The vehicle's INS position (lat, lon [rad], h [m]) and, if given, its velocity
        over the ground (NED [m/s], (3,)) for the following steps; False (counted in
        ``rejected_fixes``) if either cannot be used, and the old ones stay."""
        vel = self.vehicle_vel_n if velocity_n is None else np.asarray(velocity_n, dtype=float)
        if self.fix_error(vehicle_llh) is not None or vel.shape != (3,) or not np.all(np.isfinite(vel)):
            self.counts["rejected_fixes"] += 1
            return False
        self.vehicle_llh = check_geodetic("vehicle", vehicle_llh)
        self.vehicle_vel_n = vel
        return True

    def feed_forward_n(self, los) -> np.ndarray:
        """The aim's inertial rate [rad/s] in NED (module docstring): the earth rate at the
        vehicle's latitude (if ``earth_rate``) plus the vehicle's translation, (v × u) / R."""
        w_n = earth_rate_n(self.vehicle_llh[0]) if self.params.earth_rate else np.zeros(3)
        return w_n + np.cross(self.vehicle_vel_n, los.los_n) / los.range_m

    def step(self, quat_nm, C_nb: np.ndarray, psi_t: float) -> PointerOutput:
        """Ĉ_nm as a quaternion (x, y, z, w), the INS C_nb and the turret angle [rad] → output."""
        p = self.params
        C_nm = quat_to_dcm(quat_nm)
        los = los_to_target(self.vehicle_llh, self.target_llh, C_nb, p.lever_arm_b, p.min_range_m)
        sol = joint_angles_for_los(C_nb, los.los_n, psi_t, p.limits, self._psi_m)
        aim = los.los_n
        if sol.residual_rad > 0.0:  # a limit stopped the joints: aim where they stop
            aim = C_nb @ dcm_bm(sol.psi_t, sol.psi_m, sol.theta_m)[:, 0]
        self._psi_m = sol.psi_m
        for flag, counter in ((sol.azimuth_limited, "azimuth_limited_steps"),
                              (sol.elevation_limited, "elevation_limited_steps"), (sol.singular, "singular_steps")):
            self.counts[counter] += int(flag)
        error = sight_frame_error(C_nm, aim)
        w_m = C_nm.T @ self.feed_forward_n(los)
        lim, k = p.max_rate_rad_s, p.gain_1_s
        command = tuple(max(-lim, min(lim, float(ff) + k * e)) for ff, e in zip(w_m[1:], error))
        budget = pointing_budget(self.vehicle_llh, C_nb, self.target_llh, p.sigmas, p.lever_arm_b, p.min_range_m)
        return PointerOutput(command, error, sol, budget, los.los_n, aim)  # type: ignore[arg-type]
