"""The README is an entry point: short, and every command in it runs as written.

Every command the README shows, in a shell block or as inline code, that calls one of the
executables the packages declare, ``ros2 run`` or ``make`` is checked against the executable
itself: it resolves where the venv and ``ros2 run`` find it; its ``--help`` (its subcommand's,
when it names one) exits 0 with a usage line; every option it passes is one that help lists;
a scenario it names is a built-in one; a repository path it names exists; a ``-p`` parameter
is in the node's parameter file. ``make`` is checked by ``make -n``. Placeholders (``BAG``,
``SCENARIO``, ``<run>``) stand for what the reader supplies and are not checked.

The relative links of the README and of docs/ must reach a file and, for a Markdown anchor,
one of that file's headings (as GitHub spells it), so a section moved out of the README keeps
the links into it.
"""
from __future__ import annotations

import re
import shlex
import subprocess
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path

import yaml

from conftest import REPO_ROOT, VENV_BIN
from test_workspace import PACKAGES, declared_console_scripts

from gimbal_sim.graph.scenario import builtin_scenarios

README = REPO_ROOT / "README.md"
MAX_LINES = 150
FENCE = re.compile(r"^```(\w*)\n(.*?)^```", re.M | re.S)
SHELL_FENCES = {"sh", "bash", "shell", "console"}
#: what the reader fills in: <run>, BAG, SCENARIO, NODE.PARAM=VALUE
PLACEHOLDER = re.compile(r"<[^>]*>|^[A-Z][A-Z0-9_.=]*$")
REPO_PATH = re.compile(r"^(src|docs|test|config|\.ci)/")
SUBCOMMANDS = re.compile(r"\{([\w,-]+)\} \.\.\.")
LINK = re.compile(r"!?\[[^\]]*\]\(([^)\s]+)\)")


@dataclass
class Check:
    """One README command, reduced to what can be checked without running it."""

    text: str
    argv: list[str]                     # the command for its --help (subcommand added later)
    options: list[str] = field(default_factory=list)
    positionals: list[str] = field(default_factory=list)
    ros_args: list[str] = field(default_factory=list)
    node: tuple[str, str] | None = None  # (package, executable) of a node


def executables() -> dict[str, str]:
    return {exe: pkg for pkg in PACKAGES for exe in declared_console_scripts(pkg)}


def commands(text: str) -> list[str]:
    """Every shell line of the README's code blocks and every inline code span, as written."""
    found: list[str] = []
    for lang, body in FENCE.findall(text):
        if lang in SHELL_FENCES:
            found += [line for line in body.replace("\\\n", " ").splitlines() if line.strip()]
    prose = FENCE.sub("", text)
    found += re.findall(r"`([^`\n]+)`", prose)
    return found


def is_placeholder(token: str) -> bool:
    return bool(PLACEHOLDER.search(token))


def to_check(text: str, exes: dict[str, str]) -> Check | None:
    """The check of one command, or None when the text calls no project executable."""
    tokens = shlex.split(text, comments=True)
    if not tokens:
        return None
    head = tokens[0].removeprefix(".venv/bin/")
    if head == "make":
        return Check(text, ["make", "-n", "-C", str(REPO_ROOT), *tokens[1:]])
    if head == "ros2":
        if len(tokens) < 4 or tokens[1] != "run":
            return None   # prose that names `ros2 run` itself
        pkg, exe = tokens[2], tokens[3]
        assert exes.get(exe) == pkg, f"{text!r}: {pkg} declares no executable {exe}"
        return _split(text, [_resolved(VENV_BIN.parent / "lib" / pkg / exe)], tokens[4:], (pkg, exe))
    if head not in exes:
        return None
    node = (exes[head], head) if (REPO_ROOT / "src" / exes[head] / "config" / f"{head}.yaml").is_file() else None
    return _split(text, [_resolved(VENV_BIN / head)], tokens[1:], node)


def _resolved(path: Path) -> str:
    """The file itself, so that `ros2 run`'s path and the venv's link to it are one --help call."""
    assert path.is_file(), f"{path} is missing; run `make venv`"
    return str(path.resolve())


def _split(text: str, argv: list[str], rest: list[str], node: tuple[str, str] | None) -> Check:
    ros_args: list[str] = []
    if "--ros-args" in rest:
        ros_args = rest[rest.index("--ros-args") + 1:]
        rest = rest[:rest.index("--ros-args")]
    options = [t.split("=")[0] for t in rest if t.startswith("-")]
    positionals = [t for t in rest if not t.startswith("-")]
    return Check(text, argv, options, positionals, ros_args, node)


def run(argv: list[str]) -> subprocess.CompletedProcess:
    return subprocess.run(argv, capture_output=True, text=True, timeout=120, cwd=REPO_ROOT)


def in_parallel(argvs: list[tuple[str, ...]]) -> dict[tuple[str, ...], subprocess.CompletedProcess]:
    # each --help is a Python start-up that mostly waits on imports: a few at once
    with ThreadPoolExecutor(max_workers=4) as pool:
        return dict(zip(argvs, pool.map(lambda argv: run(list(argv)), argvs)))


def test_the_readme_is_at_most_150_lines_and_shows_one_picture():
    text = README.read_text(encoding="utf-8")
    assert len(text.splitlines()) <= MAX_LINES, f"README.md has {len(text.splitlines())} lines"
    pictures = [target for target in LINK.findall(text) if target.endswith((".png", ".svg", ".jpg"))]
    assert pictures and all((REPO_ROOT / p).is_file() for p in pictures), pictures


def test_every_command_in_the_readme_runs_as_written():
    text = README.read_text(encoding="utf-8")
    exes = executables()
    checks = [c for c in (to_check(cmd, exes) for cmd in commands(text)) if c is not None]
    # `make run ARGS="..."` passes its ARGS to gimbal-run: check them as a gimbal-run command too
    for check in list(checks):
        if check.argv[0] == "make":
            checks += [_split(check.text, [_resolved(VENV_BIN / "gimbal-run")], shlex.split(t[5:]), None)
                       for t in check.argv if t.startswith("ARGS=")]
    shown = {Path(c.argv[0]).name + (" " + c.argv[-1] if c.argv[0] == "make" else "") for c in checks}
    # the two commands and the three ways to use the toolkit are all there
    for expected in ("make run", "make test", "gyro_bias_ekf", "gimbal-bag", "gimbal-run", "gimbal-campaign"):
        assert expected in shown, f"the README shows no `{expected}` command (found {sorted(shown)})"
    assert any("/lib/" in c.argv[0] for c in checks), "the README shows no `ros2 run` command"

    first = in_parallel(sorted({tuple(c.argv if c.argv[0] == "make" else [*c.argv, "--help"]) for c in checks}))
    for check in checks:
        if check.argv[0] == "make":
            result = first[tuple(check.argv)]
            assert result.returncode == 0, f"{check.text!r}: make -n: {result.stderr}"
            args = [t[5:] for t in check.argv if t.startswith("ARGS=")]
            if args:
                assert f"gimbal-run {args[0]}" in result.stdout, f"{check.text!r}: {result.stdout}"
            continue
        result = first[(*check.argv, "--help")]
        assert result.returncode == 0 and "usage:" in result.stdout.lower(), \
            f"{check.text!r}: --help exited {result.returncode}: {result.stderr}"
        subcommands = SUBCOMMANDS.search(result.stdout)
        if subcommands and check.positionals and not is_placeholder(check.positionals[0]):
            assert check.positionals[0] in subcommands.group(1).split(","), \
                f"{check.text!r}: no subcommand {check.positionals[0]}"
            check.argv.append(check.positionals.pop(0))

    second = in_parallel(sorted({(*c.argv, "--help") for c in checks
                                 if c.argv[0] != "make" and (*c.argv, "--help") not in first}))
    scenarios = builtin_scenarios()
    for check in checks:
        if check.argv[0] == "make":
            continue
        result = first.get((*check.argv, "--help")) or second[(*check.argv, "--help")]
        assert result.returncode == 0 and "usage:" in result.stdout.lower(), \
            f"{check.text!r}: --help exited {result.returncode}: {result.stderr}"
        for option in check.options:
            assert re.search(rf"(?<![\w-]){re.escape(option)}(?![\w-])", result.stdout), \
                f"{check.text!r}: {option} is not an option of {' '.join(Path(a).name for a in check.argv)}"
        name = Path(check.argv[0]).name
        if name in ("gimbal-run", "gimbal-campaign") and check.positionals:
            scenario = check.positionals[0]
            if not is_placeholder(scenario) and not scenario.endswith(".yaml"):
                assert scenario in scenarios, f"{check.text!r}: no built-in scenario {scenario}"
        _check_ros_args(check)
        for token in check.positionals + check.ros_args:
            if REPO_PATH.match(token) and not is_placeholder(token):
                assert (REPO_ROOT / token).exists(), f"{check.text!r}: {token} does not exist"


def _check_ros_args(check: Check) -> None:
    if not check.ros_args:
        return
    assert check.node is not None, f"{check.text!r}: --ros-args on something that is not a node"
    pkg, exe = check.node
    declared = yaml.safe_load((REPO_ROOT / "src" / pkg / "config" / f"{exe}.yaml").read_text())
    params = set(declared[exe]["ros__parameters"])
    args = iter(check.ros_args)
    for flag in args:
        value = next(args, None)
        assert flag in ("-p", "-r", "--params-file", "--remap", "--param"), f"{check.text!r}: {flag}?"
        assert value is not None, f"{check.text!r}: {flag} has no value"
        if flag in ("-p", "--param"):
            name = value.split(":=")[0]
            assert ":=" in value and (name in params or name.startswith("qos_overrides.")), \
                f"{check.text!r}: {exe} has no parameter {name}"
        elif flag in ("-r", "--remap"):
            assert re.fullmatch(r"[~/\w]+:=[~/\w]+", value), f"{check.text!r}: remap {value}"


def github_anchors(path: Path) -> set[str]:
    """The anchors GitHub gives a Markdown file's headings (duplicates get -1, -2, ...)."""
    anchors: set[str] = set()
    counts: dict[str, int] = {}
    for heading in re.findall(r"^#{1,6}\s+(.*)$", FENCE.sub("", path.read_text(encoding="utf-8")), re.M):
        slug = re.sub(r"[^\w\- ]", "", heading.strip().lower()).replace(" ", "-")
        anchors.add(slug if slug not in counts else f"{slug}-{counts[slug]}")
        counts[slug] = counts.get(slug, 0) + 1
    return anchors


def test_links_in_the_readme_and_docs_resolve():
    broken = []
    for page in [README, *sorted((REPO_ROOT / "docs").rglob("*.md"))]:
        for target in LINK.findall(FENCE.sub("", page.read_text(encoding="utf-8"))):
            if re.match(r"[a-z][a-z0-9+.-]*:", target):
                continue   # https:, mailto:, ...
            path, _, anchor = target.partition("#")
            resolved = (page.parent / path).resolve() if path else page
            if not resolved.exists():
                broken.append(f"{page.relative_to(REPO_ROOT)}: {target} (no such file)")
            elif anchor and resolved.suffix == ".md" and anchor not in github_anchors(resolved):
                broken.append(f"{page.relative_to(REPO_ROOT)}: {target} (no such heading)")
    assert not broken, "\n".join(broken)
