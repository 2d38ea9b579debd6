"""A campaign's results: one row per run (``runs/<id>/result.json``), the table of all rows
(``results.parquet`` and ``results.csv``), and what :func:`~.engine.run_campaign` returns."""
from __future__ import annotations

import csv
import hashlib
import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

RESULT_FILE = "result.json"
#: Columns every row has, in this order; swept values follow as sweep.<target>, dispersed values
#: (drawn per run) as dispersed.<target>, then the metrics.
FIXED_COLUMNS = ("run_id", "scenario", "variant", "seed", "engine", "status", "reason", "wall_s", "host", "log_tail")
#: Entries of a report's metrics.json that are not figures (paths, plot lists, per-topic counts, text,
#: and ``series``: a run's per-step values a runner combines over seeds, e.g. the slew's NEES).
NOT_METRICS = {"plots", "topics", "bag", "read_error", "report", "runs", "table", "comparison", "series"}


@dataclass
class CampaignResult:
    directory: Path
    rows: list[dict[str, Any]]        # one per planned run, in plan order
    ran: int                          # runs executed by this call
    skipped: int                      # runs whose results already existed (--resume)
    wall_s: float

    @property
    def failed(self) -> list[dict[str, Any]]:
        return [r for r in self.rows if r["status"] != "ok"]


def flatten_metrics(metrics: dict[str, Any], prefix: str = "") -> dict[str, float | None]:
    """Numeric leaves of a metrics.json mapping by dotted path (list items as ``path.i``);
    booleans as 0/1; text, plot lists and per-topic counts left out."""
    out: dict[str, float | None] = {}
    for key, value in metrics.items():
        if not prefix and key in NOT_METRICS:
            continue
        path = f"{prefix}{key}"
        if isinstance(value, dict):
            out.update(flatten_metrics(value, path + "."))
        elif isinstance(value, list):
            if all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in value):
                out.update({f"{path}.{i}": float(v) for i, v in enumerate(value)})
        elif isinstance(value, bool):
            out[path] = float(value)
        elif isinstance(value, (int, float)):
            out[path] = float(value)
        elif value is None:
            out[path] = None
    return out


def table_rows(rows: list[dict[str, Any]], sweep_targets: list[str]) -> tuple[list[str], list[dict[str, Any]]]:
    """(columns, flat rows) of the results table: fixed columns, sweep.<target>, dispersed.<target>
    (a run's value of a target not swept), metrics."""
    metric_cols: dict[str, None] = {}
    dispersed: dict[str, None] = {}
    for row in rows:
        metric_cols.update(dict.fromkeys(row.get("metrics", {})))
        dispersed.update(dict.fromkeys(t for t in row.get("values", {}) if t not in sweep_targets))
    columns = list(FIXED_COLUMNS) + [f"sweep.{t}" for t in sweep_targets] + [f"dispersed.{t}" for t in dispersed] \
        + list(metric_cols)
    flat = []
    for row in rows:
        item = {c: row.get(c) for c in FIXED_COLUMNS}
        item.update({f"sweep.{t}": row.get("values", {}).get(t) for t in sweep_targets})
        item.update({f"dispersed.{t}": row.get("values", {}).get(t) for t in dispersed})
        item.update({c: row.get("metrics", {}).get(c) for c in metric_cols})
        flat.append(item)
    return columns, flat


def write_results(out_dir: Path, rows: list[dict[str, Any]], sweep_targets: list[str]) -> Path:
    """``results.parquet`` (and ``results.csv``) of the rows; returns the Parquet path."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    columns, flat = table_rows(rows, sweep_targets)
    arrays = {}
    for col in columns:
        values = [r[col] for r in flat]
        if col in ("seed",):
            arrays[col] = pa.array(values, pa.int64())
        elif col in FIXED_COLUMNS and col != "wall_s":
            arrays[col] = pa.array(["" if v is None else str(v) for v in values], pa.string())
        elif col.startswith(("sweep.", "dispersed.")):
            arrays[col] = pa.array(values)  # the parameter's own type (number, bool, text)
        else:
            arrays[col] = pa.array([None if v is None else float(v) for v in values], pa.float64())
    path = out_dir / "results.parquet"
    tmp = path.with_suffix(".parquet.tmp")
    pq.write_table(pa.table(arrays), tmp)
    tmp.replace(path)
    with open(out_dir / "results.csv", "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=columns)
        writer.writeheader()
        writer.writerows(flat)
    return path


def read_results(out_dir: Path) -> list[dict[str, Any]]:
    """The rows of ``results.parquet`` (pyarrow), as dicts by column."""
    import pyarrow.parquet as pq

    return pq.read_table(Path(out_dir) / "results.parquet").to_pylist()


def results_digest(rows: list[dict[str, Any]]) -> str:
    """SHA-256 of a results table's rows (as :func:`read_results` gives them), in run-id order
    and with every column: a report stores the digest of the table it was written from, and a
    table whose digest differs (a run's status or any of its figures) makes that report stale."""
    text = json.dumps(sorted(rows, key=lambda r: str(r.get("run_id"))), sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()
