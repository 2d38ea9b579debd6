"""``gimbal-geometry``: sighting-chain and free-gyro geometry from the command line.

Degrees at this edge only; the library works in radians.
"""
from __future__ import annotations

import argparse
import math
import sys

import numpy as np

from ..maths.free_gyro import fix_geometry, gyro_azimuth, nadir_angle
from ..maths.geo_pointing import GimbalLimits, PointingSigmas, geo_point, pointing_budget
from ..maths.sighting_chain import dcm_nb, dcm_nm, los_azimuth_elevation
from ..maths.units import ARCSEC
from .boundary import UsageError, cli_boundary


def _los(args: argparse.Namespace) -> int:
    euler = [math.radians(v) for v in args.euler_deg]
    joints = [math.radians(v) for v in args.joints_deg]
    az, el = los_azimuth_elevation(dcm_nm(euler, *joints))
    print(f"LOS azimuth {math.degrees(az):.6f} deg  elevation {math.degrees(el):.6f} deg (NED)")
    return 0


def _fdop(args: argparse.Namespace) -> int:
    lat, lon = math.radians(args.lat_deg), math.radians(args.lon_deg)
    gyros = {}
    for name, vec in (("a", args.gyro_a), ("b", args.gyro_b)):
        u = np.asarray(vec, dtype=float)
        norm = float(np.linalg.norm(u))
        if norm == 0.0:
            raise ValueError(f"--gyro-{name}: spin-axis vector is zero")
        gyros[name] = u / norm
    for name, u in gyros.items():
        theta = nadir_angle(u, lat, lon, args.time_s)
        alpha = gyro_azimuth(u, lat, lon, args.time_s)
        print(f"gyro {name}: nadir angle {math.degrees(theta):.4f} deg  azimuth {math.degrees(alpha):.4f} deg")
    geom = fix_geometry(gyros["a"], gyros["b"], lat, lon, args.time_s)
    sigma = args.sigma_arcsec * ARCSEC
    print(f"FDOP {geom.fdop:.4f} (north/east arcs)  paper form sqrt(q_ll + q_LL) {geom.fdop_latlon:.4f}")
    print(f"position error (drms) {geom.position_error_m(sigma):.1f} m for nadir-angle sigma {args.sigma_arcsec:g} arcsec")
    return 0


def _flag(value: bool) -> str:
    return "yes" if value else "no"


def _point(args: argparse.Namespace) -> int:
    vehicle = (math.radians(args.vehicle[0]), math.radians(args.vehicle[1]), args.vehicle[2])
    target = (math.radians(args.target[0]), math.radians(args.target[1]), args.target[2])
    C_nb = dcm_nb(*(math.radians(v) for v in args.euler_deg))
    az_lo, az_hi = args.azimuth_limits_deg
    el_lo, el_hi = args.elevation_limits_deg
    limits = GimbalLimits(math.radians(az_lo), math.radians(az_hi), math.radians(el_lo),
                          math.radians(el_hi), args.handover)
    sigmas = PointingSigmas(*(math.radians(v) for v in args.sigma_attitude_deg),
                            *args.sigma_vehicle_m, *args.sigma_target_m)
    los, sol = geo_point(vehicle, C_nb, target, math.radians(args.turret_deg), limits, args.lever_arm_m)
    budget = pointing_budget(vehicle, C_nb, target, sigmas, args.lever_arm_m)
    deg = math.degrees
    print(f"range {los.range_m:.3f} m")
    print(f"LOS azimuth {deg(los.azimuth_rad):.6f} deg  elevation {deg(los.elevation_rad):.6f} deg (NED)")
    print(f"joints turret {deg(sol.psi_t):.6f} deg  gimbal azimuth {deg(sol.psi_m):.6f} deg  "
          f"elevation {deg(sol.theta_m):.6f} deg")
    print(f"limits azimuth {_flag(sol.azimuth_limited)}  elevation {_flag(sol.elevation_limited)}  "
          f"turret handover {_flag(sol.turret_handover)}  singular {_flag(sol.singular)}  "
          f"residual {sol.residual_rad * 1e3:.4f} mrad")
    print("pointing error budget, 1-sigma:")
    for name, value in budget.terms.items():
        print(f"  {name.replace('_', ' ')} {value * 1e3:.4f} mrad")
    major, minor = budget.principal_sigmas_rad
    print(f"  total (RMS) {budget.total_rad * 1e3:.4f} mrad  semi-axes {major * 1e3:.4f} {minor * 1e3:.4f} mrad")
    print(f"  95 % radius {budget.radius_95_rad * 1e3:.4f} mrad (the error angle is within it 95 % of the time)")
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="gimbal-geometry",
        description="Geometry of stabilized sighting platforms: LOS pointing of the paper 1 "
        "sighting chain, and the free-gyro position-fix geometry (FDOP) of paper 4.",
    )
    sub = parser.add_subparsers(dest="command", required=True)
    los = sub.add_parser("los", help="LOS azimuth/elevation in NED from host attitude and encoders")
    los.add_argument("--euler-deg", nargs=3, type=float, required=True, metavar=("ROLL", "PITCH", "YAW"),
                     help="host 3-2-1 Euler angles [deg]")
    los.add_argument("--joints-deg", nargs=3, type=float, required=True, metavar=("PSI_T", "PSI_M", "THETA_M"),
                     help="turret azimuth, gimbal azimuth, gimbal elevation [deg]")
    los.set_defaults(func=_los)
    fdop = sub.add_parser("fdop", help="free-gyro fix geometry: nadir angles, azimuths, FDOP, position error")
    fdop.add_argument("--lat-deg", type=float, required=True, help="geodetic latitude [deg]")
    fdop.add_argument("--lon-deg", type=float, required=True, help="longitude [deg]")
    fdop.add_argument("--gyro-a", nargs=3, type=float, required=True, metavar=("UX", "UY", "UZ"),
                      help="spin axis of gyro a, inertial components (normalised)")
    fdop.add_argument("--gyro-b", nargs=3, type=float, required=True, metavar=("UX", "UY", "UZ"),
                      help="spin axis of gyro b, inertial components (normalised)")
    fdop.add_argument("--time-s", type=float, default=0.0, help="time since the inertial epoch [s]")
    fdop.add_argument("--sigma-arcsec", type=float, default=10.0, help="nadir-angle error 1-sigma [arcsec]")
    fdop.set_defaults(func=_fdop)
    _add_point_parser(sub)
    return parser


def _add_point_parser(sub: argparse._SubParsersAction) -> None:
    point = sub.add_parser("point", help="geo-pointing: LOS to a WGS-84 target, the gimbal angles that point "
                           "the sight at it, and the 1-sigma pointing-error budget")
    point.add_argument("--vehicle", nargs=3, type=float, required=True, metavar=("LAT_DEG", "LON_DEG", "H_M"),
                       help="INS position: geodetic latitude, longitude [deg], height above the ellipsoid [m]")
    point.add_argument("--euler-deg", nargs=3, type=float, required=True, metavar=("ROLL", "PITCH", "YAW"),
                       help="host 3-2-1 Euler angles [deg]")
    point.add_argument("--target", nargs=3, type=float, required=True, metavar=("LAT_DEG", "LON_DEG", "H_M"),
                       help="target position, as --vehicle")
    point.add_argument("--turret-deg", type=float, default=0.0, help="current turret azimuth psi_t [deg]")
    point.add_argument("--lever-arm-m", nargs=3, type=float, default=(0.0, 0.0, 0.0), metavar=("X", "Y", "Z"),
                       help="gimbal pivot from the INS reference point, body FRD [m]")
    point.add_argument("--azimuth-limits-deg", nargs=2, type=float, default=(-180.0, 180.0), metavar=("MIN", "MAX"),
                       help="gimbal azimuth psi_m limits relative to the turret [deg] (a 360 deg span: none)")
    point.add_argument("--elevation-limits-deg", nargs=2, type=float, default=(-90.0, 90.0), metavar=("MIN", "MAX"),
                       help="gimbal elevation theta_m limits [deg], within [-90, 90]")
    point.add_argument("--handover", choices=("stop", "turret"), default="stop",
                       help="at the azimuth limit: stop there, or turn the turret by the rest")
    point.add_argument("--sigma-attitude-deg", nargs=3, type=float, default=(0.05, 0.05, 0.2),
                       metavar=("ROLL", "PITCH", "HEADING"), help="INS attitude error 1-sigma [deg] (paper 1's)")
    point.add_argument("--sigma-vehicle-m", nargs=2, type=float, default=(0.0, 0.0), metavar=("H", "V"),
                       help="vehicle position error 1-sigma per horizontal axis and vertical [m]")
    point.add_argument("--sigma-target-m", nargs=2, type=float, default=(0.0, 0.0), metavar=("H", "V"),
                       help="target position error 1-sigma per horizontal axis and vertical [m]")
    point.set_defaults(func=_point)


def _check_finite(args: argparse.Namespace) -> None:
    """Every number given finite (NaN or inf in, NaN out is no answer) and every 1-sigma >= 0,
    before anything is printed."""
    for name, value in vars(args).items():
        values = value if isinstance(value, (list, tuple)) else [value]
        option = f"--{name.replace('_', '-')}"
        for v in values:
            if isinstance(v, float) and not math.isfinite(v):
                raise UsageError(f"{option} must be finite, got {value}")
            if name.startswith("sigma") and isinstance(v, float) and v < 0.0:
                raise UsageError(f"{option} is a 1-sigma and must be >= 0, got {value}")


@cli_boundary("gimbal-geometry")
def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    _check_finite(args)
    return args.func(args)


if __name__ == "__main__":
    sys.exit(main())
