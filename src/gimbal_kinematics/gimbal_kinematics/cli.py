"""``gimbal-geometry``: sighting-chain and free-gyro geometry from the command line.

Degrees at this edge only; the library works in radians.
"""
from __future__ import annotations

import argparse
import math
import sys

from .sighting_chain import dcm_nm, los_azimuth_elevation


def _los(args: argparse.Namespace) -> int:
    euler = [math.radians(v) for v in args.euler_deg]
    joints = [math.radians(v) for v in args.joints_deg]
    az, el = los_azimuth_elevation(dcm_nm(euler, *joints))
    print(f"LOS azimuth {math.degrees(az):.6f} deg  elevation {math.degrees(el):.6f} deg (NED)")
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="gimbal-geometry",
        description="Geometry of stabilized sighting platforms (SPEC section 2): LOS pointing "
        "of the paper 1 sighting chain.",
    )
    sub = parser.add_subparsers(dest="command", required=True)
    los = sub.add_parser("los", help="LOS azimuth/elevation in NED from host attitude and encoders")
    los.add_argument("--euler-deg", nargs=3, type=float, required=True, metavar=("ROLL", "PITCH", "YAW"),
                     help="host 3-2-1 Euler angles [deg]")
    los.add_argument("--joints-deg", nargs=3, type=float, required=True, metavar=("PSI_T", "PSI_M", "THETA_M"),
                     help="turret azimuth, gimbal azimuth, gimbal elevation [deg]")
    los.set_defaults(func=_los)
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
