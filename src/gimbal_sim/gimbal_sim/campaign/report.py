"""The campaign report (``OUT/report/``), computed from ``results.parquet`` alone:

* ``summary.json`` / ``summary.md``: per variant and sweep point, each metric's run count,
  mean, standard deviation (ddof 1), the 95 % interval of the mean (Student t) and the
  range over runs; the failed runs with their reasons;
* NEES over seeds: a report's time-averaged NEES of each run (e.g. the sighting report's
  ``bias_nees_mean_after_30s``, 2 degrees of freedom), averaged over the N runs of a group,
  against the 95 % band of an N-run average NEES, χ²(N·dof)/N (Bar-Shalom's test). A
  per-run time average of a consistent filter also has mean dof and a spread no larger
  than one sample's, so the band is the conservative one; the verdict says ``consistent``
  inside it, ``optimistic`` above (errors larger than the filter claims), ``pessimistic``
  below;
* ``hist_<metric>.png``: each figure's distribution over runs, a histogram and the empirical
  CDF per group, with a requirement's bound and verdict;
* ``sweep_<param>__<metric>.png``: each figure against each swept parameter, every run
  and the group means with their 95 % intervals;
* the design review (:mod:`.review`): each requirement's verdict per group, the sensitivity
  indices, and their plots (``scatter``, ``horizontal_error``, ``convergence__<metric>``,
  ``sensitivity``); verdicts and indices head ``summary.md``, the text table and the page.

``gimbal-report CAMPAIGN_DIR`` calls :func:`regenerate`: each run's own report is rewritten
from its bag (where the bag was kept), the results table from the runs' metrics, then this.
"""
from __future__ import annotations

import dataclasses
import json
import math
import re
from collections import defaultdict
from functools import partial
from pathlib import Path
from typing import Any, Callable

import numpy as np
import yaml

from ..figures import pyplot, save
from ..page import write_campaign_page, write_run_page
from . import review
from .results import RESULT_FILE, flatten_metrics, read_results, results_digest, write_results
from .spec import CampaignError, spec_from_mapping

#: Leaf name of a report's time-averaged NEES -> its degrees of freedom (the report that writes it).
NEES_DOF = {"bias_nees_mean_after_30s": 2,   # sighting: (b_q, b_r)
            "total_nees_mean": 3,            # flexure: three flexure axes
            "mean_nees": 2}                  # free_gyro: north/east position fix
#: Metrics that describe the run rather than the experiment: tabulated, not plotted or printed.
BOOKKEEPING = re.compile(r"^(wall_s|message_count|duration_s|closed_cleanly|los_truth_final_deg\.|core_loop\.)")
MAX_HIST_GROUPS = 8


def _groups(rows: list[dict[str, Any]], sweep_cols: list[str]) -> dict[tuple, list[dict[str, Any]]]:
    groups: dict[tuple, list[dict[str, Any]]] = defaultdict(list)
    for row in rows:
        groups[(row["variant"], *[row[c] for c in sweep_cols])].append(row)
    return dict(groups)


def _label(key: tuple, sweep_cols: list[str]) -> str:
    parts = [key[0]] if key[0] else []
    parts += [f"{c.removeprefix('sweep.').split('.', 1)[-1]}={_short(v)}" for c, v in zip(sweep_cols, key[1:])]
    return ", ".join(parts) or "all runs"


def _short(v: Any) -> str:
    return f"{v:.6g}" if isinstance(v, float) else str(v)


def stats(values: list[float | None]) -> dict[str, Any]:
    """n, mean, std (ddof 1), 95 % interval of the mean (Student t), min, max of the finite
    values; ``n_nonfinite`` counts the rest."""
    from scipy.stats import t as student_t

    x = np.array([v for v in values if v is not None and math.isfinite(v)], float)
    out: dict[str, Any] = {"n": int(x.size), "n_nonfinite": len(values) - int(x.size)}
    if x.size == 0:
        return out
    mean = float(x.mean())
    std = float(x.std(ddof=1)) if x.size > 1 else 0.0
    half = float(student_t.ppf(0.975, x.size - 1) * std / math.sqrt(x.size)) if x.size > 1 else math.nan
    out.update(mean=mean, std=std, ci95=[mean - half, mean + half], min=float(x.min()), max=float(x.max()))
    return out


def nees_verdict(values: list[float | None], dof: int) -> dict[str, Any]:
    """The N-run average of per-run NEES against χ²(N·dof)/N's 95 % band (module docstring)."""
    from scipy.stats import chi2

    x = np.array([v for v in values if v is not None and math.isfinite(v)], float)
    if x.size == 0:
        return {"dof": dof, "n": 0, "verdict": "n/a (no finite NEES: run shorter than the settling time?)"}
    n = int(x.size)
    lo, hi = (float(b) for b in chi2.ppf([0.025, 0.975], n * dof) / n)
    avg = float(x.mean())
    verdict = "consistent" if lo <= avg <= hi else ("optimistic" if avg > hi else "pessimistic")
    return {"dof": dof, "n": n, "mean": avg, "band95": [lo, hi], "verdict": verdict}


def summarize(rows: list[dict[str, Any]]) -> dict[str, Any]:
    """Per group (variant, sweep point): stats of every metric and the NEES verdicts."""
    if not rows:
        return {"groups": [], "failed": [], "runs": 0}
    columns = list(rows[0])
    sweep_cols = [c for c in columns if c.startswith("sweep.")]
    metric_cols = [c for c in columns if c not in sweep_cols and not c.startswith("dispersed.") and c not in
                   ("run_id", "scenario", "variant", "seed", "engine", "status", "reason", "host", "log_tail")]
    ok = [r for r in rows if r["status"] == "ok"]
    groups = []
    for key, members in _groups(ok, sweep_cols).items():
        entry = {"label": _label(key, sweep_cols), "variant": key[0],
                 "sweep": dict(zip([c.removeprefix("sweep.") for c in sweep_cols], key[1:])),
                 "runs": len(members), "seeds": sorted(int(r["seed"]) for r in members),
                 "metrics": {c: stats([r[c] for r in members]) for c in metric_cols},
                 "nees": {c: nees_verdict([r[c] for r in members], NEES_DOF[c.rsplit(".", 1)[-1]])
                          for c in metric_cols if c.rsplit(".", 1)[-1] in NEES_DOF}}
        groups.append(entry)
    failed = [{k: r[k] for k in ("run_id", "variant", "seed", "reason", "log_tail")} |
              {c.removeprefix("sweep."): r[c] for c in sweep_cols} for r in rows if r["status"] != "ok"]
    return {"runs": len(rows), "ok": len(ok), "failed": failed, "sweep": [c.removeprefix("sweep.") for c in sweep_cols],
            "groups": groups}


def figure_metrics(summary: dict[str, Any]) -> list[str]:
    """The experiment's figures (not bookkeeping) that vary over the runs of some group."""
    names: dict[str, None] = {}
    for g in summary["groups"]:
        for name, s in g["metrics"].items():
            if not BOOKKEEPING.match(name) and s.get("n", 0) and (s["std"] > 0 or len(summary["groups"]) > 1):
                names[name] = None
    return list(names)


def text_summary(summary: dict[str, Any], metrics: list[str] | None = None, head: bool = True) -> str:
    """Mean ± std [95 % interval of the mean] (n) per group for ``metrics`` (default: the
    figures), the NEES verdicts and the failed runs; what ``gimbal-campaign`` prints."""
    metrics = figure_metrics(summary) if metrics is None else metrics
    lines = [*(_review_lines(summary) if head else []), f"{summary['ok']} of {summary['runs']} runs ok"]
    for g in summary["groups"]:
        lines.append(f"== {g['label']} ({g['runs']} runs, seeds {_seed_text(g['seeds'])})")
        width = max((len(m) for m in metrics), default=0)
        for name in metrics:
            s = g["metrics"].get(name, {})
            if s.get("n"):
                ci = "" if not math.isfinite(s["ci95"][0]) else f" [{s['ci95'][0]:+.6g}, {s['ci95'][1]:+.6g}]"
                lines.append(f"  {name:<{width}}  {s['mean']:+.6g} ± {s['std']:.4g}{ci} (n {s['n']})")
        for name, v in g["nees"].items():
            if v["n"]:
                lines.append(f"  NEES {name} ({v['dof']} dof): mean over {v['n']} runs {v['mean']:.3f}, 95 % band "
                             f"[{v['band95'][0]:.3f}, {v['band95'][1]:.3f}] -> {v['verdict']}")
            else:
                lines.append(f"  NEES {name}: {v['verdict']}")
    for f in summary["failed"]:
        lines.append(f"FAILED {f['run_id']} ({f['variant'] or '-'}, seed {f['seed']}): {f['reason']}")
    return "\n".join(lines)


def _review_lines(summary: dict[str, Any]) -> list[str]:
    """The verdicts, then the sensitivity indices, as text lines (what heads every summary)."""
    lines = []
    for v in summary.get("requirements", []):
        lo, hi = v["pass_fraction_interval"]
        lines.append(f"REQUIREMENT {v['requirement']} [{v['group']}]: {v['verdict'].upper()} — {v['detail']}; "
                     f"{v['passed']}/{v['runs']} runs pass (Clopper–Pearson {v['c']:.0%}: [{lo:.3f}, {hi:.3f}])"
                     + (f"; quantile used: {v['quantile']}" if v.get("quantile") else ""))
    sens = summary.get("sensitivity") or {}
    for variant, per in sens.get("indices", {}).items():
        for name, res in per.items():
            if "error" in res:
                lines.append(f"SENSITIVITY {name} [{variant}]: {res['error']}")
                continue
            key = "S1" if res["method"] == "sobol" else "mu_star"
            parts = [f"{f}: {key} {x[key]:.3f} ± {x[key + '_conf']:.3f}"
                     + (f", ST {x['ST']:.3f} ± {x['ST_conf']:.3f}" if key == "S1" else "")
                     for f, x in res["factors"].items()]
            lines.append(f"SENSITIVITY {name} [{variant}]: " + "; ".join(parts))
    return lines


def _seed_text(seeds: list[int]) -> str:
    if len(seeds) > 2 and seeds[-1] - seeds[0] + 1 == len(seeds) and seeds == list(range(seeds[0], seeds[-1] + 1)):
        return f"{seeds[0]}-{seeds[-1]}"
    if len(seeds) > 8:  # a design's seeds: drawn, not listed
        return f"{len(seeds)} drawn, {seeds[0]}…{seeds[-1]}"
    return ",".join(map(str, seeds))


def _markdown(summary: dict[str, Any]) -> str:
    out = ["# Campaign report\n"]
    head = _review_lines(summary)
    if head:
        out.append("## Verdicts and sensitivity\n\n" + "\n".join(f"* {line}" for line in head) + "\n")
    out.append(f"{summary['ok']} of {summary['runs']} runs ok.\n")
    if summary.get("experiment_table"):
        out.append(f"\n```\n{summary['experiment_table']}\n```\n")
    for g in summary["groups"]:
        out.append(f"\n## {g['label']}\n\n{g['runs']} runs, seeds {_seed_text(g['seeds'])}.\n")
        out.append("| metric | n | mean | std | 95 % interval of the mean | min | max |\n|---|---|---|---|---|---|---|")
        for name, s in g["metrics"].items():
            if s.get("n"):
                out.append(f"| {name} | {s['n']} | {s['mean']:.6g} | {s['std']:.4g} | "
                           f"[{s['ci95'][0]:.6g}, {s['ci95'][1]:.6g}] | {s['min']:.6g} | {s['max']:.6g} |")
        for name, v in g["nees"].items():
            band = f"[{v['band95'][0]:.3f}, {v['band95'][1]:.3f}]" if v["n"] else "-"
            mean = f"{v['mean']:.3f}" if v["n"] else "-"
            out.append(f"\nNEES `{name}` ({v['dof']} dof): mean {mean} over {v['n']} runs, 95 % band {band}: "
                       f"**{v['verdict']}**")
    if summary["failed"]:
        out.append("\n## Failed runs\n")
        for f in summary["failed"]:
            out.append(f"* `{f['run_id']}` ({f['variant'] or '-'}, seed {f['seed']}): {f['reason']}")
    return "\n".join(out) + "\n"


def _slug(text: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", text).strip("_")[:120]


def _plot_histograms(out: Path, rows: list[dict[str, Any]], summary: dict[str, Any], metrics: list[str]) -> list[str]:
    plt = pyplot()
    sweep_cols = [f"sweep.{s}" for s in summary["sweep"]]
    groups = _groups([r for r in rows if r["status"] == "ok"], sweep_cols)
    if len(groups) > MAX_HIST_GROUPS:
        return []  # too many to overlay: the sweep plots show them
    written = []
    for name in metrics:
        fig, (ax, cdf) = plt.subplots(1, 2, figsize=(10.0, 4.0), constrained_layout=True)
        data = {_label(k, sweep_cols): [r[name] for r in m if r[name] is not None and math.isfinite(r[name])]
                for k, m in groups.items()}
        finite = [v for vals in data.values() for v in vals]
        if not finite:
            plt.close(fig)
            continue
        bins = np.histogram_bin_edges(finite, bins=min(20, max(5, len(finite) // 3)))
        for i, (label, vals) in enumerate(data.items()):
            ax.hist(vals, bins=bins, alpha=0.5, color=f"C{i}", label=f"{label} (n {len(vals)})")
            review.ecdf_plot(cdf, np.array(vals), label, f"C{i}")
        verdict = review.requirement_marks([ax, cdf], [v for v in summary.get("requirements", [])
                                                       if v["metric"] == name])
        _finish(fig, cdf, name, "fraction of runs ≤ x", "empirical CDF", out, "", save_it=False)
        written.append(_finish(fig, ax, name, "runs", f"{name} over the runs" + (f"\n{verdict}" if verdict else ""),
                               out, f"hist_{_slug(name)}.png"))
    return written


def _finish(fig: Any, ax: Any, xlabel: str, ylabel: str, title: str, out: Path, name: str,
            save_it: bool = True) -> str:
    """Label, grid and legend ``ax``, save ``fig`` as ``out/name`` (unless not ``save_it``: a
    panel of a figure still to fill); returns ``name``."""
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    ax.set_title(title, fontsize=9)
    if save_it:
        save(fig, out / name)
    return name


def _plot_sweeps(out: Path, rows: list[dict[str, Any]], summary: dict[str, Any], metrics: list[str]) -> list[str]:
    plt = pyplot()
    ok = [r for r in rows if r["status"] == "ok"]
    written = []
    for target in summary["sweep"]:
        col = f"sweep.{target}"
        if not all(isinstance(r[col], (int, float)) and not isinstance(r[col], bool) for r in ok):
            continue  # a text or boolean parameter: the per-group table shows it
        for name in metrics:
            fig, ax = plt.subplots(figsize=(7.5, 4.0), constrained_layout=True)
            by_variant: dict[str, list[dict[str, Any]]] = defaultdict(list)
            for r in ok:
                by_variant[r["variant"]].append(r)
            for i, (variant, members) in enumerate(by_variant.items()):
                x = np.array([r[col] for r in members], float)
                y = np.array([np.nan if r[name] is None else r[name] for r in members], float)
                ax.plot(x, y, ".", color=f"C{i}", alpha=0.4, label=f"{variant or 'runs'}: each run")
                points = sorted(set(x.tolist()))
                if len(points) < len(x):  # a grid: several seeds per point
                    st = [stats(y[x == p].tolist()) for p in points]
                    keep = [j for j, s in enumerate(st) if s.get("n", 0) > 1]
                    if keep:
                        px = np.array(points)[keep]
                        mean = np.array([st[j]["mean"] for j in keep])
                        err = np.array([[st[j]["mean"] - st[j]["ci95"][0], st[j]["ci95"][1] - st[j]["mean"]]
                                        for j in keep]).T
                        ax.errorbar(px, mean, yerr=err, color=f"C{i}", marker="o", capsize=3,
                                    label=f"{variant or 'runs'}: mean, 95 % interval")
            written.append(_finish(fig, ax, target, name, f"{name} against {target}", out,
                                   f"sweep_{_slug(target)}__{_slug(name)}.png"))
    return written


def write_campaign_report(campaign_dir: Path, paper: Callable[[Path, str | None, str], str | None] | None = None,
                          table: Callable[[Path], str | None] | None = None) -> tuple[Path, dict[str, Any]]:
    """Write ``<campaign_dir>/report/`` from ``results.parquet``; returns it and the summary.
    ``paper(campaign_dir, variant, metric)``: the paper's figure, for the page's paper column.
    ``table(campaign_dir)``: an experiment's own table (e.g. the navigation CEP50), put as
    ``experiment_table`` in summary.json and summary.md and ahead of the text table (which
    ``gimbal-campaign`` prints and the page shows)."""
    campaign_dir = Path(campaign_dir)
    rows = read_results(campaign_dir)
    summary = summarize(rows)
    summary["results_digest"] = results_digest(rows)  # what --resume checks the report against
    out = campaign_dir / "report"
    out.mkdir(exist_ok=True)
    for old in [*out.glob("hist_*.png"), *out.glob("sweep_*.png"), *out.glob("scatter*.png"),
                *out.glob("convergence__*.png"), *out.glob("sensitivity*.png"), *out.glob("horizontal_error.png")]:
        old.unlink()
    metrics = figure_metrics(summary)
    _review(campaign_dir, rows, summary, metrics)
    ok = [r for r in rows if r["status"] == "ok"]
    sweep_cols = [f"sweep.{s}" for s in summary["sweep"]]
    # the review's plots first: they answer the review (the page shows them in this order)
    summary["plots"] = review.plots(out, ok, {_label(k, sweep_cols): m for k, m in _groups(ok, sweep_cols).items()},
                                    summary, metrics, _slug)
    summary["plots"] += _plot_histograms(out, rows, summary, metrics) + _plot_sweeps(out, rows, summary, metrics)
    summary["table"] = text_summary(summary, metrics)
    own = table(campaign_dir) if table is not None else None
    if own:  # the verdicts, then the experiment's own table, then the generic one
        summary["experiment_table"] = own
        summary["table"] = "\n\n".join([*(["\n".join(_review_lines(summary))] if _review_lines(summary) else []),
                                         own, text_summary(summary, metrics, head=False)])
    (out / "summary.json").write_text(json.dumps(summary, indent=1, default=float) + "\n")
    (out / "summary.md").write_text(_markdown(summary))
    _write_run_pages(campaign_dir, rows, paper)
    write_campaign_page(campaign_dir, out, summary, partial(paper, campaign_dir) if paper else None)
    return out, summary


def _review(campaign_dir: Path, rows: list[dict[str, Any]], summary: dict[str, Any], metrics: list[str]) -> None:
    """The requirements' verdicts and the sensitivity indices of the campaign in
    ``campaign_dir`` (its ``campaign.yaml``) into ``summary``."""
    record = yaml.safe_load((campaign_dir / "campaign.yaml").read_text()) or {}
    try:
        spec = spec_from_mapping(record.get("campaign") or {}, "campaign.yaml")
    except CampaignError:
        return  # an older or foreign record: the generic report only
    sweep_cols = [f"sweep.{s}" for s in summary["sweep"]]
    if spec.requirements:
        groups = {_label(k, sweep_cols): m for k, m in _groups(rows, sweep_cols).items()}
        summary["requirements"] = review.verdicts(groups, list(spec.requirements))
        summary["requirement_specs"] = [dataclasses.asdict(r) for r in spec.requirements]
    if spec.sensitivity and record.get("design"):
        factors = [t for t, _ in spec.dispersions]
        summary["sensitivity"] = {"method": spec.sensitivity, "samples": spec.samples, "factors": factors,
                                  "indices": review.indices(record["design"], spec.sensitivity, spec.samples,
                                                            spec.sample_seed, factors, rows, metrics)}


def _write_run_pages(campaign_dir: Path, rows: list[dict[str, Any]],
                     paper: Callable[[Path, str | None, str], str | None] | None) -> None:
    """Each run's page, rewritten where the run now is (a run is written in an attempt
    directory, then moved): its link back to the campaign, the paper's figures of its group."""
    for row in rows:
        run_dir = campaign_dir.resolve() / "runs" / str(row["run_id"])
        metrics = run_dir / "report" / "metrics.json"
        if row.get("status") == "ok" and metrics.is_file():
            write_run_page(run_dir, metrics.parent, json.loads(metrics.read_text()),
                           partial(paper, campaign_dir.resolve(), row.get("variant") or None) if paper else None)


def regenerate(campaign_dir: Path, write_report: Callable[[Path], Any] | None = None,
               paper: Callable[[Path, str | None, str], str | None] | None = None,
               table: Callable[[Path], str | None] | None = None) -> tuple[Path, dict[str, Any]]:
    """``gimbal-report CAMPAIGN_DIR``: rewrite each kept bag's run report (with
    ``write_report(run_dir)``, the run report writer it is handed; None: keep them), each
    run's row from its metrics, the results table, then the campaign report."""
    campaign_dir = Path(campaign_dir)
    asked = (yaml.safe_load((campaign_dir / "campaign.yaml").read_text()) or {}).get("campaign", {})
    rows = []
    for result in sorted((campaign_dir / "runs").glob(f"*/{RESULT_FILE}")):
        run_dir = result.parent
        if not re.fullmatch(r"[0-9a-f]{16}", run_dir.name):
            continue  # earlier failed attempts kept beside (<id>.failed-<time>)
        row = json.loads(result.read_text())
        if row["status"] == "ok":
            if write_report is not None and (run_dir / "metadata.yaml").is_file():
                write_report(run_dir)
            path = run_dir / "report" / "metrics.json"
            if path.is_file():
                row["metrics"] = flatten_metrics(json.loads(path.read_text()))
                result.write_text(json.dumps(row, indent=1, default=float) + "\n")
        rows.append(row)
    try:  # the table's order (the plan's), runs it does not know at the end
        order = {r["run_id"]: i for i, r in enumerate(read_results(campaign_dir))}
    except OSError:
        order = {}
    rows.sort(key=lambda r: (order.get(r["run_id"], len(order)), r["run_id"]))
    write_results(campaign_dir, rows, list((asked.get("sweep") or {}).keys()))
    return write_campaign_report(campaign_dir, paper, table)


def _pair_key(row: dict[str, Any], variant: bool) -> tuple:
    """What pairs a run of one campaign with one of another: its seed and swept values (the
    drawn values may differ: that is the comparison), and its variant when both have them."""
    return ((row["variant"],) if variant else ()) + (int(row["seed"]),) + tuple(
        (k, row[k]) for k in sorted(row) if k.startswith("sweep."))


def paired_change(pairs: list[tuple[float, float]], confidence: float = 0.95) -> dict[str, Any]:
    """The change b − a over paired runs: its mean with the paired Student t interval, and
    whether it is significant (the interval excludes 0; all-equal pairs: no change)."""
    from scipy.stats import t as student_t

    d = np.array([y - x for x, y in pairs], float)
    if d.size == 0:
        return {"pairs": 0}
    mean = float(d.mean())
    if d.size < 2 or not np.any(d != d[0]):
        lo = hi = mean if d.size >= 2 else math.nan
    else:
        half = float(student_t.ppf(0.5 + confidence / 2, d.size - 1) * d.std(ddof=1) / math.sqrt(d.size))
        lo, hi = mean - half, mean + half
    significant = bool(math.isfinite(lo) and (lo > 0 or hi < 0))
    return {"pairs": int(d.size), "mean_change": mean, "interval": [lo, hi], "confidence": confidence,
            "significant": significant}


def diff_results(dir_a: Path, dir_b: Path, prefix: str = "") -> dict[str, Any]:
    """Two campaigns' metrics on their paired runs (same seed and swept values, same variant
    when both campaigns have the same variants; else same seed across their one variant
    each): per metric starting with ``prefix``, the runs compared, max |a − b| and the
    paired change b − a with its 95 % interval (:func:`paired_change`)."""
    rows_a = [r for r in read_results(dir_a) if r["status"] == "ok"]
    rows_b = [r for r in read_results(dir_b) if r["status"] == "ok"]
    by_variant = {r["variant"] for r in rows_a} == {r["variant"] for r in rows_b} or \
        len({r["variant"] for r in rows_a}) > 1 or len({r["variant"] for r in rows_b}) > 1
    a = {_pair_key(r, by_variant): r for r in rows_a}
    b = {_pair_key(r, by_variant): r for r in rows_b}
    shared = sorted(set(a) & set(b), key=str)
    first_a, first_b = (rows_a[0] if rows_a else {}), (rows_b[0] if rows_b else {})
    cols = [c for c in first_a if c.startswith(prefix) and c in first_b and c not in ("wall_s", "seed")
            and not c.startswith(("sweep.", "dispersed.")) and isinstance(a[shared[0]][c] if shared else None, float)]
    out: dict[str, Any] = {"shared_runs": len(shared), "only_a": len(set(a) - set(b)), "only_b": len(set(b) - set(a)),
                           "paired_by": "variant, seed, swept values" if by_variant else "seed, swept values",
                           "metrics": {}}
    for c in cols:
        pairs = [(a[i][c], b[i][c]) for i in shared if a[i][c] is not None and b[i][c] is not None]
        finite = [(x, y) for x, y in pairs if math.isfinite(x) and math.isfinite(y)]
        same_nan = all(math.isfinite(x) == math.isfinite(y) for x, y in pairs)
        out["metrics"][c] = {"runs": len(finite), "max_abs_diff": max((abs(x - y) for x, y in finite), default=0.0),
                             "nonfinite_agree": same_nan, **paired_change(finite)}
    return out
