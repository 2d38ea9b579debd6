"""Block-buffered standard normal draws from a caller-owned numpy Generator.

Calling ``Generator.standard_normal()`` once per scalar costs about a microsecond; the
lockstep loop needs a handful of normals per sensor per step at ~20 kHz, so the models
draw blocks and index into a Python list. The sequence is still fully determined by the
Generator's seed.
"""
from __future__ import annotations

import numpy as np

from gimbal_kinematics.maths.validate import of_type

_BLOCK = 4096


class NormalStream:
    """Standard normal variates in blocks from ``rng`` (never the global numpy RNG)."""

    __slots__ = ("_rng", "_buf", "_j")

    def __init__(self, rng: np.random.Generator) -> None:
        of_type("rng", rng, np.random.Generator, "a numpy.random.Generator")
        self._rng = rng
        self._buf: list[float] = []
        self._j = 0

    def take(self, k: int) -> tuple[list[float], int]:
        """Reserve ``k`` normals; returns ``(buffer, start)``: use ``buffer[start:start+k]``."""
        j = self._j
        if j + k > len(self._buf):
            self._buf = self._rng.standard_normal(max(_BLOCK, k)).tolist()
            j = 0
        self._j = j + k
        return self._buf, j

    def one(self) -> float:
        buf, j = self.take(1)
        return buf[j]

    def take_block(self, k: int, m: int) -> np.ndarray:
        """The normals of ``m`` successive :meth:`take` (``k``) calls, (m, k), the stream left
        where those calls leave it (a compiled loop's noise, drawn in blocks)."""
        out = np.empty(m * k)
        filled = 0
        while filled < m * k:
            j, buf = self._j, self._buf
            n = min((len(buf) - j) // k * k, m * k - filled)
            if n <= 0:
                self._buf = self._rng.standard_normal(max(_BLOCK, k)).tolist()
                self._j = 0
                continue
            out[filled:filled + n] = buf[j:j + n]
            self._j = j + n
            filled += n
        return out.reshape(m, k)
