"""``gimbal-allan``: characterise a gyro or accelerometer at rest from any rosbag2 bag.

Reads one sensor_msgs/Imu topic (MCAP or sqlite3, streamed), computes the overlapping
Allan deviation of each measured axis with its confidence interval, fits the IEEE Std 952
noise terms jointly with their uncertainties, and writes to ``--out DIR``: ``allan.json``,
``adev_<axis>.png``, ``sensor_models.yaml`` (a ``--params-file`` that simulates this sensor),
``filters.yaml`` (the filters' noise parameters) and ``set_args.txt`` (the same simulator
values as ``gimbal-run --set`` arguments). Bad input exits 2 with a message naming the
argument; nothing existing is overwritten.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from gimbal_kinematics.cli_boundary import UsageError, cli_boundary, creatable

from ..bag.any_reader import AnyBagError
from .analyze import ACCEL_SIGMA_PREFIX, AXES, AnalysisError, SIGMA_PREFIX, UNITS, analyze, to_json
from .params import ACCEL_TARGETS, GYRO_TARGETS, filters_yaml, sensor_models_yaml, set_arguments
from .plot import plot_all
from .stream import FIELDS, read_imu_field

OUTPUTS = ("allan.json", "sensor_models.yaml", "filters.yaml", "set_args.txt")


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="gimbal-allan",
        description="Characterise a gyro (or accelerometer) recorded at rest: read a sensor_msgs/Imu topic from any "
                    "rosbag2 bag (MCAP or sqlite3), compute the overlapping Allan deviation of each axis with its "
                    "confidence interval (allantools, octave-spaced tau), fit the IEEE Std 952 noise terms jointly "
                    "with their 1-sigma (quantisation, angle/velocity random walk, Gauss-Markov bias instability "
                    "with its correlation time and the flicker floor, rate random walk, rate ramp), and write a plot "
                    "per axis, a JSON file, a sensor_models parameter file that simulates the sensor and the "
                    "filters' matching noise parameters.",
        epilog="Exit status: 0 done, 2 bad input (the message names the argument). "
               "Docs: docs/gyro-characterisation.md.")
    parser.add_argument("bag", metavar="BAG", help="rosbag2 bag directory (or its .mcap / .db3 file)")
    parser.add_argument("--topic", required=True, help="sensor_msgs/Imu topic to characterise")
    parser.add_argument("--field", choices=tuple(FIELDS), default="angular_velocity",
                        help="gyro (angular_velocity, default) or accelerometer (linear_acceleration)")
    parser.add_argument("--axes", nargs="+", choices=AXES, metavar="AXIS",
                        help="axes to analyse (x y z); default: every axis the messages do not mark as unmeasured "
                             "(a diagonal variance >= 1e6)")
    parser.add_argument("--out", type=Path, required=True, metavar="DIR",
                        help="output directory (created; files already in it are not overwritten)")
    parser.add_argument("--json", type=Path, metavar="FILE", help="also write the JSON result to FILE")
    parser.add_argument("--tau-max-s", type=float, metavar="S",
                        help="longest averaging time [s]; the record must last 10x as long (default: a tenth "
                             "of the record)")
    parser.add_argument("--gaps", choices=("split", "refuse"), default="split",
                        help="a gap or irregular step in the stamps: analyse the evenly sampled segments "
                             "(split, default) or refuse the record; never interpolated")
    parser.add_argument("--simulate-as", metavar="SENSOR",
                        help=f"sensor_models sensor the parameter file sets: gyro {sorted(GYRO_TARGETS)} (default "
                             f"gimbal_gyro), accelerometer {sorted(ACCEL_TARGETS)}")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")
    return parser


def _refuse(option: str, message: str) -> int:
    print(f"gimbal-allan: {option}: {message}" if option else f"gimbal-allan: {message}", file=sys.stderr)
    return 2


def summary(doc: dict) -> str:
    """A few lines per axis for the terminal."""
    lines = [f"{doc['topic']} {doc['field']}: {doc['duration_s'] / 3600.0:.3g} h at {doc['sample_rate_hz']:.4g} Hz, "
             f"{doc['messages']} messages, sampling: {doc['sampling']['segments']} segment(s) "
             f"(step jitter {doc['sampling']['jitter_rms']:.2%} RMS), "
             f"{doc['nonfinite_dropped']} non-finite dropped"]
    for axis, why in doc["skipped_axes"].items():
        lines.append(f"  axis {axis} skipped: {why}")
    field = doc["field"]
    prefix = SIGMA_PREFIX if field == "angular_velocity" else ACCEL_SIGMA_PREFIX
    pairs = [(UNITS[field][t].key, f"{prefix[t]}_sigma") for t in ("white", "gauss_markov", "rrw", "quantization",
                                                                    "ramp")]
    for axis, terms in doc["axes"].items():
        if terms["dead"]:
            lines.append(f"  {axis}: dead (the output never changes): no term detected")
            continue
        parts = [f"{key} {terms[key]:.4g} ± {terms[sig]:.2g}" for key, sig in pairs if terms[key] is not None]
        if terms.get("bias_tau_s"):
            parts.append(f"bias_tau_s {terms['bias_tau_s']:.4g} ± {terms['bias_tau_sigma']:.2g}")
        lines.append(f"  {axis}: " + ", ".join(parts))
        absent = [f"{key} < {bound:.2g}" if bound is not None else key for key, bound in terms["not_detected"].items()]
        lines.append("     not detected: " + ", ".join(absent))
        lines += [f"     FLAGGED {key}: {why}" for key, why in terms["flagged"].items()]
    return "\n".join(lines)


def _check_outputs(args: argparse.Namespace) -> None:
    """Every output can be written, before the analysis and before any file is: nothing is
    half-written when one of them cannot be."""
    if args.out.exists() and not args.out.is_dir():
        raise UsageError(f"--out: {args.out} exists and is not a directory")
    existing = [args.out / name for name in OUTPUTS if (args.out / name).exists()]
    existing += sorted(args.out.glob("adev_*.png")) if args.out.is_dir() else []
    if existing:
        raise UsageError(f"--out: {', '.join(map(str, existing))} already exist(s); not overwriting")
    if not args.out.is_dir():
        creatable(args.out, "--out")
    if args.json is not None:
        if args.json.exists():
            raise UsageError(f"--json: {args.json} already exists; not overwriting it")
        creatable(args.json, "--json")


@cli_boundary("gimbal-allan")
def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    target = args.simulate_as or ("gimbal_gyro" if args.field == "angular_velocity" else "platform_accel")
    targets = GYRO_TARGETS if args.field == "angular_velocity" else ACCEL_TARGETS
    if target not in targets:
        return _refuse("--simulate-as", f"{target!r} cannot simulate {args.field}; choose one of {sorted(targets)}")
    _check_outputs(args)
    if args.tau_max_s is not None and not args.tau_max_s > 0:
        return _refuse("--tau-max-s", f"must be > 0, got {args.tau_max_s}")
    try:
        data = read_imu_field(args.bag, args.topic, args.field, progress=False if args.no_progress else None)
    except AnyBagError as exc:
        option = "--topic" if "topic" in str(exc) else "BAG"
        return _refuse(option, str(exc))
    try:
        result = analyze(data, axes=args.axes, tau_max_s=args.tau_max_s, gaps=args.gaps)
    except AnalysisError as exc:
        return _refuse(exc.option, str(exc))
    doc = to_json(result)

    args.out.mkdir(parents=True, exist_ok=True)
    text = json.dumps(doc, indent=2) + "\n"
    (args.out / "allan.json").write_text(text)
    if args.json is not None:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(text)
    plots = plot_all(result, args.out)
    source = str(args.bag)
    (args.out / "sensor_models.yaml").write_text(sensor_models_yaml(result, target, source))
    (args.out / "filters.yaml").write_text(filters_yaml(result, target, source))
    (args.out / "set_args.txt").write_text(" ".join(set_arguments(result, target)) + "\n")
    if result.sampling.segments and not result.sampling.regular:
        print(f"gimbal-allan: warning: the sampling breaks ({result.sampling.describe()}); analysed "
              f"{len(result.sampling.segments)} evenly sampled segments", file=sys.stderr)
    for axis, terms in doc["axes"].items():
        for key, why in terms["flagged"].items():
            print(f"gimbal-allan: warning: axis {axis}: {key} flagged ({why}): left out of sensor_models.yaml, "
                  "filters.yaml and set_args.txt", file=sys.stderr)
    print(summary(doc))
    print(f"wrote {args.out}: allan.json, {', '.join(p.name for p in plots)}, sensor_models.yaml "
          f"(as {target}), filters.yaml, set_args.txt")
    return 0


if __name__ == "__main__":
    sys.exit(main())
