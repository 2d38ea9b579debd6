"""What a design review asks of a campaign, from its results table and ``campaign.yaml``:
each requirement's verdict per group (:mod:`.order_stats`), the sensitivity indices of each
metric (:mod:`.sensitivity`) and the plots that show them (ECDF with the requirement's
line, each metric against each dispersed parameter, the navigation error scatter with its
CEP50 circle and covariance ellipses, the convergence of each reported quantile, the
indices as bars). :mod:`.report` puts them in the summary; the page puts them first."""
from __future__ import annotations

import math
import re
from pathlib import Path
from typing import Any, Callable

import numpy as np

from ..figures import pyplot, save
from . import sensitivity
from .order_stats import Requirement, quantile_interval, upper_bound_rank, verdict

#: A navigation campaign's end-of-run horizontal error: metric names ending so.
NORTH, EAST = re.compile(r"(^|\.)(final_)?north_error_m$"), re.compile(r"(^|\.)(final_)?east_error_m$")
#: The CEP rate a navigation campaign reports the median of (CEP50).
CEP_RATE = re.compile(r"(^|\.)(final_)?radial_rate_nmi_h$")
#: Metrics drawn in the scatter and index figures: at most this many (the first the summary lists).
MAX_INDEX_PLOTS = 8


def _finite(rows: list[dict[str, Any]], col: str) -> np.ndarray:
    return np.array([r[col] for r in rows if r.get(col) is not None and math.isfinite(r[col])], float)


def verdicts(groups: dict[str, list[dict[str, Any]]], requirements: list[Requirement]) -> list[dict[str, Any]]:
    """Each requirement's verdict in each group (label -> its ok runs); a failed run or a
    run without the metric counts against the requirement (it is in no group: see caller)."""
    out = []
    for req in requirements:
        for label, members in groups.items():
            v = verdict(req, [r.get(req.metric) for r in members])
            out.append({"group": label, **v})
    return out


def indices(design: dict[str, list[str]], method: str, samples: int, sample_seed: int, factors: list[str],
            rows: list[dict[str, Any]], metrics: list[str]) -> dict[str, Any]:
    """Per variant and metric the indices of the design's runs (``design``: variant -> run id of
    each row); a metric some row lacks (a failed run, a NaN) gets its reason instead."""
    by_id = {r["run_id"]: r for r in rows if r["status"] == "ok"}
    unit = sensitivity.design(method, samples, factors, sample_seed)
    out: dict[str, Any] = {}
    for variant, ids in design.items():
        per_metric = {}
        for name in metrics:
            y = [by_id[i].get(name) if i in by_id else None for i in ids]
            missing = sum(v is None or not math.isfinite(v) for v in y)
            if missing:
                per_metric[name] = {"error": f"{missing} of {len(y)} design rows have no finite value"}
            elif np.std(y) == 0.0:
                continue  # constant: nothing to apportion
            else:
                per_metric[name] = sensitivity.analyze(method, factors, unit, y, sample_seed)
        out[variant or "all runs"] = per_metric
    return out


# ------------------------------------------------------------------------ plots
def ecdf_plot(ax: Any, values: np.ndarray, label: str, color: str) -> None:
    x = np.sort(values)
    ax.step(x, np.arange(1, x.size + 1) / x.size, where="post", color=color, label=f"{label} (n {x.size})")


def requirement_marks(axes: list[Any], reqs: list[dict[str, Any]]) -> str:
    """The requirement's bound on each axis and its verdict as text (for the title)."""
    texts = []
    for v in reqs:
        bound = v["max"] if "max" in v else v["min"]
        for ax in axes:
            for b in ((bound, -bound) if v.get("abs") else (bound,)):
                ax.axvline(b, color="k", linestyle="--", linewidth=1.0)
        texts.append(f"{v['group']}: {v['verdict']}")
    if reqs:
        axes[-1].axhline(reqs[0]["p"] if "max" in reqs[0] else 1 - reqs[0]["p"], color="0.4", linestyle=":",
                         linewidth=0.8)
    return "; ".join(texts)


def scatter_plot(out: Path, rows: list[dict[str, Any]], params: list[str], names: list[str]) -> str:
    """Each metric of ``names`` (rows) against each dispersed parameter (columns), every run."""
    plt = pyplot()
    fig, axes = plt.subplots(len(names), len(params), figsize=(3.3 * len(params) + 1.0, 2.4 * len(names) + 0.6),
                             squeeze=False, constrained_layout=True)
    variants = sorted({r["variant"] for r in rows})
    for row, name in enumerate(names):
        for ax, param in zip(axes[row], params):
            for i, variant in enumerate(variants):
                members = [r for r in rows if r["variant"] == variant]
                ax.plot([r[f"dispersed.{param}"] for r in members],
                        [np.nan if r.get(name) is None else r[name] for r in members], ".", color=f"C{i}",
                        alpha=0.5, label=variant or "runs")
            ax.grid(True, alpha=0.3)
            if row == len(names) - 1:
                ax.set_xlabel(param.split(".", 1)[-1], fontsize=8)
        axes[row, 0].set_ylabel(name.split(".", 1)[-1], fontsize=7)
    axes[0, 0].legend(fontsize=7)
    fig.suptitle("each metric against each dispersed parameter (every run)", fontsize=9)
    save(fig, out / "scatter.png")
    return "scatter.png"


def _ellipse(cov: np.ndarray, k: float) -> np.ndarray:
    w, v = np.linalg.eigh(cov)
    t = np.linspace(0, 2 * math.pi, 200)
    return (v @ (np.sqrt(np.maximum(w, 0.0))[:, None] * np.vstack([np.cos(t), np.sin(t)]))).T * k


def horizontal_error_plot(out: Path, rows: list[dict[str, Any]], north: str, east: str) -> tuple[str, dict]:
    """East/north error at the end of each run, per variant, with the CEP50 circle (the median
    radial error) and the 50 % and 95 % ellipses of the sample covariance (χ²₂ quantiles)."""
    from scipy.stats import chi2

    plt = pyplot()
    fig, ax = plt.subplots(figsize=(6.5, 6.0), constrained_layout=True)
    figures = {}
    for i, variant in enumerate(sorted({r["variant"] for r in rows})):
        members = [r for r in rows if r["variant"] == variant and r.get(north) is not None and r.get(east) is not None]
        e = np.array([r[east] for r in members], float)
        n = np.array([r[north] for r in members], float)
        if e.size < 3:
            continue
        cep50 = float(np.median(np.hypot(e, n)))
        mean = np.array([e.mean(), n.mean()])
        cov = np.cov(np.vstack([e, n]))
        c = f"C{i}"
        ax.plot(e, n, ".", color=c, alpha=0.6, label=f"{variant or 'runs'} (n {e.size})")
        t = np.linspace(0, 2 * math.pi, 200)
        ax.plot(cep50 * np.cos(t), cep50 * np.sin(t), "-", color=c, linewidth=1.2, label=f"CEP50 {cep50:.4g} m")
        for p, style in ((0.5, "--"), (0.95, ":")):
            pts = _ellipse(cov, math.sqrt(chi2.ppf(p, 2))) + mean
            ax.plot(pts[:, 0], pts[:, 1], style, color=c, linewidth=1.0, label=f"{p:.0%} covariance ellipse")
        figures[variant or "all runs"] = {"runs": int(e.size), "cep50_m": cep50, "mean_en_m": mean.tolist(),
                                          "cov_en_m2": cov.tolist()}
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("east error at the end [m]")
    ax.set_ylabel("north error at the end [m]")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=7)
    ax.set_title("horizontal position error at the end of each run")
    save(fig, out / "horizontal_error.png")
    return "horizontal_error.png", figures


def convergence_plot(out: Path, groups: dict[str, list[dict[str, Any]]], name: str, q: float, c: float,
                     slug: str, bound: float | None = None, absolute: bool = False) -> str:
    """The running q-quantile of ``name`` (its magnitude when ``absolute``) against the number
    of runs, with its two-sided c interval (order statistics) and, for an upper bound, the
    Wilks upper bound at c."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(7.5, 4.0), constrained_layout=True)
    for i, (label, members) in enumerate(groups.items()):
        x = np.abs(_finite(members, name)) if absolute else _finite(members, name)
        ns = np.arange(1, x.size + 1)
        est = np.array([quantile_interval(x[:k], q, c) for k in ns])
        ax.plot(ns, est[:, 0], "-", color=f"C{i}", label=f"{label}: running {q:g}-quantile")
        lo, hi = (np.where(np.isfinite(est[:, j]), est[:, j], np.nan) for j in (1, 2))
        ax.fill_between(ns, lo, hi, color=f"C{i}", alpha=0.2)
        # an end of the interval exists only from some run count on: each drawn where it does
        ax.plot(ns, lo, "--", color=f"C{i}", linewidth=0.8, label=f"{c:.0%} interval (order statistics)")
        ax.plot(ns, hi, "--", color=f"C{i}", linewidth=0.8)
        if bound is not None:
            ranks = [upper_bound_rank(k, q, c) for k in ns]
            wilks = [np.sort(x[:k])[r - 1] if r else np.nan for k, r in zip(ns, ranks)]
            ax.plot(ns, wilks, "v:", color=f"C{i}", markersize=4, label=f"Wilks upper bound ({c:.0%})")
    if bound is not None:
        ax.axhline(bound, color="k", linestyle="--", linewidth=1.0, label=f"requirement {bound:g}")
    shown = f"|{name}|" if absolute else name
    ax.set_xlabel("runs")
    ax.set_ylabel(shown)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=7)
    ax.set_title(f"convergence of the {q:g}-quantile of {shown}", fontsize=9)
    file = f"convergence__{slug}.png"
    save(fig, out / file)
    return file


def index_plot(out: Path, names: list[str], per_variant: dict[str, Any]) -> str | None:
    """One tornado per metric of ``names`` (rows) and variant (columns): Sobol S1 and ST, or
    Morris μ*, of each factor with its bootstrap interval."""
    plt = pyplot()
    variants = [v for v, m in per_variant.items() if any("factors" in m.get(n, {}) for n in names)]
    names = [n for n in names if any("factors" in per_variant[v].get(n, {}) for v in variants)]
    if not names:
        return None
    n_factors = max(len(per_variant[v][n]["factors"]) for v in variants for n in names if n in per_variant[v])
    fig, axes = plt.subplots(len(names), len(variants), figsize=(4.8 * len(variants) + 2.0,
                                                                 (0.32 * n_factors + 0.9) * len(names) + 0.6),
                             squeeze=False, constrained_layout=True)
    for row, name in enumerate(names):
        for col, variant in enumerate(variants):
            ax, res = axes[row, col], per_variant[variant].get(name, {})
            if "factors" not in res:
                ax.set_axis_off()
                continue
            factors = list(res["factors"])
            y = np.arange(len(factors))
            keys = (("S1", -0.18, "first order"), ("ST", 0.18, "total")) if res["method"] == "sobol" else \
                (("mu_star", 0.0, "μ* (per unit of probability)"),)
            for k, (key, offset, label) in enumerate(keys):
                ax.barh(y + offset, [res["factors"][f][key] for f in factors], height=0.34 if offset else 0.6,
                        xerr=[res["factors"][f][f"{key}_conf"] for f in factors], color=f"C{k}", capsize=2,
                        label=label)
            ax.set_yticks(y, [f.split(".", 1)[-1] for f in factors], fontsize=7)
            ax.invert_yaxis()
            ax.grid(True, axis="x", alpha=0.3)
            ax.set_title(f"{name} [{variant}]", fontsize=8)
            if row == 0 and col == 0:
                ax.legend(fontsize=7)
    fig.suptitle(f"sensitivity ({per_variant[variants[0]][names[0]]['method']}): index of each factor, "
                 "95 % bootstrap interval", fontsize=9)
    save(fig, out / "sensitivity.png")
    return "sensitivity.png"


def navigation_columns(columns: list[str]) -> tuple[str, str] | None:
    """The (north, east) end-error columns of a navigation campaign, if it has them."""
    north = [c for c in columns if NORTH.search(c)]
    east = [c for c in columns if EAST.search(c)]
    return (north[0], east[0]) if north and east else None


def quantiles_reported(columns: list[str], requirements: list[Requirement]) -> list[tuple[str, float, float, Any,
                                                                                          bool]]:
    """(metric, quantile, confidence, upper bound or None, of the magnitude) of each quantile
    the campaign reports: each requirement's p-quantile (1 − p for a lower bound) at its c,
    and a navigation campaign's CEP50 (the median of the CEP rate) at 95 %."""
    out = [(r.metric, r.p if r.upper else 1 - r.p, r.c, r.bound if r.upper else None, r.absolute)
           for r in requirements]
    out += [(c, 0.5, 0.95, None, False) for c in columns if CEP_RATE.search(c) and (c, 0.5) not in
            {o[:2] for o in out}]
    return out


def plots(out: Path, ok: list[dict[str, Any]], groups: dict[str, list[dict[str, Any]]], summary: dict[str, Any],
          metrics: list[str], slug: Callable[[str], str]) -> list[str]:
    """The review's plots (module docstring) into ``out``; returns their file names."""
    written: list[str] = []
    columns = list(ok[0]) if ok else []
    dispersed = [c.removeprefix("dispersed.") for c in columns if c.startswith("dispersed.")]
    if dispersed:
        numeric = [p for p in dispersed if all(isinstance(r[f"dispersed.{p}"], (int, float)) for r in ok)]
        reqs = [r["metric"] for r in summary.get("requirements", [])]
        names = [n for n in dict.fromkeys([*reqs, *metrics]) if n in columns][:MAX_INDEX_PLOTS]
        if numeric and names:
            written.append(scatter_plot(out, ok, numeric, names))
    nav = navigation_columns(columns)
    if nav:
        file, figures = horizontal_error_plot(out, ok, *nav)
        summary["horizontal_error"] = figures
        written.append(file)
    requirements = [Requirement(**{k: v for k, v in r.items() if k in ("metric", "bound", "p", "c", "upper",
                                                                        "absolute")})
                    for r in summary.get("requirement_specs", [])]
    for name, q, c, bound, absolute in quantiles_reported(columns, requirements):
        if name in columns:
            written.append(convergence_plot(out, groups, name, q, c, slug(f"{name}_{q:g}"), bound, absolute))
    per_variant = summary.get("sensitivity", {}).get("indices", {})
    names = list(dict.fromkeys(n for per in per_variant.values() for n in per))[:MAX_INDEX_PLOTS]
    file = index_plot(out, names, per_variant) if names else None
    return written + ([file] if file else [])
