"""The one ``/diagnostics`` builder of the controller and estimator nodes.

Each node reports one ``diagnostic_msgs/DiagnosticStatus`` named ``<node>: health`` whose
values are its counters (the core's, its input policy's, ``incompatible_qos``, the NIS
window's ``nis_*``), and whose level is the first of these that holds:

1. STALE: no output yet (``ready`` false: the filter is not aligned, no fix yet), with
   ``not_ready`` as the message;
2. WARN "an input is stale: command zeroed": a controller in free timing that zeroed this
   step's command;
3. WARN "running; inputs rejected or filter reset (see values)": one of the ``warn``
   counters is non-zero;
4. WARN "running; NIS <verdict> (see nis_*)": the NIS window says the filter is
   overconfident or conservative (:class:`gimbal_estimators.nis.NisWindow`);
5. OK "running".
"""
from __future__ import annotations

from typing import Any, Iterable, Mapping

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue

from .messages import time_msg

#: NIS verdicts that make a WARN.
NIS_WARNINGS = ("overconfident", "conservative")


def health_level(fields: Mapping[str, Any], *, ready: bool = True, not_ready: str = "not aligned",
                 stale: bool = False, warn: Iterable[str] = (), nis_verdict: str | None = None) -> tuple[int, str]:
    """(level, message) of a node's health (module docstring)."""
    if not ready:
        return DiagnosticStatus.STALE, not_ready
    if stale:
        return DiagnosticStatus.WARN, "an input is stale: command zeroed"
    if any(fields.get(k, 0) for k in warn):
        return DiagnosticStatus.WARN, "running; inputs rejected or filter reset (see values)"
    if nis_verdict in NIS_WARNINGS:
        return DiagnosticStatus.WARN, f"running; NIS {nis_verdict} (see nis_*)"
    return DiagnosticStatus.OK, "running"


def health_msg(t_ns: int, name: str, fields: Mapping[str, Any], **level: Any) -> DiagnosticArray:
    """The node ``name``'s /diagnostics stamped ``t_ns``: ``fields`` as key/values, the level
    of :func:`health_level` (keyword arguments ``level``)."""
    status = DiagnosticStatus(name=f"{name}: health", hardware_id=name)
    status.level, status.message = health_level(fields, **level)
    status.values = [KeyValue(key=k, value=str(v)) for k, v in fields.items()]
    arr = DiagnosticArray(status=[status])
    arr.header.stamp = time_msg(t_ns)
    return arr


class _NotAdvertised:
    """The /diagnostics of a node whose input policy has none: nothing goes out."""

    def publish(self, msg: Any) -> None:
        pass


def advertise_diagnostics(io: Any, timing: str, policy: Any) -> Any:
    """A node's /diagnostics publisher (through its :class:`~.node_io.NodeIo`), or, when its
    input policy has no diagnostics (``policy.diagnostics``), one that is never advertised
    and drops what it is given, so the node's body publishes the same way in every timing."""
    return io.advertise(DiagnosticArray, "/diagnostics", timing) if policy.diagnostics else _NotAdvertised()
