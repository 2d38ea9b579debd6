"""Scenario reports, computed from recorded bags alone.

Each report is a function ``(bag_dir, report_dir) -> metrics`` in a module of its own; a
scenario names its report in its YAML (``report:``). A scenario with variants also names a
comparison (``comparison:``), a function ``(runs, report_dir) -> metrics`` over the
variants' bags (``runs``: variant name -> bag directory, in run order); a ``table`` entry
in its metrics (text) is printed at the end of the run. The registry holds import paths so a
report's own dependencies load only when it runs.
"""
from __future__ import annotations

import importlib
from pathlib import Path
from typing import Callable

#: report name -> "module:function" (module relative to this package)
REPORTS: dict[str, str] = {
    "generic": "generic:generic_report",
    "flexure": "flexure:flexure_report",
    "los_pointing": "los_pointing:los_pointing_report",
    "sighting": "sighting:sighting_report",
    "free_gyro": "free_gyro:free_gyro_report",
    "encoder_fusion": "encoder_fusion:encoder_fusion_report",
    "platform_servo": "platform_servo:platform_servo_report",
    "alignment": "alignment:alignment_report",
    "allan": "allan:allan_report",
}

#: comparison name -> "module:function"
COMPARISONS: dict[str, str] = {
    "sighting": "sighting:sighting_comparison",
    "encoder_fusion": "encoder_fusion:encoder_fusion_comparison",
    "alignment_rotation": "alignment:rotation_comparison",
    "alignment_campaign": "alignment:alignment_campaign",
    "allan": "allan:allan_comparison",
}


def _load(path: str) -> Callable:
    module, _, func = path.partition(":")
    return getattr(importlib.import_module(f"{__name__}.{module}"), func)


def report_function(name: str) -> Callable[[Path, Path], dict]:
    """The report called ``name``; ``KeyError`` if there is none."""
    return _load(REPORTS[name])


def comparison_function(name: str) -> Callable[[dict[str, Path], Path], dict]:
    """The comparison called ``name``; ``KeyError`` if there is none."""
    return _load(COMPARISONS[name])
