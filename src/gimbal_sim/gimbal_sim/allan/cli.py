"""``gimbal-allan``: characterise a gyro or accelerometer at rest from any rosbag2 bag.

Reads one sensor_msgs/Imu topic (MCAP or sqlite3, streamed), computes the overlapping
Allan deviation of each measured axis with its confidence interval, fits the IEEE Std 952
noise terms jointly with their uncertainties, and writes to ``--out DIR``: ``allan.json``,
``adev_<axis>.png``, ``sensor_models.yaml`` (a ``--params-file`` that simulates this sensor),
``filters.yaml`` (the filters' noise parameters) and ``set_args.txt`` (the same simulator
values as ``gimbal-run --set`` arguments). ``--kalibr FILE`` also characterises the topic's
other field and writes Kalibr's IMU noise file; ``--from-kalibr FILE`` and
``--from-allan-variance-ros FILE`` read such a file (no bag) into the same parameter files
(:mod:`.kalibr`). Bad input exits 2 with a message naming the argument; nothing existing is
overwritten.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from gimbal_kinematics.cli.boundary import UsageError, cli_boundary, creatable

from ..bag.any_reader import AnyBagError
from .analyze import ACCEL_SIGMA_PREFIX, AXES, AnalysisError, SIGMA_PREFIX, UNITS, analyze, to_json
from . import kalibr
from .params import (ACCEL_TARGETS, DATASHEET, GYRO_TARGETS, datasheet_params, filters_yaml, sensor_models_params,
                     sensor_models_yaml, set_arguments)
from .plot import plot_all
from .stream import FIELDS, read_imu_field

OUTPUTS = ("allan.json", "sensor_models.yaml", "filters.yaml", "set_args.txt")
#: What --from-kalibr / --from-allan-variance-ros write (no analysis: no JSON, no plots).
FILE_OUTPUTS = OUTPUTS[1:]


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="gimbal-allan",
        description="Characterise a gyro (or accelerometer) recorded at rest: read a sensor_msgs/Imu topic from any "
                    "rosbag2 bag (MCAP or sqlite3), compute the overlapping Allan deviation of each axis with its "
                    "confidence interval (allantools, octave-spaced tau), fit the IEEE Std 952 noise terms jointly "
                    "with their 1-sigma (quantisation, angle/velocity random walk, Gauss-Markov bias instability "
                    "with its correlation time and the flicker floor, rate random walk, rate ramp), and write a plot "
                    "per axis, a JSON file, a sensor_models parameter file that simulates the sensor and the "
                    "filters' matching noise parameters; --kalibr also writes Kalibr's IMU noise file (imu.yaml). "
                    "Or, without a bag, read a Kalibr or allan_variance_ros imu.yaml into the same parameter "
                    "files (--from-kalibr, --from-allan-variance-ros).",
        epilog="Exit status: 0 done, 2 bad input (the message names the argument). "
               "Docs: docs/gyro-characterisation.md.")
    parser.add_argument("bag", metavar="BAG", nargs="?",
                        help="rosbag2 bag directory (or its .mcap / .db3 file); not with --from-kalibr or "
                             "--from-allan-variance-ros")
    parser.add_argument("--topic", help="sensor_msgs/Imu topic to characterise (needed with BAG)")
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
    parser.add_argument("--kalibr", type=Path, metavar="FILE",
                        help="also characterise the topic's other field and write Kalibr's IMU noise file (imu.yaml: "
                             "continuous-time noise densities and bias random walks, largest over the axes)")
    source = parser.add_mutually_exclusive_group()
    source.add_argument("--from-kalibr", type=Path, metavar="FILE",
                        help="instead of a bag, read a Kalibr imu.yaml into sensor_models.yaml, filters.yaml and "
                             "set_args.txt")
    source.add_argument("--from-allan-variance-ros", type=Path, metavar="FILE",
                        help="the same for the imu.yaml allan_variance_ros (analysis.py) writes")
    parser.add_argument("--bias-tau-s", type=float, metavar="S",
                        help="with --from-*: gyro_bias_ekf's bias correlation time [s] for the file's random walk "
                             "(default: gyro_bias_ekf's own default for the channel)")
    for option, help_ in (("--scale-factor-ppm", "the data sheet's scale-factor error"),
                          ("--scale-asymmetry-ppm", "the data sheet's scale-factor asymmetry"),
                          ("--misalignment-urad", "the data sheet's axis misalignment (each off-diagonal element)")):
        parser.add_argument(option, type=float, metavar="X",
                            help=f"{help_}, 1-sigma: a record at rest does not show it; written into "
                                 f"sensor_models.yaml and set_args.txt as the sensor's per-run draw (and as a comment "
                                 f"of --kalibr's file)")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")
    return parser


def _datasheet(args: argparse.Namespace) -> dict[str, float | None]:
    """The data sheet's figures given (:data:`.params.DATASHEET`); ``UsageError`` naming the
    option of a value that is not a finite number >= 0."""
    out = {}
    for key, (option, _) in DATASHEET.items():
        value = getattr(args, option[2:].replace("-", "_"))
        if value is not None and not (value >= 0.0 and value != float("inf")):
            raise UsageError(f"{option}: must be a finite number >= 0, got {value}")
        out[key] = value
    return out


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


def _check_outputs(args: argparse.Namespace, outputs: tuple[str, ...] = OUTPUTS) -> None:
    """Every output can be written, before the analysis and before any file is: nothing is
    half-written when one of them cannot be."""
    if args.out.exists() and not args.out.is_dir():
        raise UsageError(f"--out: {args.out} exists and is not a directory")
    existing = [args.out / name for name in outputs if (args.out / name).exists()]
    existing += sorted(args.out.glob("adev_*.png")) if args.out.is_dir() else []
    if existing:
        raise UsageError(f"--out: {', '.join(map(str, existing))} already exist(s); not overwriting")
    if not args.out.is_dir():
        creatable(args.out, "--out")
    for option, path in (("--json", args.json), ("--kalibr", args.kalibr)):
        if path is not None:
            if path.exists():
                raise UsageError(f"{option}: {path} already exists; not overwriting it")
            creatable(path, option)


def _from_file(args: argparse.Namespace, target: str) -> int:
    """--from-kalibr / --from-allan-variance-ros: the file's noise model as parameter files."""
    option = "--from-kalibr" if args.from_kalibr is not None else "--from-allan-variance-ros"
    path = args.from_kalibr if args.from_kalibr is not None else args.from_allan_variance_ros
    for given, name in ((args.bag, "BAG"), (args.topic, "--topic"), (args.kalibr, "--kalibr")):
        if given is not None:
            return _refuse(name, f"not with {option} (the file is the input)")
    if target not in GYRO_TARGETS:
        return _refuse("--simulate-as", f"{target!r}: the file's gyro can be simulated as {sorted(GYRO_TARGETS)}")
    tau = kalibr.default_bias_tau_s(target) if args.bias_tau_s is None else args.bias_tau_s
    if not (tau > 0 and tau != float("inf")):
        return _refuse("--bias-tau-s", f"must be > 0 and finite, got {args.bias_tau_s}")
    _check_outputs(args, FILE_OUTPUTS)
    imu = kalibr.read_kalibr(path, option)
    files = kalibr.parameter_files(imu, target, tau, str(path), _datasheet(args))
    args.out.mkdir(parents=True, exist_ok=True)
    for name, text in files.items():
        (args.out / name).write_text(text)
    for note in imu.notes:
        print(f"gimbal-allan: note: {note}", file=sys.stderr)
    print(f"{path}: gyro {imu.gyroscope_noise_density:.4g} rad/s/sqrt(Hz), walk {imu.gyroscope_random_walk:.4g} "
          f"rad/s^2/sqrt(Hz); accelerometer {imu.accelerometer_noise_density:.4g} m/s^2/sqrt(Hz), walk "
          f"{imu.accelerometer_random_walk:.4g} m/s^3/sqrt(Hz)")
    print(f"wrote {args.out}: {', '.join(files)} (gyro as {target}, gyro_bias_ekf tau {tau:g} s)")
    return 0


def _kalibr_imu(args: argparse.Namespace, result) -> kalibr.KalibrImu:
    """--kalibr: characterise the topic's other field too; Kalibr's model of the two."""
    other = "linear_acceleration" if result.is_gyro else "angular_velocity"
    try:
        data = read_imu_field(args.bag, args.topic, other, progress=False if args.no_progress else None)
        second = analyze(data, tau_max_s=args.tau_max_s, gaps=args.gaps)
    except (AnyBagError, AnalysisError) as exc:
        raise UsageError(f"--kalibr: Kalibr's file needs both the gyro and the accelerometer of {args.topic}; "
                         f"{other}: {exc}") from exc
    gyro, accel = (result, second) if result.is_gyro else (second, result)
    return kalibr.from_characterisations(gyro, accel)


@cli_boundary("gimbal-allan")
def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    target = args.simulate_as or ("gimbal_gyro" if args.field == "angular_velocity" else "platform_accel")
    targets = GYRO_TARGETS if args.field == "angular_velocity" else ACCEL_TARGETS
    if args.from_kalibr is not None or args.from_allan_variance_ros is not None:
        return _from_file(args, args.simulate_as or "gimbal_gyro")
    for given, name in ((args.bag, "BAG"), (args.topic, "--topic")):
        if given is None:
            return _refuse(name, "required (or read a noise file with --from-kalibr / --from-allan-variance-ros)")
    if args.bias_tau_s is not None:
        return _refuse("--bias-tau-s", "only with --from-kalibr or --from-allan-variance-ros (a bag's fit gives tau)")
    if target not in targets:
        return _refuse("--simulate-as", f"{target!r} cannot simulate {args.field}; choose one of {sorted(targets)}")
    _check_outputs(args)
    datasheet = _datasheet(args)
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
    imu = _kalibr_imu(args, result) if args.kalibr is not None else None  # before any file is written

    args.out.mkdir(parents=True, exist_ok=True)
    text = json.dumps(doc, indent=2) + "\n"
    (args.out / "allan.json").write_text(text)
    if args.json is not None:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(text)
    plots = plot_all(result, args.out)
    source = str(args.bag)
    (args.out / "sensor_models.yaml").write_text(sensor_models_yaml(result, target, source, datasheet))
    (args.out / "filters.yaml").write_text(filters_yaml(result, target, source))
    sim = {**sensor_models_params(result, target), **datasheet_params(target, datasheet)}
    (args.out / "set_args.txt").write_text(" ".join(set_arguments(sim)) + "\n")
    if imu is not None:
        args.kalibr.parent.mkdir(parents=True, exist_ok=True)
        args.kalibr.write_text(kalibr.kalibr_yaml(imu, source, datasheet if result.is_gyro else None))
        for note in imu.notes:
            print(f"gimbal-allan: note: {note}", file=sys.stderr)
    if result.sampling.segments and not result.sampling.regular:
        print(f"gimbal-allan: warning: the sampling breaks ({result.sampling.describe()}); analysed "
              f"{len(result.sampling.segments)} evenly sampled segments", file=sys.stderr)
    for axis, terms in doc["axes"].items():
        for key, why in terms["flagged"].items():
            print(f"gimbal-allan: warning: axis {axis}: {key} flagged ({why}): left out of sensor_models.yaml, "
                  "filters.yaml and set_args.txt", file=sys.stderr)
    print(summary(doc))
    print(f"wrote {args.out}: allan.json, {', '.join(p.name for p in plots)}, sensor_models.yaml "
          f"(as {target}), filters.yaml, set_args.txt" + (f"; {args.kalibr}" if args.kalibr is not None else ""))
    return 0


if __name__ == "__main__":
    sys.exit(main())
