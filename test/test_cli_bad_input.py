"""Every console command over a matrix of bad inputs (the bad-input acceptance).

The matrix is data: one row per (command, input), each naming the words its one-line
message must contain. Every row must exit with its documented code (docs/usage.md: 2 for
bad usage or input, 1 for a run or check that failed; :data:`EXIT_NOT_USAGE`), print no
traceback, and leave the folders that existed before exactly as they were (no file changed,
no file or folder created). The mains run in this process (their ``main(argv)``), on tiny
inputs: bags written by the ``rosbags`` writer (foreign_bags), damaged by cutting their
bytes, never through our own writer. Every console script of the four packages, and every
subcommand, has a row (:func:`test_every_console_command_has_a_row`); the 15 node
executables share one kind of row (a params file that is not text, refused before rclpy
starts), and a NaN parameter is run for two of them as separate processes.

"Unwritable" is a path under a regular file: nothing can be created there, even as root
(CI runs as root, where a read-only folder is still writable).
"""
from __future__ import annotations

import importlib
import os
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Callable

import numpy as np
import pytest

from conftest import VENV_BIN
from foreign_bags import synthetic_messages, write_rosbags
from test_workspace import PACKAGES, declared_console_scripts
from gimbal_kinematics.cli import geometry as geometry_cli
from gimbal_sim import campaign_cli, run_cli
from gimbal_sim.allan import cli as allan_cli
from gimbal_sim.bag import cli as bag_cli
from gimbal_sim.reports import dispatch as report_cli
from gimbal_sim.tools import bench as bench_cli

NOT_TEXT = b"\xff\xfe\x00\x9c\x81 not: [utf-8\n"


@pytest.fixture(scope="module")
def inputs(tmp_path_factory) -> dict[str, Path]:
    """The bad inputs, by name, in one folder; ``existing`` is an output folder that exists."""
    root = tmp_path_factory.mktemp("bad_input")
    rng = np.random.default_rng(27)
    good = write_rosbags(root / "good_bag", synthetic_messages(n_imu=40))
    data = next(good.glob("*.mcap")).read_bytes()
    paths = {"root": root, "good": good, "missing": root / "no_such_thing", "file": root / "plain.txt",
             "dir": root / "a_folder", "existing": root / "existing_out"}
    paths["file"].write_text("a file, not a folder\n")
    paths["dir"].mkdir()
    paths["existing"].mkdir()
    (paths["existing"] / "keep.txt").write_text("the user's data\n")
    for name, payload in (("empty", b""), ("random", rng.bytes(4096)), ("truncated", data[:len(data) // 2])):
        folder = root / f"{name}_bag"
        folder.mkdir()
        (folder / f"{name}_bag_0.mcap").write_bytes(payload)
        paths[name] = folder
    # a bag folder without metadata.yaml whose MCAP is complete (a recording killed after its
    # last chunk): readable, but not closed cleanly. `info` says so (exit 1) and gimbal-allan
    # refuses it; play, recover, compare and report read all of it (as ros2 bag play reads a
    # bare .mcap), so it has no row there
    paths["no_metadata"] = root / "no_metadata_bag"
    paths["no_metadata"].mkdir()
    (paths["no_metadata"] / "x_0.mcap").write_bytes(data)
    paths["empty_file"] = root / "empty.mcap"
    paths["empty_file"].write_bytes(b"")
    paths["not_text"] = root / "not_text.yaml"
    paths["not_text"].write_bytes(NOT_TEXT)
    paths["empty_yaml"] = root / "empty.yaml"
    paths["empty_yaml"].write_text("")
    paths["qos_typo"] = root / "qos_typo.yaml"
    paths["qos_typo"].write_text("/imu: {reliabilty: best_effort}\n")
    paths["unwritable"] = paths["file"] / "out"  # its parent is a file: nothing can be created there
    return paths


def _p(key: str, suffix: str = "") -> Callable[[dict[str, Path]], str]:
    return lambda paths: str(paths[key]) + suffix


#: (row id, main, argv (strings, or callables of the inputs), words the message must contain)
ROWS: list[tuple[str, Callable, list, list[str]]] = [
    # gimbal-run
    ("run/missing scenario file", run_cli.main, [_p("missing", ".yaml")], ["no_such_thing"]),
    ("run/scenario folder", run_cli.main, [_p("dir")], ["a_folder", "directory"]),
    ("run/non-text scenario", run_cli.main, [_p("not_text")], ["not_text.yaml", "not a text file"]),
    ("run/empty scenario", run_cli.main, [_p("empty_yaml")], ["empty.yaml"]),
    ("run/non-text params file", run_cli.main, ["sim_open_loop", "--params-file", _p("not_text")],
     ["--params-file", "not a text file"]),
    ("run/missing params file", run_cli.main, ["sim_open_loop", "--params-file", _p("missing")],
     ["--params-file", "no_such_thing"]),
    ("run/duration inf", run_cli.main, ["sim_open_loop", "--duration", "inf"], ["--duration", "finite"]),
    ("run/duration nan", run_cli.main, ["sim_open_loop", "--duration", "nan"], ["--duration", "finite"]),
    ("run/duration negative", run_cli.main, ["sim_open_loop", "--duration", "-1"], ["--duration", "> 0"]),
    ("run/existing out", run_cli.main, ["sim_open_loop", "--out", _p("existing")], ["existing_out", "exists"]),
    ("run/unwritable out", run_cli.main, ["sim_open_loop", "--out", _p("unwritable")], ["--out", "cannot create"]),
    # gimbal-report
    ("report/missing path", report_cli.main, [_p("missing")], ["no_such_thing", "no such"]),
    ("report/a file", report_cli.main, [_p("file")], ["plain.txt", "a file"]),
    ("report/a bag's mcap file", report_cli.main, [lambda p: str(next(p["good"].glob("*.mcap")))], ["a file"]),
    ("report/empty folder", report_cli.main, [_p("dir")], ["a_folder", "not a bag"]),
    ("report/empty bag", report_cli.main, [_p("empty")], ["no message can be read"]),
    ("report/random bytes", report_cli.main, [_p("random")], ["random_bag", "no message can be read"]),
    ("report/truncated bag", report_cli.main, [_p("truncated")], ["truncated_bag", "no message can be read"]),
    ("report/empty file", report_cli.main, [_p("empty_file")], ["empty.mcap", "a file"]),
    ("report/unknown report", report_cli.main, [_p("good"), "--report", "nope"], ["unknown report"]),
    # gimbal-bag
    ("bag info/missing", bag_cli.main, ["info", _p("missing")], ["no_such_thing"]),
    ("bag info/random bytes", bag_cli.main, ["info", _p("random")], ["Closed cleanly: NO"]),
    ("bag info/empty bag", bag_cli.main, ["info", _p("empty")], ["Closed cleanly: NO"]),
    ("bag info/bag without metadata", bag_cli.main, ["info", _p("no_metadata")],
     ["Closed cleanly: NO (no metadata.yaml)"]),
    ("bag recover/missing", bag_cli.main, ["recover", _p("missing"), "--out", _p("root", "/rec3")],
     ["no_such_thing"]),
    ("bag recover/empty bag", bag_cli.main, ["recover", _p("empty"), "--out", _p("root", "/rec4")],
     ["nothing to recover"]),
    ("bag recover/random bytes", bag_cli.main, ["recover", _p("random"), "--out", _p("root", "/rec1")],
     ["nothing to recover"]),
    ("bag recover/truncated", bag_cli.main, ["recover", _p("truncated"), "--out", _p("root", "/rec2")],
     ["nothing to recover"]),
    ("bag recover/existing out", bag_cli.main, ["recover", _p("good"), "--out", _p("existing")], ["already exists"]),
    ("bag recover/unwritable out", bag_cli.main, ["recover", _p("good"), "--out", _p("unwritable")], ["plain.txt"]),
    ("bag play/random bytes", bag_cli.main, ["play", _p("random"), "--rate", "0"], ["nothing to play"]),
    ("bag play/offset past the end", bag_cli.main, ["play", _p("good"), "--start-offset", "100"],
     ["nothing to play", "--start-offset"]),
    ("bag play/remap of a missing topic", bag_cli.main, ["play", _p("good"), "--remap", "/nope:=/x"],
     ["--remap", "/nope"]),
    ("bag play/topic filter", bag_cli.main, ["play", _p("good"), "--topics", "/nope"], ["--topics", "/nope"]),
    ("bag play/rate inf", bag_cli.main, ["play", _p("good"), "--rate", "inf"], ["--rate", "finite"]),
    ("bag play/rate nan", bag_cli.main, ["play", _p("good"), "--rate", "nan"], ["--rate"]),
    ("bag play/rate negative", bag_cli.main, ["play", _p("good"), "--rate", "-1"], ["--rate"]),
    ("bag play/start offset negative", bag_cli.main, ["play", _p("good"), "--start-offset", "-1"],
     ["--start-offset"]),
    ("bag play/missing", bag_cli.main, ["play", _p("missing"), "--rate", "0"], ["no_such_thing"]),
    ("bag play/empty file", bag_cli.main, ["play", _p("empty_file"), "--rate", "0"], ["empty.mcap"]),
    ("bag play/empty bag", bag_cli.main, ["play", _p("empty"), "--rate", "0"], ["nothing to play"]),
    ("bag play/truncated bag", bag_cli.main, ["play", _p("truncated"), "--rate", "0"], ["nothing to play"]),
    ("bag play/QoS file a folder", bag_cli.main, ["play", _p("good"), "--qos-profile-overrides-path", _p("dir")],
     ["--qos-profile-overrides-path", "a_folder"]),
    ("bag play/non-text QoS file", bag_cli.main, ["play", _p("good"), "--qos-profile-overrides-path",
                                                  _p("not_text")], ["--qos-profile-overrides-path", "text"]),
    ("bag play/misspelt QoS key", bag_cli.main, ["play", _p("good"), "--qos-profile-overrides-path",
                                                 _p("qos_typo")], ["reliabilty", "known keys"]),
    ("bag play/pace without reader", bag_cli.main, ["play", _p("good"), "--rate", "0", "--pace", "/nobody/progress",
                                                    "--wait-timeout", "0.5"], ["no reader came", "--wait-timeout"]),
    # gimbal-bench
    ("bench compare/random bytes", bench_cli.main, ["compare", _p("good"), _p("random")], ["damaged"]),
    ("bench compare/truncated", bench_cli.main, ["compare", _p("truncated"), _p("good")], ["damaged"]),
    ("bench compare/missing", bench_cli.main, ["compare", _p("good"), _p("missing")], ["no_such_thing"]),
    ("bench record/negative duration", bench_cli.main, ["record", "--duration", "-5"], ["--duration", "> 0"]),
    ("bench flexure/negative duration", bench_cli.main, ["flexure", "--duration", "-1"], ["--duration", "> 0"]),
    ("bench flexure/nan duration", bench_cli.main, ["flexure", "--duration", "nan"], ["--duration", "finite"]),
    ("bench run/existing keep", bench_cli.main, ["run", "--keep", _p("existing")], ["--keep", "exists"]),
    ("bench run/unwritable keep", bench_cli.main, ["run", "--keep", _p("unwritable"), "--duration", "1"],
     ["--keep", "cannot create"]),
    ("bench run/nan duration", bench_cli.main, ["run", "--duration", "nan"], ["--duration", "finite"]),
    ("bench record/inf duration", bench_cli.main, ["record", "--duration", "inf"], ["--duration", "finite"]),
    ("bench live/negative duration", bench_cli.main, ["live", "--duration", "-1"], ["--duration", "> 0"]),
    ("bench live/nan duration", bench_cli.main, ["live", "--duration", "nan"], ["--duration", "finite"]),
    ("bench compare/negative tolerance", bench_cli.main, ["compare", _p("good"), _p("good"), "--rel-tol", "-1"],
     ["--rel-tol", ">= 0"]),
    # gimbal-campaign
    ("campaign/resume of a missing folder", campaign_cli.main, ["--resume", "--out", _p("missing")],
     ["--resume", "no such campaign directory"]),
    ("campaign/non-text campaign file", campaign_cli.main, [_p("not_text")], ["not a text file"]),
    ("campaign/huge seed range", campaign_cli.main, ["sim_open_loop", "--seeds", "1-100000000", "--serial"],
     ["seeds", "more than"]),
    ("campaign/many runs", campaign_cli.main, ["sim_open_loop", "--seeds", "0-20000", "--serial", "--engine", "core"],
     ["--large"]),
    ("campaign/days by its own estimate", campaign_cli.main, ["sim_open_loop", "--seeds", "1-200", "--duration",
                                                             "7200", "--serial"], ["own estimate", "--large"]),
    ("campaign/duration inf", campaign_cli.main, ["sim_open_loop", "--duration", "inf"], ["--duration", "finite"]),
    ("campaign/duration nan", campaign_cli.main, ["sim_open_loop", "--duration", "nan"], ["--duration", "finite"]),
    ("campaign/duration negative", campaign_cli.main, ["sim_open_loop", "--duration", "-1"], ["--duration"]),
    ("campaign/existing out", campaign_cli.main, ["sim_open_loop", "--out", _p("existing"), "--serial"],
     ["existing_out", "--resume"]),
    ("campaign/unwritable out", campaign_cli.main, ["sim_open_loop", "--out", _p("unwritable"), "--serial"],
     ["--out", "cannot create"]),
    ("campaign diff/missing", campaign_cli.main, ["diff", _p("missing"), _p("dir")], ["no_such_thing"]),
    # gimbal-geometry
    ("geometry/NaN", geometry_cli.main, ["los", "--euler-deg", "nan", "0", "0", "--joints-deg", "0", "0", "0"],
     ["--euler-deg", "finite"]),
    ("geometry/inf", geometry_cli.main, ["fdop", "--lat-deg", "inf", "--lon-deg", "0", "--gyro-a", "1", "0", "0",
                                         "--gyro-b", "0", "1", "0"], ["--lat-deg", "finite"]),
    ("geometry/negative sigma", geometry_cli.main, ["fdop", "--lat-deg", "40", "--lon-deg", "0", "--gyro-a", "1", "0",
                                                    "0", "--gyro-b", "0", "1", "0", "--sigma-arcsec", "-1"],
     ["--sigma-arcsec", ">= 0"]),
    ("geometry point/NaN", geometry_cli.main, ["point", "--vehicle", "39.9", "32.8", "900", "--euler-deg", "0", "0",
                                               "0", "--target", "nan", "32.8", "900"], ["--target", "finite"]),
    ("geometry point/negative sigma", geometry_cli.main, ["point", "--vehicle", "39.9", "32.8", "900", "--euler-deg",
                                                          "0", "0", "0", "--target", "39.92", "32.8", "900",
                                                          "--sigma-attitude-deg", "0.05", "-0.05", "0.2"],
     ["--sigma-attitude-deg", ">= 0"]),
    # gimbal-allan
    ("allan/missing bag", allan_cli.main, [_p("missing"), "--topic", "/imu", "--out", _p("root", "/allan1")],
     ["no_such_thing"]),
    ("allan/random bytes", allan_cli.main, [_p("random"), "--topic", "/imu", "--out", _p("root", "/allan2")],
     ["random_bag"]),
    ("allan/existing out", allan_cli.main, [_p("good"), "--topic", "/imu", "--out", _p("existing"), "--json",
                                            _p("existing", "/keep.txt")], ["keep.txt"]),
    ("allan/unwritable json", allan_cli.main, [_p("good"), "--topic", "/imu", "--out", _p("root", "/allan3"), "--json",
                                               _p("unwritable", "/a.json")], ["--json", "cannot create"]),
    ("allan/unwritable out", allan_cli.main, [_p("good"), "--topic", "/imu", "--out", _p("unwritable")],
     ["--out", "cannot create"]),
    ("allan/out a file", allan_cli.main, [_p("good"), "--topic", "/imu", "--out", _p("file")],
     ["--out", "not a directory"]),
    ("allan/tau nan", allan_cli.main, [_p("good"), "--topic", "/imu", "--out", _p("root", "/allan4"), "--tau-max-s",
                                       "nan"], ["--tau-max-s"]),
    ("allan/bag without metadata", allan_cli.main, [_p("no_metadata"), "--topic", "/imu", "--out",
                                                    _p("root", "/allan5")], ["no metadata.yaml"]),
    # gimbal-run: a list value the node would refuse, refused before anything starts
    ("run/set list NaN", run_cli.main, ["free_gyro_positioning", "--set",
                                        "free_gyro_positioning.spin_nadir_deg=[.nan, 50.0]"], ["spin_nadir_deg"]),
    ("run/set list negative", run_cli.main, ["free_gyro_positioning", "--set",
                                             "free_gyro_positioning.spin_nadir_deg=[-60.0, 50.0]"],
     ["spin_nadir_deg", "(0, 180)"]),
    ("run/set list length", run_cli.main, ["free_gyro_positioning", "--set",
                                           "free_gyro_positioning.spin_nadir_deg=[60.0]"], ["spin_nadir_deg", "two"]),
    ("campaign/set list NaN", campaign_cli.main, ["free_gyro_positioning", "--engine", "core", "--serial", "--set",
                                                  "free_gyro_positioning.spin_nadir_deg=[.nan, 50.0]",
                                                  "--out", _p("missing")], ["spin_nadir_deg"]),
]

#: node executable -> module holding its ``main``: each has a row (a params file that is not text)
NODES = {
    "vehicle_dynamics": "gimbal_sim.nodes.vehicle_dynamics_node",
    "sensor_models": "gimbal_sim.nodes.sensor_models_node",
    "bag_recorder": "gimbal_sim.nodes.bag_recorder_node", "operator": "gimbal_sim.nodes.operator_node",
    "los_rate_controller": "gimbal_control.los_rate_controller_node",
    "encoder_fusion_controller": "gimbal_control.encoder_fusion_controller_node",
    "platform_servo": "gimbal_control.platform_servo_node", "geo_pointer": "gimbal_control.geo_pointer_node",
    "gyro_bias_ekf": "gimbal_estimators.gyro_bias_ekf_node",
    "free_gyro_positioning": "gimbal_estimators.free_gyro_positioning_node",
    "flexure_estimator": "gimbal_estimators.flexure_estimator_node",
    "platform_alignment": "gimbal_estimators.platform_alignment_node",
    "platform_navigator": "gimbal_estimators.platform_navigator_node",
    "mavlink_gimbal_device": "gimbal_sim.mavlink.mavlink_gimbal_device_node",
    "mavlink_gimbal_manager": "gimbal_sim.mavlink.mavlink_gimbal_manager_node",
}


def _node_main(module: str) -> Callable:
    return lambda argv: importlib.import_module(module).main(argv)


ROWS += [(f"{exe}/non-text params file", _node_main(module), [exe, "--ros-args", "--params-file", _p("not_text")],
          ["--params-file", "not_text.yaml", "not a text file"]) for exe, module in NODES.items()]
ROWS += [("gyro_bias_ekf/missing params file", _node_main(NODES["gyro_bias_ekf"]),
          ["gyro_bias_ekf", "--ros-args", "--params-file", _p("missing")], ["no_such_thing"])]

#: rows whose documented exit code is not 2 (bad usage or input), with why
EXIT_NOT_USAGE = {
    "bag info/random bytes": 1,  # info answers; the bag is not closed cleanly (a check that failed)
    "bag info/empty bag": 1,
    "bag info/bag without metadata": 1,
    "bag play/pace without reader": 1,  # a wait that timed out
}

#: console script -> (row-id prefix, the subcommands each needing a row)
COMMANDS = {"gimbal-run": ("run", ()), "gimbal-report": ("report", ()),
            "gimbal-bag": ("bag", ("info", "play", "recover")),
            "gimbal-bench": ("bench", ("run", "record", "flexure", "compare", "live")),
            "gimbal-campaign": ("campaign", ("", "diff")), "gimbal-geometry": ("geometry", ("", "point")),
            "gimbal-allan": ("allan", ())}



def _snapshot(root: Path) -> dict[str, bytes | None]:
    """Every file under ``root`` (the inputs and the folders that existed) with its bytes, and
    every folder (None): a command that creates an empty folder before failing is caught."""
    return {str(p.relative_to(root)): p.read_bytes() if p.is_file() else None for p in sorted(root.rglob("*"))}


@pytest.mark.parametrize("row", ROWS, ids=[r[0] for r in ROWS])
def test_bad_input_is_refused_in_one_line(row, inputs, capfd, monkeypatch, tmp_path):
    name, main, argv, words = row
    monkeypatch.chdir(tmp_path)  # a command's default output folder lands here, not in the repo
    before = _snapshot(inputs["root"])
    args = [a(inputs) if callable(a) else a for a in argv]
    try:
        code = main(args)
    except SystemExit as exc:  # argparse's own refusals
        code = exc.code
    out, err = capfd.readouterr()  # file descriptors: rclpy's log lines too
    text = out + err
    assert code == EXIT_NOT_USAGE.get(name, 2), f"{name}: exit {code}\n{text}"
    assert "Traceback" not in text, text
    for word in words:
        assert word.lower() in text.lower(), f"{name}: {word!r} not in:\n{text}"
    after = _snapshot(inputs["root"])
    assert {k: v for k, v in after.items() if k in before} == before, f"{name} changed an existing file"
    created = sorted(set(after) - set(before))
    assert not created, f"{name} created {created}"
    assert not os.listdir(tmp_path), f"{name} wrote into the working directory: {os.listdir(tmp_path)}"


def test_every_console_command_has_a_row():
    """Adding a console script (or a subcommand) without a row fails here."""
    ids = [r[0] for r in ROWS]
    scripts = {s for pkg in PACKAGES for s in declared_console_scripts(pkg)}
    assert scripts == set(COMMANDS) | set(NODES), scripts ^ (set(COMMANDS) | set(NODES))
    for script, (prefix, subs) in COMMANDS.items():
        for sub in subs or ("",):
            head = f"{prefix} {sub}".strip() if sub else prefix
            assert any(i.split("/")[0] == head for i in ids), f"{script} {sub}: no row"
    for exe in NODES:
        assert any(i.split("/")[0] == exe for i in ids), f"{exe}: no row"


def _node_with_nan(exe: str, param: str, env: dict) -> subprocess.CompletedProcess:
    return subprocess.run([str(VENV_BIN / exe), "--ros-args", "-p", f"{param}:=.nan"], env=env,
                          capture_output=True, text=True, timeout=60)


def test_nodes_refuse_a_nan_parameter(ros_domain_env):
    """Through rclpy's own parameter path (so in processes, two at a time): exit 2, one line
    naming the parameter, no traceback."""
    cases = [("sensor_models", "gimbal_gyro_rate_hz"), ("gyro_bias_ekf", "diagnostics_period_s")]
    with ThreadPoolExecutor(2) as pool:
        results = list(pool.map(lambda c: _node_with_nan(*c, ros_domain_env), cases))
    for (exe, param), result in zip(cases, results):
        assert result.returncode == 2, (exe, result.returncode, result.stderr)
        assert param in result.stderr and "Traceback" not in result.stderr, result.stderr
