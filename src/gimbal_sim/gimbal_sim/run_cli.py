"""``gimbal-run``: the launch-free scenario orchestrator's entry point.

Scenarios register here as they are built (one line each for ``--list``). A scenario that
is not built is refused with exit code 2: this command never stands in a fake run.
"""
from __future__ import annotations

import argparse
import sys

#: Built-in scenarios: name -> one-line description.
BUILTIN_SCENARIOS: dict[str, str] = {}


def _scenario_lines() -> list[str]:
    if not BUILTIN_SCENARIOS:
        return ["(no scenario is built in yet: the simulation, recorder and controller nodes come first)"]
    width = max(len(name) for name in BUILTIN_SCENARIOS)
    return [f"{name:<{width}}  {text}" for name, text in sorted(BUILTIN_SCENARIOS.items())]


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="gimbal-run",
        description=(
            "Run a stabilized-sighting-platform scenario: start its nodes in lockstep, record "
            "every topic to MCAP and write a report. Without SCENARIO, list the built-in ones."
        ),
    )
    parser.add_argument("scenario", nargs="?", help="built-in scenario name")
    parser.add_argument("--list", action="store_true", help="list the built-in scenarios and exit")
    return parser


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    if args.list or args.scenario is None:
        print("Built-in scenarios:")
        for line in _scenario_lines():
            print("  " + line)
        return 0
    known = ", ".join(sorted(BUILTIN_SCENARIOS)) or "none yet"
    print(f"gimbal-run: unknown scenario {args.scenario!r} (built in: {known})", file=sys.stderr)
    return 2


if __name__ == "__main__":
    sys.exit(main())
