"""Compare the recorded data of two bags: every message payload and stamp, per topic.

Used to prove that a change (an optimisation, an executor swap) did not change what a run
records for the same seed. Two levels:

* bytes: per topic, the same number of messages with byte-identical CDR payloads and the
  same log and publish times, in order;
* values (what "the recorded data is identical" means): payloads that differ in bytes are
  decoded (rclpy's deserializer) and every field must be equal, floats to the bit. CDR padding
  and the trailing slack rmw_fastrtps adds to some messages are uninitialised memory, so
  two encodings of the same message may differ in bytes only;
* numeric (``rel_tol`` > 0): float fields may differ by ``|a − b| <= rel_tol·max(|a|,
  |b|, floor)``; ints, strings and stamps must still be equal. The largest deviation per
  topic is reported.

The bags are read with the ``mcap`` library directly (not our reader), so a bug in our
reader cannot hide a difference.
"""
from __future__ import annotations

import math
import struct
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Iterator

from mcap.exceptions import McapError
from mcap.reader import make_reader

from .reader import BagError, find_mcap
from .schemas import message_class


@dataclass
class TopicDiff:
    """Outcome for one topic: counts, first difference, numeric deviation."""

    topic: str
    count_a: int = 0
    count_b: int = 0
    byte_identical: bool = True
    stamps_equal: bool = True
    values_equal: bool = True
    first_difference: str = ""
    max_abs: float = 0.0       # largest |a − b| over the float fields of differing payloads
    max_rel: float = 0.0       # largest |a − b| / max(|a|, |b|, floor)
    within_tolerance: bool = True

    @property
    def comparable(self) -> bool:
        return self.count_a == self.count_b and self.stamps_equal


@dataclass
class BagDiff:
    topics: dict[str, TopicDiff] = field(default_factory=dict)

    @property
    def byte_identical(self) -> bool:
        return all(t.comparable and t.byte_identical for t in self.topics.values())

    @property
    def identical(self) -> bool:
        """Same messages with the same stamps and the same field values (to the bit)."""
        return all(t.comparable and t.values_equal for t in self.topics.values())

    @property
    def within_tolerance(self) -> bool:
        return all(t.comparable and t.within_tolerance for t in self.topics.values())

    def lines(self) -> list[str]:
        width = max((len(t) for t in self.topics), default=0)
        out = []
        for name, t in sorted(self.topics.items()):
            if t.count_a != t.count_b:
                verdict = f"COUNTS DIFFER ({t.count_a} vs {t.count_b})"
            elif not t.stamps_equal:
                verdict = f"STAMPS DIFFER: {t.first_difference}"
            elif t.byte_identical:
                verdict = f"identical ({t.count_a} messages)"
            elif t.values_equal:
                verdict = f"identical values ({t.count_a} messages; bytes differ in padding)"
            else:
                verdict = (f"{'within tolerance' if t.within_tolerance else 'DIFFERENT'}: max |Δ| {t.max_abs:.3g}, "
                           f"max rel {t.max_rel:.3g} (first at {t.first_difference})")
            out.append(f"{name:<{width}}  {verdict}")
        return out


def _raw(bag: Path) -> tuple[dict[str, list[tuple[int, int, bytes]]], dict[str, str]]:
    """Per topic, (log time, publish time, payload) in file order; and topic -> type name."""
    mcap_path, _ = find_mcap(Path(bag))
    out: dict[str, list[tuple[int, int, bytes]]] = {}
    types: dict[str, str] = {}
    with open(mcap_path, "rb") as f:
        try:
            for schema, channel, message in make_reader(f).iter_messages(log_time_order=False):
                out.setdefault(channel.topic, []).append((message.log_time, message.publish_time, message.data))
                if schema is not None:
                    types[channel.topic] = schema.name
        except (McapError, EOFError, KeyError, ValueError, struct.error) as exc:
            raise BagError(f"{mcap_path}: a damaged bag, not compared ({type(exc).__name__}: {exc}); "
                           f"`gimbal-bag recover` keeps its complete chunks") from None
    return out, types


def _decode(data: bytes, type_name: str) -> Any:
    """The message object rclpy's own deserializer makes of a payload."""
    from rclpy.serialization import deserialize_message

    return deserialize_message(data, message_class(type_name.replace("/msg/", "/")))


def _leaves(msg: Any, prefix: str = "") -> Iterator[tuple[str, Any]]:
    """(path, value) of every primitive field of a message object, arrays element-wise."""
    if isinstance(msg, (bool, int, float, str, bytes)):
        yield prefix, msg
    elif hasattr(msg, "get_fields_and_field_types"):
        for name in msg.get_fields_and_field_types():
            yield from _leaves(getattr(msg, name), f"{prefix}.{name}" if prefix else name)
    else:  # sequences: list, tuple, array.array, numpy arrays
        for i, v in enumerate(msg):
            yield from _leaves(v.item() if hasattr(v, "item") else v, f"{prefix}[{i}]")


def _same(a: Any, b: Any) -> bool:
    """Equal, floats to the bit (−0.0 is not 0.0; any NaN equals any NaN)."""
    if isinstance(a, float) and isinstance(b, float):
        if a != a or b != b:
            return a != a and b != b
        return a == b and math.copysign(1.0, a) == math.copysign(1.0, b)
    return a == b


def compare_bags(bag_a: Path, bag_b: Path, rel_tol: float = 0.0, abs_floor: float = 1e-12) -> BagDiff:
    """Compare every topic of two bags (module docstring). ``abs_floor`` keeps values near
    zero from inflating the relative deviation."""
    (a, types), (b, _) = _raw(bag_a), _raw(bag_b)
    diff = BagDiff()
    for topic in sorted(set(a) | set(b)):
        ma, mb = a.get(topic, []), b.get(topic, [])
        t = diff.topics[topic] = TopicDiff(topic, len(ma), len(mb))
        differing = []
        for i, (x, y) in enumerate(zip(ma, mb)):
            if x[0] != y[0] or x[1] != y[1]:
                if t.stamps_equal:
                    t.first_difference = f"message {i}: times {x[:2]} vs {y[:2]}"
                t.stamps_equal = False
            if x[2] != y[2]:
                if t.byte_identical and t.stamps_equal:
                    t.first_difference = f"message {i}"
                t.byte_identical = False
                differing.append(i)
        if differing:
            for i in differing:
                la = list(_leaves(_decode(ma[i][2], types[topic])))
                lb = list(_leaves(_decode(mb[i][2], types[topic])))
                if [p for p, _ in la] != [p for p, _ in lb]:
                    t.values_equal = t.within_tolerance = False
                    t.first_difference = f"message {i}: different fields or array lengths"
                    continue
                for (path, va), (_, vb) in zip(la, lb):
                    if _same(va, vb):
                        continue
                    if t.values_equal:
                        t.first_difference = f"message {i} {path}"
                    t.values_equal = False
                    if isinstance(va, float) and isinstance(vb, float):
                        dev = abs(va - vb)
                        rel = dev / max(abs(va), abs(vb), abs_floor)
                        t.max_abs = max(t.max_abs, dev)
                        t.max_rel = max(t.max_rel, rel)
                        if not rel <= rel_tol:  # also NaN against a number
                            t.within_tolerance = False
                    else:
                        t.within_tolerance = False
                        t.first_difference = f"message {i} {path}: {va!r} vs {vb!r}"
    return diff
