"""One page per report: ``report/index.html`` of a run, a variant comparison or a campaign.

The page is one self-contained file: the scenario and its parameters, the metrics with their
units (and the paper's figure beside a measured one where the caller knows it), every plot of
the report directory embedded as a ``data:`` URI, the commands that reproduce it and links
to the pages of the other variants and of the campaign (relative, so the tree can move). It
loads nothing from the network and opens from ``file://``. It sits in a room of its own,
below the campaign and the reports, which both finish by calling it.
"""
from __future__ import annotations

import base64
import html
import json
import os
import re
import shlex
from pathlib import Path
from typing import Any, Callable

import yaml

PAGE = "index.html"
#: Unit suffixes of metric names (their last word carrying one wins) -> the unit shown.
UNITS = (("_deg_h", "deg/h"), ("_deg_s", "deg/s"), ("_arcsec", "arcsec"), ("_arcmin", "arcmin"),
         ("_urad", "µrad"), ("_mrad", "mrad"), ("_rad", "rad"), ("_deg", "deg"), ("_ma", "mA"), ("_ug", "µg"),
         ("_hz", "Hz"), ("_ms", "ms"), ("_per_s", "1/s"), ("_s", "s"), ("_m", "m"), ("_pct", "%"))
#: Top-level entries of metrics.json that are not figures: shown elsewhere or not at all.
NOT_FIGURES = {"plots", "table", "runs", "bag", "report", "comparison", "read_error", "topics"}
#: The paper's figure of a metric (dotted name) or None.
PaperLookup = Callable[[str], "str | None"]
#: The paper's figure of a metric in a campaign's group of a variant (None: no variant) or None.
GroupPaperLookup = Callable[["str | None", str], "str | None"]

_STYLE = """
body{font-family:sans-serif;margin:1.5em auto;padding:0 1em;max-width:1100px;color:#222}
h1{font-size:1.5em}h2{font-size:1.2em;border-bottom:1px solid #ccc;margin-top:1.6em}
table{border-collapse:collapse;font-size:.9em}td,th{border:1px solid #ccc;padding:2px 8px;text-align:left}
td.num{text-align:right;font-family:monospace}pre{background:#f4f4f4;padding:.6em;overflow-x:auto}
figure{margin:1em 0}img{max-width:100%;border:1px solid #ddd}figcaption{font-size:.85em;color:#555}
nav a{margin-right:1em}
"""


def unit_of(name: str) -> str:
    """The unit of a dotted metric name from the unit suffix of its last word that has one."""
    for word in reversed(name.split(".")):
        for suffix, unit in UNITS:
            if word.endswith(suffix):
                return unit
    return ""


def _number(value: Any) -> str:
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, float):
        return f"{value:.6g}"
    return "–" if value is None else str(value)


def flat_figures(metrics: dict[str, Any], prefix: str = "") -> list[tuple[str, Any]]:
    """(dotted name, value) of every scalar leaf of ``metrics`` (lists of numbers as one row)."""
    rows: list[tuple[str, Any]] = []
    for key, value in metrics.items():
        if not prefix and key in NOT_FIGURES:
            continue
        name = f"{prefix}{key}"
        if isinstance(value, dict):
            rows += flat_figures(value, name + ".")
        elif isinstance(value, list):
            if value and all(isinstance(v, (int, float, bool)) or v is None for v in value):
                rows.append((name, "[" + ", ".join(_number(v) for v in value) + "]"))
        elif isinstance(value, (int, float, bool)) or value is None:
            rows.append((name, value))
        elif isinstance(value, str) and len(value) < 200:
            rows.append((name, value))
    return rows


def _table(header: list[str], rows: list[list[str]], numeric: set[int] = frozenset()) -> str:
    head = "".join(f"<th>{html.escape(h)}</th>" for h in header)
    body = "".join("<tr>" + "".join(f"<td class=\"num\">{c}</td>" if i in numeric else f"<td>{c}</td>"
                                    for i, c in enumerate(r)) + "</tr>" for r in rows)
    return f"<table><tr>{head}</tr>{body}</table>"


def metrics_section(metrics: dict[str, Any], paper: PaperLookup | None = None) -> str:
    """The metrics table (name, value, unit, the paper's figure) and the report's text table."""
    rows = flat_figures(metrics)
    papers = {name: (paper(name) if paper else None) for name, _ in rows}
    header = ["metric", "value", "unit"] + (["paper"] if any(papers.values()) else [])
    out = [_table(header, [[html.escape(n), html.escape(_number(v)), html.escape(unit_of(n))]
                           + ([html.escape(papers[n] or "")] if len(header) > 3 else []) for n, v in rows], {1})]
    if metrics.get("table"):
        out.append(f"<pre>{html.escape(str(metrics['table']))}</pre>")
    topics = metrics.get("topics")
    if isinstance(topics, dict) and topics:
        trs = [[html.escape(t), html.escape(_number(v.get("count") if isinstance(v, dict) else v))]
               for t, v in topics.items()]
        out.append(f"<details><summary>recorded topics ({len(topics)})</summary>"
                   f"{_table(['topic', 'messages'], trs, {1})}</details>")
    return "\n".join(out)


def plots_section(report_dir: Path, plots: list[str]) -> str:
    """Every plot the report lists, then any other PNG of ``report_dir``, embedded inline."""
    names = list(dict.fromkeys([*plots, *sorted(p.name for p in report_dir.glob("*.png"))]))
    figures = []
    for name in names:
        path = report_dir / name
        if not path.is_file():
            continue
        data = base64.b64encode(path.read_bytes()).decode("ascii")
        figures.append(f"<figure><img alt=\"{html.escape(name)}\" src=\"data:image/png;base64,{data}\">"
                       f"<figcaption>{html.escape(name)}</figcaption></figure>")
    return "\n".join(figures) or "<p>No plots.</p>"


def scenario_section(scenario_file: Path) -> str:
    """The scenario's settings, each node's parameters and the variants, from its YAML."""
    if not scenario_file.is_file():
        return "<p>No scenario.yaml beside the bag (a bag recorded elsewhere).</p>"
    data = yaml.safe_load(scenario_file.read_text()) or {}
    facts = [[html.escape(k), html.escape(_number(v))] for k, v in data.items()
             if k not in ("nodes", "variants") and not isinstance(v, (dict, list))]
    out = [_table(["setting", "value"], facts)]
    nodes = data.get("nodes") or {}
    if nodes:
        rows = [[html.escape(name), html.escape(str(node.get("executable", ""))),
                 "<br>".join(f"{html.escape(k)}: {html.escape(json.dumps(v, default=str))}"
                             for k, v in (node.get("params") or {}).items())] for name, node in nodes.items()]
        out.append("<h3>Nodes and parameters</h3>" + _table(["node", "executable", "parameters"], rows))
    variants = data.get("variants") or {}
    if variants:
        rows = [[html.escape(name), "<br>".join(f"{html.escape(k)}: {html.escape(json.dumps(v, default=str))}"
                                                for k, v in (over or {}).items())] for name, over in variants.items()]
        out.append("<h3>Variants</h3>" + _table(["variant", "overrides"], rows))
    return "\n".join(out)


def _link(report_dir: Path, target_dir: Path, label: str) -> str:
    rel = os.path.relpath(Path(target_dir) / "report" / PAGE, report_dir)
    return f"<a href=\"{html.escape(Path(rel).as_posix())}\">{html.escape(label)}</a>"


def _commands(lines: list[list[str]]) -> str:
    return "<pre>" + "\n".join(html.escape(shlex.join(str(a) for a in line)) for line in lines) + "</pre>"


def _render(report_dir: Path, title: str, sections: list[tuple[str, str]], nav: list[str]) -> Path:
    body = "\n".join(f"<h2>{html.escape(head)}</h2>\n{content}" for head, content in sections if content)
    nav_html = f"<nav>{''.join(nav)}</nav>" if nav else ""
    page = (f"<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">"
            f"<title>{html.escape(title)}</title><style>{_STYLE}</style></head>\n<body>\n"
            f"<h1>{html.escape(title)}</h1>\n{nav_html}\n{body}\n</body></html>\n")
    path = Path(report_dir) / PAGE
    path.write_text(page, encoding="utf-8")
    return path


def _run_links(bag_dir: Path, report_dir: Path) -> list[str]:
    """Links of a run's page: the comparison and the other variants, or the campaign."""
    parent = bag_dir.parent
    links = []
    if (parent.parent / "campaign.yaml").is_file() and parent.name == "runs":
        links.append(_link(report_dir, parent.parent, "↑ campaign"))
    spec = parent / "scenario.yaml"
    if not (parent / "metadata.yaml").is_file() and spec.is_file():
        variants = (yaml.safe_load(spec.read_text()) or {}).get("variants") or {}
        if bag_dir.name in variants:
            links.append(_link(report_dir, parent, "↑ comparison"))
            links += [_link(report_dir, parent / v, f"variant {v}") for v in variants
                      if v != bag_dir.name and (parent / v).is_dir()]
    return links


def _run_facts(bag_dir: Path) -> str:
    """What ``run.json`` says of a run with no scenario.yaml (an experiment runner's run)."""
    path = bag_dir / "run.json"
    if not path.is_file():
        return ""
    run = json.loads(path.read_text())
    rows = [[html.escape(k), html.escape(json.dumps(v, default=str) if isinstance(v, (dict, list)) else _number(v))]
            for k, v in run.items()]
    return _table(["run", "value"], rows)


def _run_command(bag_dir: Path) -> tuple[str, list[list[str]]]:
    """(what the commands do, the commands) that reproduce the run in ``bag_dir``."""
    run = json.loads((bag_dir / "run.json").read_text()) if (bag_dir / "run.json").is_file() else {}
    spec = bag_dir / "scenario.yaml"
    has_bag = (bag_dir / "metadata.yaml").is_file() or any(bag_dir.glob("*.mcap"))
    if run.get("engine") == "core":  # no bag: the core engine again, the same seed
        if not spec.is_file():
            return (f"One seeded run of the experiment <code>{html.escape(str(run.get('experiment', '')))}"
                    "</code> (its runner's own loop, no bag): the runner, given the seed and the options above, "
                    "runs it again (docs/campaigns.md lists the runners and their options).", [])
        return "Run the same scenario again on the core engine (same seed, same numbers):", [
            ["gimbal-campaign", str(spec), "--engine", "core", "--seeds", str(run.get("seed", 0)), "--serial",
             "--out", "NEW_DIR"]]
    extra = (["--mode", run["mode"]] if run.get("mode") == "container" else []) + \
        (["--no-compress"] if run.get("compressed") is False else [])
    lines = [["gimbal-report", str(bag_dir)]] if has_bag else []
    if spec.is_file():
        lines.insert(0, ["gimbal-run", str(spec), "--out", "NEW_DIR", *extra])
    return ("Run the same scenario again (same seed, same data)"
            + (", or rewrite this report from the bag:" if has_bag else ":")), lines


def write_run_page(bag_dir: Path, report_dir: Path, metrics: dict[str, Any], paper: PaperLookup | None = None) -> Path:
    """``report_dir/index.html`` of the run recorded in ``bag_dir`` (or run there by the
    core engine: no bag, its ``run.json`` says how it ran)."""
    bag_dir = Path(bag_dir).resolve()
    name = metrics.get("report", "generic")
    spec = bag_dir / "scenario.yaml"
    what, commands = _run_command(bag_dir)
    return _render(report_dir, f"Run {bag_dir.name} ({name} report)", [
        ("Scenario", scenario_section(spec) if spec.is_file() or not (bag_dir / "run.json").is_file()
         else _run_facts(bag_dir)),
        ("Metrics", metrics_section(metrics, paper)),
        ("Plots", plots_section(Path(report_dir), metrics.get("plots", []))),
        ("Reproduce", f"<p>{what}</p>" + (_commands(commands) if commands else "")),
    ], _run_links(bag_dir, Path(report_dir)))


def write_comparison_page(run_dir: Path, report_dir: Path, metrics: dict[str, Any], runs: dict[str, Path],
                          paper: PaperLookup | None = None,
                          run_paper: Callable[[Path], PaperLookup] | None = None) -> Path:
    """``report_dir/index.html`` of the comparison of the variant runs ``runs`` in ``run_dir``;
    rewrites the variants' pages too, which now have a comparison to link to (with the
    lookup ``run_paper(scenario file)`` makes for each, else ``paper``)."""
    run_dir = Path(run_dir).resolve()
    for bag in runs.values():
        run_metrics = Path(bag) / "report" / "metrics.json"
        if run_metrics.is_file():
            lookup = run_paper(Path(bag) / "scenario.yaml") if run_paper else paper
            write_run_page(Path(bag), run_metrics.parent, json.loads(run_metrics.read_text()), lookup)
    links = [_link(Path(report_dir), Path(bag).resolve(), f"variant {name}") for name, bag in runs.items()]
    if run_dir.parent.name == "runs" and (run_dir.parent.parent / "campaign.yaml").is_file():
        links.insert(0, _link(Path(report_dir), run_dir.parent.parent, "↑ campaign"))
    spec = run_dir / "scenario.yaml"
    command = ([["gimbal-run", str(spec), "--out", "NEW_DIR"]] if spec.is_file() else []) + \
        [["gimbal-report", str(run_dir)]]
    return _render(report_dir, f"Comparison {metrics.get('comparison', '')}: {run_dir.name}", [
        ("Scenario", scenario_section(spec)),
        ("Metrics", metrics_section(metrics, paper)),
        ("Plots", plots_section(Path(report_dir), metrics.get("plots", []))),
        ("Reproduce", "<p>Run every variant again, or rewrite the reports from the bags:</p>" + _commands(command)),
    ], links)


def _campaign_tables(summary: dict[str, Any], paper: GroupPaperLookup | None = None) -> str:
    """Per group, each metric's statistics, with a paper column where a metric has a figure."""
    out = [f"<p>{summary.get('ok', 0)} of {summary.get('runs', 0)} runs ok.</p>"]
    for g in summary.get("groups", []):
        named = [(n, s) for n, s in g["metrics"].items() if s.get("n")]
        papers = {n: paper(g.get("variant") or None, n) if paper else None for n, _ in named}
        header = ["metric", "n", "mean", "std", "95 % interval of the mean", "unit"] + \
            (["paper"] if any(papers.values()) else [])
        rows = [[html.escape(n), str(s["n"]), html.escape(_number(s["mean"])), html.escape(_number(s["std"])),
                 html.escape(f"[{_number(s['ci95'][0])}, {_number(s['ci95'][1])}]"), html.escape(unit_of(n))]
                + ([html.escape(papers[n] or "")] if len(header) > 6 else []) for n, s in named]
        out.append(f"<h3>{html.escape(g['label'])} ({g['runs']} runs)</h3>" + _table(header, rows, {1, 2, 3}))
        for name, v in g.get("nees", {}).items():
            band = f"[{v['band95'][0]:.3f}, {v['band95'][1]:.3f}]" if v.get("n") else "–"
            out.append(f"<p>NEES {html.escape(name)} ({v['dof']} dof): mean "
                       f"{html.escape(_number(v.get('mean')))} over {v['n']} runs, 95 % band {band}: "
                       f"<b>{html.escape(v['verdict'])}</b></p>")
    if summary.get("table"):
        out.append(f"<pre>{html.escape(summary['table'])}</pre>")
    return "\n".join(out)


def _verdicts(summary: dict[str, Any]) -> str:
    """Each requirement's verdict per group: the order statistic used, the pass fraction."""
    rows = []
    for v in summary.get("requirements", []):
        lo, hi = v["pass_fraction_interval"]
        color = {"met": "#1a7f37", "not met": "#c62828"}.get(v["verdict"], "#b26a00")
        rows.append([html.escape(v["requirement"]), html.escape(v["group"]),
                     f"<b style=\"color:{color}\">{html.escape(v['verdict'].upper())}</b>",
                     html.escape(v["detail"]), html.escape(v.get("quantile") or "–"),
                     html.escape(f"{v['passed']}/{v['runs']} [{lo:.3f}, {hi:.3f}]")])
    return _table(["requirement", "group", "verdict", "order statistic", "quantile used",
                   "runs passing (Clopper–Pearson interval at c)"], rows) if rows else ""


def _indices(summary: dict[str, Any]) -> str:
    """The sensitivity indices of each metric per variant, with their bootstrap intervals."""
    sens = summary.get("sensitivity") or {}
    out = []
    for variant, per in sens.get("indices", {}).items():
        for name, res in per.items():
            if "error" in res:
                out.append(f"<p>{html.escape(name)} [{html.escape(variant)}]: {html.escape(res['error'])}</p>")
                continue
            if res["method"] == "sobol":
                header = ["factor", "first order S1 (95 % bootstrap)", "total ST (95 % bootstrap)"]
                rows = [[html.escape(f), f"{x['S1']:.3f} ± {x['S1_conf']:.3f}", f"{x['ST']:.3f} ± {x['ST_conf']:.3f}"]
                        for f, x in res["factors"].items()]
            else:
                header = ["factor", "μ* (95 % bootstrap)", "μ", "σ"]
                rows = [[html.escape(f), f"{x['mu_star']:.4g} ± {x['mu_star_conf']:.3g}", f"{x['mu']:.4g}",
                         f"{x['sigma']:.4g}"] for f, x in res["factors"].items()]
            out.append(f"<h3>{html.escape(name)} [{html.escape(variant)}]</h3>" + _table(header, rows, {1, 2, 3}))
    if out:
        out.insert(0, f"<p>{html.escape(sens['method'])} design, N = {sens['samples']}; the seed's noise is its own "
                      f"factor.</p>")
    return "\n".join(out)


def _campaign_runs(campaign_dir: Path, report_dir: Path) -> str:
    rows = []
    for result in sorted((campaign_dir / "runs").glob("*/result.json")):
        row = json.loads(result.read_text())
        run_dir = result.parent
        page = run_dir / "report" / PAGE
        label = _link(report_dir, run_dir, row.get("run_id", run_dir.name)) if page.is_file() \
            else html.escape(row.get("run_id", run_dir.name))
        rows.append([label, html.escape(str(row.get("variant") or "–")), html.escape(str(row.get("seed"))),
                     html.escape(str(row.get("status"))), html.escape(str(row.get("reason") or ""))])
    return _table(["run", "variant", "seed", "status", "reason"], rows) if rows else ""


def write_campaign_page(campaign_dir: Path, report_dir: Path, summary: dict[str, Any],
                        paper: GroupPaperLookup | None = None) -> Path:
    """``report_dir/index.html`` of the campaign in ``campaign_dir`` (its ``summary``);
    ``paper``: the paper's figure of a metric in a group (its variant), for a paper column."""
    campaign_dir = Path(campaign_dir).resolve()
    spec = campaign_dir / "campaign.yaml"
    spec_html = f"<pre>{html.escape(spec.read_text())}</pre>" if spec.is_file() else ""
    return _render(report_dir, f"Campaign {campaign_dir.name}", [
        ("Requirements", _verdicts(summary)),
        ("Sensitivity", _indices(summary)),
        ("Campaign", spec_html),
        ("Metrics over the runs", _campaign_tables(summary, paper)),
        ("Plots", plots_section(Path(report_dir), summary.get("plots", []))),
        ("Runs", _campaign_runs(campaign_dir, Path(report_dir))),
        ("Reproduce", "<p>Run the campaign again, or rewrite every report from the kept bags:</p>"
                      + _commands([["gimbal-campaign", str(spec), "--out", "NEW_DIR"],
                                   ["gimbal-report", str(campaign_dir)]])),
    ], [])
