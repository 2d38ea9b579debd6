"""The ``allan`` report: ``gimbal-allan``'s characterisation of the INS gyro of an at-rest run
(``gyro_at_rest``), next to the terms the run simulated; ``allan`` comparison: one row per
variant (term mix)."""
from __future__ import annotations

import json
from pathlib import Path

import yaml

from ..allan.analyze import analyze, to_json
from ..allan.plot import plot_all
from ..allan.stream import read_imu_field
from ..bag.reader import scan
from ..nodes.sensor_models_params import PARAMS as SENSOR_PARAMS

TOPIC = "/ins/imu"
#: JSON key of a fitted term -> the sensor_models parameter that set it.
TRUTH_KEYS = {"arw_deg_rt_h": "ins_gyro_arw_deg_rt_h", "bias_instability_deg_h": "ins_gyro_bi_deg_h",
              "bias_tau_s": "ins_gyro_bi_tau_s", "rrw_deg_h_rt_h": "ins_gyro_rrw_deg_h_rt_h"}


def simulated_terms(bag_dir: Path) -> dict[str, float]:
    """The INS gyro terms the run simulated, from its ``scenario.yaml`` (defaults filled in)."""
    values = {p.name: p.default for p in SENSOR_PARAMS}
    scenario = Path(bag_dir) / "scenario.yaml"
    if scenario.is_file():
        nodes = (yaml.safe_load(scenario.read_text()) or {}).get("nodes", {})
        for spec in nodes.values():
            if (spec or {}).get("executable") == "sensor_models":
                values.update(spec.get("params") or {})
    truth = {key: float(values[name]) for key, name in TRUTH_KEYS.items()}
    if not truth["bias_instability_deg_h"]:
        truth["bias_tau_s"] = 0.0
    return truth


def allan_report(bag_dir: Path, out: Path) -> dict:
    """Characterise ``/ins/imu``'s angular velocity; plots, ``allan.json`` and fitted / true per term."""
    contents = scan(bag_dir)  # what every report states: counts and whether the bag was closed
    data = read_imu_field(bag_dir, TOPIC, "angular_velocity", progress=False)
    result = analyze(data)
    doc = to_json(result)
    (out / "allan.json").write_text(json.dumps(doc, indent=2) + "\n")
    plots = [p.name for p in plot_all(result, out)]
    truth = simulated_terms(bag_dir)
    ratios = {axis: {key: (terms[key] or 0.0) / truth[key] for key in truth if truth[key]}
              for axis, terms in doc["axes"].items()}
    return {"bag": str(bag_dir), "closed_cleanly": contents.closed_cleanly, "read_error": contents.error,
            "message_count": contents.message_count,
            "topics": {name: {"type": t.type_name, "count": t.count} for name, t in sorted(contents.topics.items())},
            "topic": TOPIC, "duration_s": doc["duration_s"],
            "sample_rate_hz": doc["sample_rate_hz"], "simulated": truth,
            "fitted": {axis: {key: terms[key] for key in truth} for axis, terms in doc["axes"].items()},
            "fitted_over_simulated": ratios, "plots": plots}


def allan_comparison(runs: dict[str, Path], out: Path) -> dict:
    """One row per variant: simulated terms and the fitted / simulated ratio of each (axes x, y, z)."""
    rows, metrics = [], {}
    for name, bag in runs.items():
        report = bag / "report" / "metrics.json"
        m = json.loads(report.read_text()) if report.is_file() else allan_report(bag, bag / "report")
        metrics[name] = {"simulated": m["simulated"], "fitted_over_simulated": m["fitted_over_simulated"]}
        cells = []
        for key, value in m["simulated"].items():
            if value:
                ratios = ", ".join(f"{r[key]:.3f}" for r in m["fitted_over_simulated"].values())
                cells.append(f"{key} {value:g} (fitted/true {ratios})")
        rows.append(f"  {name}: " + "; ".join(cells))
    table = "gimbal-allan on the recorded /ins/imu (fitted / simulated, per axis):\n" + "\n".join(rows)
    (out / "comparison.md").write_text(table + "\n")
    return {"variants": metrics, "table": table, "plots": []}
