"""Attributes that read one element of a core's flat state array.

The cores whose steps run in numba kernels keep their state and counters in one float64
array that the kernels update in place; :func:`slot` shows one element of it as a plain
read-only attribute of the Python object, converted to ``int`` (a counter) or ``float``.
"""
from __future__ import annotations

from typing import Any, Callable


def slot(index: int, kind: Callable[[Any], Any] = float, doc: str | None = None, array: str = "state") -> property:
    """A read-only property: ``kind(self.<array>[index])``."""
    return property(lambda self: kind(getattr(self, array)[index]), doc=doc)
