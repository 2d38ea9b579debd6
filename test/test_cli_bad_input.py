"""Every console command over a matrix of bad inputs (issue 27's acceptance).

The matrix is data: one row per (command, input), each naming the words its one-line
message must contain. Every row must exit non-zero, print no traceback, and leave the
folders that existed before exactly as they were. The mains run in this process (their
``main(argv)``), on tiny inputs: bags written by the ``rosbags`` writer (foreign_bags),
damaged by cutting their bytes, never through our own writer.
"""
from __future__ import annotations

import os
from pathlib import Path
from typing import Callable

import numpy as np
import pytest

from foreign_bags import synthetic_messages, write_rosbags
from gimbal_kinematics import cli as geometry_cli
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
    # a bag folder without metadata.yaml whose MCAP is cut too: nothing can be read or indexed
    paths["no_metadata"] = root / "no_metadata_bag"
    paths["no_metadata"].mkdir()
    (paths["no_metadata"] / "x_0.mcap").write_bytes(data[:len(data) // 2])
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
    ("report/bag without metadata", report_cli.main, [_p("no_metadata")], ["no message can be read"]),
    ("report/unknown report", report_cli.main, [_p("good"), "--report", "nope"], ["unknown report"]),
    # gimbal-bag
    ("bag info/missing", bag_cli.main, ["info", _p("missing")], ["no_such_thing"]),
    ("bag info/random bytes", bag_cli.main, ["info", _p("random")], ["NO"]),
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
    # gimbal-campaign
    ("campaign/resume of a missing folder", campaign_cli.main, ["--resume", "--out", _p("missing")],
     ["--resume", "no such campaign directory"]),
    ("campaign/non-text campaign file", campaign_cli.main, [_p("not_text")], ["not a text file"]),
    ("campaign/huge seed range", campaign_cli.main, ["sim_open_loop", "--seeds", "1-100000000", "--serial"],
     ["seeds", "more than"]),
    ("campaign/many runs", campaign_cli.main, ["sim_open_loop", "--seeds", "0-20000", "--serial", "--engine", "core"],
     ["--large"]),
    ("campaign/duration inf", campaign_cli.main, ["sim_open_loop", "--duration", "inf"], ["--duration", "finite"]),
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
    # gimbal-allan
    ("allan/missing bag", allan_cli.main, [_p("missing"), "--topic", "/imu", "--out", _p("root", "/allan1")],
     ["no_such_thing"]),
    ("allan/random bytes", allan_cli.main, [_p("random"), "--topic", "/imu", "--out", _p("root", "/allan2")],
     ["random_bag"]),
    ("allan/existing out", allan_cli.main, [_p("good"), "--topic", "/imu", "--out", _p("existing"), "--json",
                                            _p("existing", "/keep.txt")], ["keep.txt"]),
]


def _snapshot(root: Path) -> dict[str, bytes]:
    """Every file under ``root`` (the inputs and the folders that existed) with its bytes."""
    return {str(p.relative_to(root)): p.read_bytes() for p in sorted(root.rglob("*")) if p.is_file()}


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
    assert code not in (0, None), f"{name}: exit 0\n{text}"
    assert "Traceback" not in text, text
    for word in words:
        assert word.lower() in text.lower(), f"{name}: {word!r} not in:\n{text}"
    after = _snapshot(inputs["root"])
    assert {k: v for k, v in after.items() if k in before} == before, f"{name} changed an existing file"
    created = sorted(set(after) - set(before))
    assert not created, f"{name} created {created}"
    assert not os.listdir(tmp_path), f"{name} wrote into the working directory: {os.listdir(tmp_path)}"
