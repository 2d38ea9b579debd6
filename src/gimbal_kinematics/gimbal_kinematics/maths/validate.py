"""Parameter checks shared by the parameter dataclasses of every package (sensor models,
estimators, controllers).

Every failure raises ``ValueError`` naming the offending field, because a config typo
must point at the key to fix, not at a NaN ten thousand steps later. The scalar checks
return the value as a float, so a constructor can check and convert in one step.
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TypeVar

Number = float | int
T = TypeVar("T")


def of_type(name: str, value: T, cls: type, what: str | None = None) -> T:
    """``value`` if it is a ``cls``, else ``TypeError`` naming the argument (``what``: how
    the message names the type, default its class name)."""
    if not isinstance(value, cls):
        raise TypeError(f"{name} must be {what or cls.__name__}, got {type(value).__name__}")
    return value


def finite(name: str, value: object) -> float:
    """A finite real number (not a bool)."""
    if not isinstance(value, (int, float)) or isinstance(value, bool) or not math.isfinite(value):
        raise ValueError(f"{name} must be a finite number, got {value!r}")
    return float(value)


def nonneg(name: str, value: object) -> float:
    """``value >= 0`` (+inf admitted)."""
    if not isinstance(value, (int, float)) or isinstance(value, bool) or math.isnan(value) or value < 0.0:
        raise ValueError(f"{name} must be >= 0, got {value!r}")
    return float(value)


def nonneg_finite(name: str, value: object) -> float:
    nonneg(name, value)
    return finite(name, value)


def positive(name: str, value: object, allow_inf: bool = False) -> float:
    """``value > 0``; ``allow_inf`` admits +inf (e.g. a correlation time meaning 'constant')."""
    if not isinstance(value, (int, float)) or isinstance(value, bool) or math.isnan(value) or value <= 0.0:
        raise ValueError(f"{name} must be > 0, got {value!r}")
    if not allow_inf and math.isinf(value):
        raise ValueError(f"{name} must be finite, got {value!r}")
    return float(value)


def per_axis(name: str, value: Number | Sequence[Number], n: int | None = None) -> tuple[float, ...]:
    """Normalise a scalar-or-sequence field to a tuple of floats (length ``n`` when given).

    A scalar is kept as a 1-tuple when ``n`` is None; models broadcast 1-tuples over their
    axes, so one value can serve every axis.
    """
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        vals = (float(value),) if n is None else (float(value),) * n
    else:
        try:
            if isinstance(value, (str, bytes)):
                raise TypeError("a string is not a number")
            vals = tuple(float(v) for v in value)  # type: ignore[union-attr]
        except (TypeError, ValueError) as exc:
            raise ValueError(f"{name} must be a number or a sequence of numbers, got {value!r}") from exc
        if len(vals) == 0:
            raise ValueError(f"{name} must not be empty")
        if n is not None and len(vals) != n:
            raise ValueError(f"{name} must have {n} elements, got {len(vals)}")
    for v in vals:
        if not math.isfinite(v):
            raise ValueError(f"{name} must be finite, got {value!r}")
    return vals


def broadcast(name: str, vals: tuple[float, ...], n: int) -> list[float]:
    """Expand a 1-tuple to ``n`` axes, or check an ``n``-tuple; raises naming ``name``."""
    if len(vals) == 1:
        return [vals[0]] * n
    if len(vals) != n:
        raise ValueError(f"{name} has {len(vals)} elements but the sensor has {n} axes")
    return list(vals)
