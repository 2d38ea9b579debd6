"""Ctrl-C on a 2-hour ``gimbal-run`` keeps the run, in both modes.

The run is interrupted once it has simulated half a second (read from the progress file the
orchestrator keeps, not after a wall-clock sleep). It must exit 130 without a traceback or a
[FATAL] log line, leave a bag that the ``rosbags`` reader (not ours) reads to the time
simulated, and write ``run.json`` (``interrupted: true``) and the report of that time, and print its page's
path last.
"""
from __future__ import annotations

import json

import pytest
from rosbags.highlevel import AnyReader

from conftest import VENV_BIN
from ros_harness import interrupt_when, progress_sim_s

TWO_HOURS_S = 7200.0
INTERRUPT_AT_S = 0.5     # simulated seconds reached before the SIGINT


@pytest.mark.parametrize("mode", ["container", "processes"])
def test_ctrl_c_keeps_the_run(mode, tmp_path, ros_domain_env):
    out, progress = tmp_path / "run", tmp_path / "progress"
    env = dict(ros_domain_env, GIMBAL_RUN_PROGRESS_FILE=str(progress))
    code, text = interrupt_when([str(VENV_BIN / "gimbal-run"), "sim_open_loop", "--duration", str(TWO_HOURS_S),
                                 "--mode", mode, "--out", str(out), "--no-progress"], env, tmp_path,
                                ready=lambda: progress_sim_s(progress) >= INTERRUPT_AT_S)
    logs = "".join(p.read_text() for p in (out / "logs").glob("*.log"))
    assert code == 130, text
    for bad in ("Traceback", "[FATAL]"):
        assert bad not in text and bad not in logs, text + logs
    assert "interrupted" in text and "kept the bag (closed cleanly)" in text, text
    stderr = (tmp_path / "interrupted.stderr").read_text()  # where an interrupted run says what it kept
    assert stderr.rstrip().splitlines()[-1] == f"page: {out / 'report' / 'index.html'}", text  # printed last
    assert (out / "report" / "index.html").is_file()

    run = json.loads((out / "run.json").read_text())
    assert run["interrupted"] is True
    assert INTERRUPT_AT_S <= run["sim_s"] < TWO_HOURS_S
    metrics = json.loads((out / "report" / "metrics.json").read_text())
    assert metrics["closed_cleanly"] and metrics["message_count"] > 0
    with AnyReader([out]) as reader:  # a reader we did not write
        stamps = [t for _, t, _ in reader.messages(connections=[c for c in reader.connections
                                                               if c.topic == "/clock"])]
        assert reader.message_count == metrics["message_count"]
    # the bag holds the time simulated: its last /clock step is the run's sim time (1 kHz grid)
    assert abs((max(stamps) - min(stamps)) * 1e-9 - run["sim_s"]) <= 2e-3
