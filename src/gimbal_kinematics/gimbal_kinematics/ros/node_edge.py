"""The one shape of a controller or estimator node: the plumbing every node shares.

A node file holds its topics, its core and its serialisation; everything else it asks of
:class:`NodeEdge`, made once in its constructor:

* the inputs: :meth:`NodeEdge.subscribe` takes a topic serialized and decodes it the one
  way (:func:`gimbal_kinematics.ros.views.decoder`: a view with the message's own field
  names, the message object for a type without a view), with the timing's QoS
  (:class:`~.node_io.NodeIo`); bytes that decode to nothing are counted (``malformed``)
  and warned of, never passed on;
* the input checks: a node's ``_validate`` returns what its core takes, or
  :meth:`NodeEdge.reject` (the input-check counter, counted and warned of) when the input
  cannot be used;
* the warnings: :meth:`NodeEdge.warn`, at most one a second per call site (rclpy's throttle);
* the outputs: :meth:`NodeEdge.advertise` keeps each publisher by its topic, and
  :meth:`NodeEdge.publish` sends the (topic, type, bytes) a node's pure serialisation
  (its package's ``wire`` module, shared with the engine) returns;
* the diagnostics throttle: :meth:`NodeEdge.diagnostics` publishes ``/diagnostics`` on an
  output stamp when it is due (once per ``diagnostics_period_s`` of stamp time, and at once
  after :meth:`NodeEdge.diagnostics_now`, e.g. after a filter reset).

``docs/architecture.md`` (the node shape) names the node file to copy.
"""
from __future__ import annotations

from typing import Any, Callable

from rclpy.node import Node
from rclpy.subscription import Subscription

from diagnostic_msgs.msg import DiagnosticArray

from ..params.table import steps_per_sample
from ..timing.input_policy import grouped_policy
from .diagnostics import advertise_diagnostics, health_msg
from .node_io import NodeIo
from .views import decoder
from .wire import clock_cdr

#: (topic, message type name, serialized bytes): what a node's serialisation returns
Messages = list[tuple[str, str, bytes]]
#: The edge's own counters that make /diagnostics a WARN: inputs of the wrong QoS or type.
EDGE_WARNINGS = ("incompatible_qos", "wrong_type")


def input_warnings(*streams: str) -> tuple[str, ...]:
    """The counters that make /diagnostics a WARN for inputs of ``streams``: the input
    policy's repeated and late stamps of each, then the edge's own (:data:`EDGE_WARNINGS`)."""
    return (*(f"{s}_{kind}" for s in streams for kind in ("duplicates", "out_of_order")), *EDGE_WARNINGS)


def grouped_policy_of(node: Node, values: dict[str, Any], kinds: tuple[str, ...], paced: str,
                      on_restart: Callable[[str], None], ahead: tuple[str, ...] = ()) -> Any:
    """The grouped input policy (:func:`gimbal_kinematics.timing.input_policy.grouped_policy`)
    of a node whose inputs ``kinds`` are sampled at ``<kind>_rate_hz``, from its timing
    parameters (``timing``, ``sim_rate_hz``, ``progress_every_steps``, ``clock_jump_s``,
    ``max_sync_wait_s``); ``~/progress`` on ``paced``; a clock jump back calls ``on_restart``.
    ``ahead``: inputs stamped one sample ahead of the step that makes them (in lockstep the
    first sample step has none: their grid starts a sample later)."""
    every = {kind: steps_per_sample(values, f"{kind}_rate_hz") for kind in kinds}
    return grouped_policy(values["timing"], every, rate_hz=values["sim_rate_hz"],
                          progress_every=values["progress_every_steps"], clock_jump_s=values["clock_jump_s"],
                          max_wait_ns=int(round(values["max_sync_wait_s"] * 1e9)), paced=paced,
                          logger=node.get_logger(), on_restart=on_restart,
                          first={kind: every[kind] for kind in ahead})


def publish_progress(pub: Any, stamp_ns: int | None) -> None:
    """Report ``stamp_ns`` (None: nothing) on the ``~/progress`` publisher ``pub``, a
    ``rosgraph_msgs/Clock``: what every node's pacing reader waits for."""
    if stamp_ns is not None:
        pub.publish(clock_cdr(stamp_ns))


class NodeEdge:
    """The shared plumbing of one node (module docstring); ``values`` its parameters
    (``timing``, and ``diagnostics_period_s`` when it publishes /diagnostics); ``counters``
    the input-check counters /diagnostics carries from the start; ``malformed`` the one that
    counts inputs that do not decode."""

    def __init__(self, node: Node, values: dict[str, Any], counters: tuple[str, ...] = (),
                 malformed: str = "malformed") -> None:
        self.node = node
        self.timing = values["timing"]
        self.io = NodeIo(node)
        self.diag_period_ns = int(round(values.get("diagnostics_period_s", 0.0) * 1e9))
        self._next_diag_ns = 0
        #: the input-check counters, by name (:meth:`reject`), for /diagnostics
        self.counts: dict[str, int] = dict.fromkeys(counters, 0)
        self.warnings = 0
        self.malformed = malformed
        self.pubs: dict[str, Any] = {}
        self._inputs: dict[str, tuple[Callable[[bytes], Any], Callable[[Any], None]]] = {}

    # ----------------------------------------------------------------- inputs
    def subscribe(self, msg_type: Any, topic: str, on_input: Callable[[Any], None]) -> Subscription:
        """A subscription to ``topic`` whose messages reach ``on_input`` decoded (module docstring)."""
        self._inputs[topic] = (decoder(msg_type), on_input)
        return self.io.subscribe(msg_type, topic, lambda data: self.take(topic, data), self.timing, raw=True)

    def subscribe_all(self, inputs: Any, on_input: Callable[[str, Any], None]) -> list[Subscription]:
        """:meth:`subscribe` to each (kind, type, topic) of ``inputs``, ``on_input(kind, msg)``;
        :meth:`take` knows each input by its kind too."""
        subs = [self.subscribe(msg_type, topic, lambda msg, k=kind: on_input(k, msg))
                for kind, msg_type, topic in inputs]
        self._inputs.update((kind, self._inputs[topic]) for kind, _, topic in inputs)
        return subs

    def take(self, name: str, data: bytes) -> None:
        """Serialized bytes of an input (its topic, or its kind for :meth:`subscribe_all`'s),
        decoded and passed on, or counted as ``malformed``: what a subscription does."""
        decode, on_input = self._inputs[name]
        try:
            msg = decode(data)
        except Exception as exc:  # noqa: BLE001  (rclpy's deserialiser raises several kinds)
            self.reject(self.malformed, f"malformed message on {name} ignored: {exc}")
            return
        on_input(msg)

    # ----------------------------------------------------------------- outputs
    def advertise(self, msg_type: Any, topic: str, profile: Any = None) -> Any:
        """A publisher with the timing's QoS, or ``profile`` (:meth:`.node_io.NodeIo.advertise`),
        kept by its topic for :meth:`publish`."""
        pub = self.pubs[topic] = self.io.advertise(msg_type, topic, self.timing, profile)
        return pub

    def advertise_all(self, outputs: Any) -> None:
        """:meth:`advertise` each (type, topic) of ``outputs``."""
        for msg_type, topic in outputs:
            self.advertise(msg_type, topic)

    def progress(self, stamp_ns: int | None) -> None:
        """Report ``stamp_ns`` (the input policy's ``progress``; None: nothing) on ``~/progress``."""
        publish_progress(self.pubs["~/progress"], stamp_ns)

    def publish(self, messages: Messages) -> None:
        """Publish each (topic, type, bytes) on the publisher advertised for its topic."""
        for topic, _, data in messages:
            self.pubs[topic].publish(data)

    def reject(self, counter: str, text: str) -> None:
        """Count an input that cannot be used under ``counter`` and warn of it; returns None,
        what a ``_validate`` returns for it."""
        n = self.counts[counter] = self.counts.get(counter, 0) + 1
        self.warn(f"{text} ({n} {counter})")

    # ----------------------------------------------------------------- warnings
    def warn(self, text: str) -> None:
        """A warning, at most one a second (rclpy's throttle), counted in ``warnings``."""
        self.warnings += 1
        self.node.get_logger().warning(text, throttle_duration_sec=1.0)

    # ----------------------------------------------------------------- diagnostics
    def advertise_diagnostics(self, policy: Any = None) -> Any:
        """The /diagnostics publisher; not advertised when the input ``policy`` has none
        (:func:`.diagnostics.advertise_diagnostics`)."""
        if policy is None:
            return self.advertise(DiagnosticArray, "/diagnostics")
        pub = self.pubs["/diagnostics"] = advertise_diagnostics(self.io, self.timing, policy)
        return pub

    def diagnostics(self, t_ns: int, health: Callable[[], Any]) -> None:
        """Publish ``health()`` on /diagnostics when due at the output stamp ``t_ns``."""
        if self.diagnostics_due(t_ns):
            self.pubs["/diagnostics"].publish(health())

    def health(self, t_ns: int, policy: Any, core: dict[str, Any], nis: Any = None, node: dict[str, Any] | None = None,
               **level: Any) -> DiagnosticArray:
        """The node's /diagnostics at ``t_ns``: the fields its input ``policy`` reports from the
        ``core``'s counters, the ``node``'s own and the edge's (:meth:`counters`), and the ``nis``
        window's (:func:`.diagnostics.health_msg`; ``level``: its keyword arguments)."""
        fields, verdict = policy.report(core, {**(node or {}), **self.counters()}, {} if nis is None else nis.as_dict(),
                                        None if nis is None else nis.verdict().verdict)
        return health_msg(t_ns, self.node.get_name(), fields, nis_verdict=verdict, **level)

    def diagnostics_due(self, t_ns: int) -> bool:
        """Whether /diagnostics goes out with the output stamped ``t_ns`` (module docstring)."""
        if t_ns < self._next_diag_ns:
            return False
        self._next_diag_ns = t_ns + self.diag_period_ns
        return True

    def diagnostics_now(self) -> None:
        """Let the next output carry /diagnostics (after a reset, say)."""
        self._next_diag_ns = 0

    def counters(self) -> dict[str, int]:
        """The edge's counters for /diagnostics: the input checks', then the QoS plumbing's."""
        return {**self.counts, **self.io.counters()}
