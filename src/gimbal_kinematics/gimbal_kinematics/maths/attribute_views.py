"""Read-only attributes that show numbers a class stores in another shape.

:func:`slot`: one element of a core's flat state array. The cores whose steps run in numba
kernels keep their state and counters in one float64 array that the kernels update in
place; a slot shows one element as a plain attribute, converted to ``int`` (a counter) or
``float``.

:func:`vector_of`: scalar fields of a sample (a NamedTuple of floats, as the kernels fill
it) as one numpy vector, e.g. the three components of a rate.
"""
from __future__ import annotations

from operator import attrgetter
from typing import Any, Callable

import numpy as np


def slot(index: int, kind: Callable[[Any], Any] = float, doc: str | None = None, array: str = "state") -> property:
    """A read-only property: ``kind(self.<array>[index])``."""
    return property(lambda self: kind(getattr(self, array)[index]), doc=doc)


def vector_of(*names: str, doc: str | None = None) -> property:
    """A read-only property: ``np.array([self.<name>, ...])`` of the fields ``names``, in order."""
    get = attrgetter(*names)
    return property(lambda self: np.array(get(self)), doc=doc)
