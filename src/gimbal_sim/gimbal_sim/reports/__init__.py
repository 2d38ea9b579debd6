"""Scenario reports, computed from recorded bags alone.

Each report is a function ``(bag_dir, report_dir) -> metrics`` in a module of its own; a
scenario names its report in its YAML (``report:``). A scenario with variants also names a
comparison (``comparison:``), a function ``(runs, report_dir) -> metrics`` over the
variants' bags (``runs``: variant name -> bag directory, in run order); a ``table`` entry
in its metrics (text) is printed at the end of the run. matplotlib loads only when a report
draws its first figure (:func:`.figures.pyplot`).
"""
from __future__ import annotations

from pathlib import Path
from typing import Callable

from .alignment import alignment_campaign, alignment_report, rotation_comparison
from .allan import allan_comparison, allan_report
from .consistency import consistency_report
from .encoder_fusion import encoder_fusion_comparison, encoder_fusion_report
from .flexure import flexure_report, flexure_sea_states_comparison
from .free_gyro import free_gyro_report
from .generic import generic_report
from .geo_pointing import geo_pointing_comparison, geo_pointing_report
from .gyro_encoder import gyro_encoder_report
from .los_pointing import los_pointing_report
from .operator import sighting_operator_comparison, sighting_operator_report
from .navigation import navigation_report
from .navigation import rotation_comparison as navigation_rotation_comparison
from .platform_servo import platform_servo_comparison, platform_servo_report
from .sighting import sighting_comparison, sighting_report
from .slew import slew_comparison, slew_report

#: report name -> function (bag_dir, report_dir) -> metrics
REPORTS: dict[str, Callable[[Path, Path], dict]] = {
    "generic": generic_report,
    "flexure": flexure_report,
    "los_pointing": los_pointing_report,
    "sighting": sighting_report,
    "sighting_operator": sighting_operator_report,
    "free_gyro": free_gyro_report,
    "encoder_fusion": encoder_fusion_report,
    "platform_servo": platform_servo_report,
    "alignment": alignment_report,
    "allan": allan_report,
    "consistency": consistency_report,
    "gyro_encoder": gyro_encoder_report,
    "geo_pointing": geo_pointing_report,
    "navigation": navigation_report,
    "slew": slew_report,
}

#: comparison name -> function (runs, report_dir) -> metrics
COMPARISONS: dict[str, Callable[[dict[str, Path], Path], dict]] = {
    "sighting": sighting_comparison,
    "sighting_operator": sighting_operator_comparison,
    "encoder_fusion": encoder_fusion_comparison,
    "alignment_rotation": rotation_comparison,
    "alignment_campaign": alignment_campaign,
    "allan": allan_comparison,
    "geo_pointing": geo_pointing_comparison,
    "navigation_rotation": navigation_rotation_comparison,
    "slew": slew_comparison,
    "flexure_sea_states": flexure_sea_states_comparison,
    "platform_servo_gyro_source": platform_servo_comparison,
}


def report_function(name: str) -> Callable[[Path, Path], dict]:
    """The report called ``name``; ``KeyError`` if there is none."""
    return REPORTS[name]


def comparison_function(name: str) -> Callable[[dict[str, Path], Path], dict]:
    """The comparison called ``name``; ``KeyError`` if there is none."""
    return COMPARISONS[name]
