"""Hand-offs between chained graph runs: a scenario's ``prelude`` (gimbal-run runs it first)
leaves a run directory; its hand-off reads that run's bag and returns the ROS 2 parameter
file that starts the next run where the prelude left off, and the figures of the hand-over.

``alignment_to_navigation`` (paper 3 l. 580–582, 707–709; ``rotational_ins_navigation``
variants ``original_system`` and ``upgraded``), the same on either engine. From the alignment
run's last estimate (``platform_alignment``,
:func:`.alignment.alignment_series`):

* ``platform_navigator``: the misalignment (ENU, ″) to torque out, the level drifts (x, y;
  no vertical one is estimated) and the north drift into the command, the level accelerometer
  biases off the specific force, the base heading the alignment assumed minus δφU; the site
  (latitude, longitude, height) of the base, at rest;
* ``vehicle_dynamics``: the same static base (its ``profile_params``) and the gimbal angles
  the plant had at the estimate's stamp (``initial_platform_deg``), the plant starting at
  rest there;
* ``platform_servo``: the site's latitude.

The sensor biases are not handed over: the navigation run's ``sensor_models`` draws them from
the same seed (each sensor's stream is ``[seed, crc32(name)]``, the bias its first draw, so
the rate does not change it); the navigation report checks that they are the alignment's.

Figures (``hand_off.json``), the no-ROS engine's names: truth, estimate and residual
(truth − estimate) misalignment [″] at the hand-off, residual level drifts [°/h] (true
platform drift −b_gyro minus the estimate), residual level accelerometer biases [µg], the
north-drift estimate [°/h], the true biases, the hand-off stamp [s].
"""
from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Callable

import yaml

from gimbal_kinematics.maths.units import ARCSEC, DEG_H, UG

from ..bag.reader import BagError
from .alignment import alignment_series

#: The hand-off's parameter file and figures, written into the prelude's run directory.
PARAMS_FILE, FIGURES_FILE = "hand_off.yaml", "hand_off.json"


def _static_base(run_dir: Path) -> str:
    """The prelude's ``vehicle_dynamics.profile_params`` (the static base it ran on)."""
    nodes = yaml.safe_load((run_dir / "scenario.yaml").read_text()).get("nodes", {})
    vehicle = next((n.get("params", {}) for n in nodes.values() if n.get("executable") == "vehicle_dynamics"), {})
    return str(vehicle.get("profile_params", "{}"))


def alignment_to_navigation(run_dir: Path) -> tuple[dict, dict]:
    """(parameter file contents, figures) of the alignment run in ``run_dir`` (module docstring)."""
    s = alignment_series(run_dir)
    profile_params = _static_base(run_dir)
    site = yaml.safe_load(profile_params) or {}
    site = {k: float(site.get(k, 0.0)) for k in ("lat_deg", "lon_deg", "height_m")}
    phi, phi_true = s["current"][-1], s["truth_current"][-1]
    drift, bias = s["gyro_drift"][-1], s["accel_bias"][-1]
    navigator = {**site, "base_heading_deg": math.degrees(s["heading"] - float(phi[2])),
                 "misalignment_arcsec": [float(v / ARCSEC) for v in phi],
                 "gyro_drift_deg_h": [float(drift[0] / DEG_H), float(drift[1] / DEG_H), 0.0],
                 "north_drift_deg_h": float(s["north_drift"][-1] / DEG_H),
                 "accel_bias_ug": [float(bias[0] / UG), float(bias[1] / UG), 0.0]}
    params = {
        "vehicle_dynamics": {"ros__parameters": {
            "profile_params": profile_params,
            "initial_platform_deg": [math.degrees(float(v)) for v in s["final_joints"]]}},
        "platform_servo": {"ros__parameters": {"lat_deg": site["lat_deg"]}},
        "platform_navigator": {"ros__parameters": navigator},
    }
    figures = {
        "hand_off_s": float(s["t"][-1]),
        "misalignment_truth_arcsec": [float(v / ARCSEC) for v in phi_true],
        "misalignment_estimate_arcsec": navigator["misalignment_arcsec"],
        "residual_misalignment_arcsec": [float((a - b) / ARCSEC) for a, b in zip(phi_true, phi)],
        "residual_gyro_drift_deg_h": [float(v / DEG_H) for v in s["truth_gyro_drift"] - drift],
        "residual_accel_bias_ug": [float(v / UG) for v in s["truth_accel_bias"] - bias],
        "north_drift_estimate_deg_h": navigator["north_drift_deg_h"],
        "true_gyro_bias_deg_h": [float(v / DEG_H) for v in s["true_gyro_bias"]],
        "true_accel_bias_ug": [float(v / UG) for v in s["true_accel_bias"]],
    }
    return params, figures


#: hand-off name (a prelude's ``hand_off``) -> function (prelude run dir) -> (params, figures)
HAND_OFFS: dict[str, Callable[[Path], tuple[dict, dict]]] = {"alignment_to_navigation": alignment_to_navigation}


def write_hand_off(name: str, run_dir: Path) -> tuple[Path, dict]:
    """Run the hand-off ``name`` on the prelude's ``run_dir``; writes its parameter file and
    figures there and returns (parameter file, figures)."""
    if name not in HAND_OFFS:
        raise BagError(f"unknown hand-off {name!r}; known: {', '.join(sorted(HAND_OFFS))}")
    params, figures = HAND_OFFS[name](Path(run_dir))
    path = Path(run_dir) / PARAMS_FILE
    path.write_text(yaml.safe_dump(params, sort_keys=False))
    (Path(run_dir) / FIGURES_FILE).write_text(json.dumps(figures, indent=2) + "\n")
    return path, figures


def write_figures(run_dir: Path, figures: dict) -> None:
    """The hand-off's figures into the run it started (``hand_off.json``), which its report reads."""
    (Path(run_dir) / FIGURES_FILE).write_text(json.dumps(figures, indent=2) + "\n")
