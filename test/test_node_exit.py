"""A node executable ends as the commands do: Ctrl-C once it is up exits 130
with no traceback and no [FATAL]; an unexpected exception keeps its traceback and is
followed by the commands' 'this is a bug' line (one boundary: cli_boundary)."""
from __future__ import annotations

import subprocess
import sys

from conftest import VENV_BIN
from gimbal_kinematics.cli.boundary import BUG_LINE
from ros_harness import interrupt_when_on_graph


def test_sigint_on_a_running_node_exits_130(ros_domain_env, tmp_path):
    code, text = interrupt_when_on_graph([str(VENV_BIN / "gyro_bias_ekf")], ros_domain_env, "gyro_bias_ekf", tmp_path)
    assert code == 130, text
    assert "Traceback" not in text and "[FATAL]" not in text, text
    assert "gyro_bias_ekf: interrupted: stopped the node" in text, text


def test_unexpected_exception_in_a_node_is_reported_as_a_bug(ros_domain_env):
    code = ("import sys\n"
            "from gimbal_kinematics.ros.node_main import run_node\n"
            "def make():\n"
            "    raise ZeroDivisionError('a node bug')\n"
            "sys.exit(run_node(make, 'bug_node', 'a node that fails', ['bug_node']))\n")
    result = subprocess.run([sys.executable, "-c", code], env=ros_domain_env, capture_output=True, text=True,
                            timeout=60)
    assert result.returncode == 1, result.stderr
    assert "Traceback" in result.stderr and "ZeroDivisionError: a node bug" in result.stderr, result.stderr
    assert BUG_LINE.format(prog="bug_node") in result.stderr, result.stderr


def test_after_a_stop_a_node_that_counts_what_it_hears_takes_what_is_waiting():
    """node_main's settle step: what was already sent to the recorder when the stop came is
    taken before the bag closes; a node without the count is left as it is."""
    from gimbal_kinematics.ros.node_main import _settle

    class Waiting:
        """An executor with ``pending`` messages queued for the node, one per spin."""

        def __init__(self, node, pending: int):
            self.node, self.pending, self.spins = node, pending, 0

        def spin_once(self, timeout_sec: float) -> None:
            self.spins += 1
            if self.pending:
                self.pending -= 1
                self.node.messages_heard += 1

    class Recorder:
        messages_heard = 0

    recorder = Recorder()
    executor = Waiting(recorder, pending=40)
    _settle(executor, recorder)
    assert executor.pending == 0 and recorder.messages_heard == 40
    untouched = Waiting(object(), pending=3)
    _settle(untouched, untouched.node)
    assert untouched.spins == 0
