"""Scenario reports, computed from recorded bags alone.

Each report is a function ``(bag_dir, report_dir) -> metrics`` in a module of its own; a
scenario names its report in its YAML (``report:``). The registry holds import paths so a
report's own dependencies load only when it runs.
"""
from __future__ import annotations

import importlib
from pathlib import Path
from typing import Callable

#: report name -> "module:function" (module relative to this package)
REPORTS: dict[str, str] = {
    "generic": "generic:generic_report",
    "los_pointing": "los_pointing:los_pointing_report",
    "platform_servo": "platform_servo:platform_servo_report",
    "alignment": "alignment:alignment_report",
}

#: comparison name -> "module:function" ``f(runs: dict[variant, bag dir], out) -> metrics``
COMPARISONS: dict[str, str] = {
    "alignment_rotation": "alignment:rotation_comparison",
    "alignment_campaign": "alignment:alignment_campaign",
}


def report_function(name: str) -> Callable[[Path, Path], dict]:
    """The report called ``name``; ``KeyError`` if there is none."""
    module, _, func = REPORTS[name].partition(":")
    return getattr(importlib.import_module(f"{__name__}.{module}"), func)
