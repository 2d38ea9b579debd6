"""``gimbal-geometry``: sighting-chain and free-gyro geometry from the command line.

Degrees at this edge only; the library works in radians.
"""
from __future__ import annotations

import argparse
import math
import sys

import numpy as np

from .free_gyro import fix_geometry, gyro_azimuth, nadir_angle
from .sighting_chain import dcm_nm, los_azimuth_elevation

ARCSEC = math.radians(1.0 / 3600.0)


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
    return parser


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        return args.func(args)
    except ValueError as exc:
        print(f"gimbal-geometry: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
