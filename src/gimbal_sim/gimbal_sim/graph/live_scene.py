"""The live view's scene description of a run, from its scenario: what
:class:`gimbal_sim.bag.scene_config.SceneConfig` holds, read from the nodes that own it.

* the geo target: ``geo_pointer``'s ``target_llh_deg`` seen from its ``vehicle_llh_deg`` (both
  set: a node left at its defaults points nowhere), NED [m] from the vehicle;
* the heading the platform alignment assumes: ``platform_alignment``'s ``base_heading_deg``;
* the site: ``vehicle_dynamics``' latitude (``lat_deg`` of its ``profile_params``) and
  ``earth_rate``.

A parameter a scenario does not set takes the node's declared default. :func:`write_scene`
puts the description beside the run's bag, where the recorder's and ``gimbal-bag play``'s
live view read it.
"""
from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import yaml

from gimbal_kinematics.maths.geo_pointing import los_to_target

from ..bag.scene_config import SCENE_FILE, SceneConfig
from .registry import NODE_TYPES
from .scenario import Scenario

GEO_POINTER = "geo_pointer"
PLATFORM_ALIGNMENT = "platform_alignment"
VEHICLE = "vehicle_dynamics"


def _set_params(scenario: Scenario, executable: str) -> dict[str, Any]:
    """The parameters the scenario sets on its (first) node running ``executable``."""
    return next((spec["params"] for spec in scenario.nodes.values() if spec["executable"] == executable), {})


def _param(scenario: Scenario, executable: str, name: str) -> Any:
    """The scenario's value of a node's parameter, else the node's declared default."""
    params = _set_params(scenario, executable)
    if name in params:
        return params[name]
    return next(p.default for p in NODE_TYPES[executable].params if p.name == name)


def _radians_llh(llh_deg: list[float]) -> tuple[float, float, float]:
    return math.radians(llh_deg[0]), math.radians(llh_deg[1]), float(llh_deg[2])


def geo_target_n(scenario: Scenario) -> tuple[float, float, float] | None:
    """The geo-pointing target, NED from the vehicle [m]; None without a geo-pointing node."""
    geo = _set_params(scenario, GEO_POINTER)
    if "target_llh_deg" not in geo or "vehicle_llh_deg" not in geo:
        return None
    los = los_to_target(_radians_llh(geo["vehicle_llh_deg"]), _radians_llh(geo["target_llh_deg"]))
    return tuple(float(c) * los.range_m for c in los.los_n)


def scene_config(scenario: Scenario) -> SceneConfig:
    """The live view's :class:`SceneConfig` of a run of ``scenario``."""
    profile = yaml.safe_load(_param(scenario, VEHICLE, "profile_params")) or {}
    return SceneConfig(target_n=geo_target_n(scenario),
                       platform_heading_rad=math.radians(float(_param(scenario, PLATFORM_ALIGNMENT,
                                                                      "base_heading_deg"))),
                       site_lat_rad=math.radians(float(profile.get("lat_deg", 0.0))),
                       earth_rate=bool(_param(scenario, VEHICLE, "earth_rate")))


def write_scene(scenario: Scenario, out_dir: Path) -> None:
    """The scene description beside the run's bag (:data:`~gimbal_sim.bag.scene_config.SCENE_FILE`)."""
    (Path(out_dir) / SCENE_FILE).write_text(scene_config(scenario).to_json())
