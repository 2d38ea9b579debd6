"""The counters every message-driven core here keeps for /diagnostics, whatever else it
counts: samples rejected as non-finite, and its resets with their reasons.

A core's own counters dataclass adds its fields to :class:`CoreCounters`; its ``reset``
calls :meth:`CoreCounters.count_reset` before it restarts.
"""
from __future__ import annotations

from dataclasses import dataclass, field


@dataclass
class CoreCounters:
    """Non-finite samples rejected, resets and their reasons (cumulative: a reset does not
    clear them)."""

    rejected_nonfinite: int = 0
    resets: int = 0
    reset_reasons: list[str] = field(default_factory=list)

    def count_reset(self, reason: str) -> None:
        """Count a reset and record ``reason``."""
        self.resets += 1
        self.reset_reasons.append(str(reason))
