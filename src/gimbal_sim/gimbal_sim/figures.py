"""Figure plumbing shared by the reports: matplotlib on the headless Agg backend, panels
stacked over a shared time axis, one style for their axes, and writing a figure out."""
from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np


def pyplot() -> Any:
    """``matplotlib.pyplot`` on the Agg backend: reports run without a display (CI, ssh).
    Imported on first use, so loading a report module for its metrics stays cheap."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def stacked(rows: int, height_in: float, *, cols: int = 1, width_in: float = 9.0) -> tuple[Any, np.ndarray]:
    """A figure of ``rows`` × ``cols`` panels sharing the x axis; the axes as a (rows, cols) array."""
    return pyplot().subplots(rows, cols, figsize=(width_in, height_in), sharex=True, squeeze=False,
                             constrained_layout=True)


def style(ax: Any, ylabel: str, *, legend_loc: str = "best", fontsize: int = 8, ncol: int = 1) -> None:
    """The reports' panel style: y label, light grid, legend."""
    ax.set_ylabel(ylabel)
    ax.grid(True, alpha=0.3)
    ax.legend(loc=legend_loc, fontsize=fontsize, ncol=ncol)


def limit_lines(ax: Any, limit: float) -> None:
    """Dashed lines at ±``limit`` (an accuracy bound)."""
    for sign in (1, -1):
        ax.axhline(sign * limit, color="k", linestyle="--", linewidth=0.7)


def save(fig: Any, path: Path, *, dpi: int = 110) -> None:
    """Write ``fig`` to ``path`` and release it (pyplot keeps every open figure)."""
    fig.savefig(path, dpi=dpi)
    pyplot().close(fig)


def save_stacked(fig: Any, axes: np.ndarray, path: Path, title: str, *, xlabel: str = "sim time [s]",
                 dpi: int = 110) -> None:
    """Title on the top panel, ``xlabel`` under the bottom row, then :func:`save`."""
    axes[0, 0].set_title(title)
    for ax in axes[-1]:
        ax.set_xlabel(xlabel)
    save(fig, path, dpi=dpi)
