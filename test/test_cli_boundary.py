"""The one error boundary around every console command: each kind of failure gets the exit
code of docs/usage.md's table, one line for an expected failure, and for anything else the
traceback plus a line saying it is a bug."""
from __future__ import annotations

import io
import math

import pytest
import yaml

from gimbal_kinematics.cli.boundary import EXIT_CODES, RunFailed, UsageError, cli_boundary, finite, read_text


def _raising(exc: BaseException):
    @cli_boundary("gimbal-test", interrupted="stopped the test")
    def main(argv=None) -> int:
        raise exc
    return main


@pytest.mark.parametrize("exc, code, words", [
    (UsageError("--x must be > 0"), 2, ["gimbal-test: --x must be > 0"]),
    (FileNotFoundError(2, "No such file or directory", "/nowhere/f.yaml"), 2, ["/nowhere/f.yaml", "No such file"]),
    (UnicodeDecodeError("utf-8", b"\xff", 0, 1, "invalid start byte"), 2,
     ["not a text file"]),
    (yaml.YAMLError("mapping values are not allowed here"), 2, ["mapping values"]),
    (RunFailed("a node died"), 1, ["gimbal-test: a node died"]),
    (KeyboardInterrupt(), 130, ["interrupted: stopped the test"]),
    (KeyboardInterrupt("stopped after 3 of 9 runs"), 130, ["stopped after 3 of 9 runs"]),
])
def test_expected_failures_are_one_line_with_their_exit_code(exc, code, words, capsys):
    assert _raising(exc)([]) == code
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err, err
    for word in words:
        assert word in err
    assert code in EXIT_CODES


@pytest.mark.parametrize("exc", [ZeroDivisionError("division by zero"), KeyError("x"),
                                 io.UnsupportedOperation("fileno")])  # an OSError that names no path
def test_a_bug_keeps_its_traceback_and_says_it_is_a_bug(exc, capsys):
    assert _raising(exc)([]) == 1
    err = capsys.readouterr().err
    assert "Traceback" in err and type(exc).__name__ in err
    assert "this is a bug" in err.splitlines()[-1]


def test_argparse_exits_pass_through():
    with pytest.raises(SystemExit) as info:
        _raising(SystemExit(2))([])
    assert info.value.code == 2


def test_helpers_name_the_option_and_file(tmp_path):
    for value in (math.nan, math.inf, -math.inf):
        with pytest.raises(UsageError, match="--duration must be a finite number"):
            finite(value, "--duration")
    with pytest.raises(UsageError, match=r"--duration must be > 0, got -1"):
        finite(-1.0, "--duration", 0.0, strict=True)
    assert finite(0.0, "--rate", 0.0) == 0.0
    (tmp_path / "bin.yaml").write_bytes(b"a: \xff\n")
    with pytest.raises(UsageError, match=r"--params-file .*bin.yaml: not a text file \(byte 3"):
        read_text(tmp_path / "bin.yaml", "--params-file")
    with pytest.raises(UsageError, match="is a directory"):
        read_text(tmp_path, "scenario file")
