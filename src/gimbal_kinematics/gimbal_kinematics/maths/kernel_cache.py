"""Where numba keeps the compiled kernels: a directory named by every kernel's source.

numba's ``cache=True`` checks only the source file of the function it compiled. A kernel
that calls another module's kernel (the engine's block loops call the cores' kernels) would
keep its cached machine code after that other kernel changed: stale code, wrong numbers or a
crash. So the cache lives in ``<cache home>/gimbal-numba/<hash>``, the hash taken over every
``*_kernels.py`` of the four packages (path and bytes): any change to any kernel gives a
fresh directory, an unchanged tree finds its kernels again. :func:`configure` runs when any
of the packages is imported, before a kernel compiles; a ``NUMBA_CACHE_DIR`` already set
(the user's choice) is left alone.
"""
from __future__ import annotations

import hashlib
import os
import sys
from pathlib import Path

PACKAGES = ("gimbal_kinematics", "gimbal_control", "gimbal_estimators", "gimbal_sim")


def kernel_sources(here: Path | None = None) -> list[Path]:
    """Every ``*_kernels.py`` of the four packages, found beside this one (a source tree's
    ``src/<pkg>/<pkg>`` or an install's ``<site>/<pkg>``), in a fixed order."""
    pkg = Path(here or __file__).resolve().parent
    while pkg.name != "gimbal_kinematics" and pkg != pkg.parent:
        pkg = pkg.parent
    source_tree = pkg.parent.name == "gimbal_kinematics"
    root = pkg.parent.parent if source_tree else pkg.parent
    out = []
    for name in PACKAGES:
        base = root / name / name if source_tree else root / name
        if base.is_dir():
            out += sorted(base.rglob("*_kernels.py"))
    return out


def cache_dir(here: Path | None = None) -> Path:
    """The kernels' cache directory for this tree's kernel sources."""
    digest = hashlib.sha256()
    for path in kernel_sources(here):
        digest.update(path.name.encode() + b"\0" + path.read_bytes() + b"\0")
    home = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache")
    return home / "gimbal-numba" / digest.hexdigest()[:16]


def configure() -> None:
    """Point numba's cache at :func:`cache_dir`, unless the user set ``NUMBA_CACHE_DIR`` or
    numba was configured already (imported before these packages)."""
    if "NUMBA_CACHE_DIR" not in os.environ and "numba" not in sys.modules:
        os.environ["NUMBA_CACHE_DIR"] = str(cache_dir())
