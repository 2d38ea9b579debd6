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

Both bags are read as every command reads them (:mod:`.reader`): every file of a split bag
in ``metadata.yaml``'s order, every chunk CRC-checked. Each topic is then one of: the same,
different (with the first differing message and its log time), or unreadable on a side
(a damaged chunk held some of its messages, or the damage does not say which topics it
cost, or the topic's channel cannot be typed): an unreadable topic is never called the same.
Within a topic, messages are compared in log-time order (stable), so a split copy written
by another tool compares equal to its original.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Iterator

from .checks import damage_warnings
from .reader import BagContents, read_messages
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
    unreadable: str = ""       # why some of the topic cannot be read on a side ("" when it all can)

    @property
    def comparable(self) -> bool:
        return self.count_a == self.count_b and self.stamps_equal and not self.unreadable


@dataclass
class BagDiff:
    topics: dict[str, TopicDiff] = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)   # each damaged part of either bag, in words

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
            if t.unreadable:
                verdict = f"UNREADABLE: {t.unreadable}"
            elif t.count_a != t.count_b:
                verdict = f"COUNTS DIFFER ({t.count_a} vs {t.count_b}; first difference at {t.first_difference})"
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


Raw = dict[str, list[tuple[int, int, bytes]]]


def _raw(bag: Path) -> tuple[Raw, dict[str, str], BagContents]:
    """Per topic, (log time, publish time, payload) in log-time order; topic -> type; what was read."""
    messages, contents = read_messages(Path(bag))
    out: Raw = {}
    for raw in messages:
        out.setdefault(raw.topic, []).append((raw.log_time_ns, raw.publish_time_ns, raw.data))
    for series in out.values():
        series.sort(key=lambda x: x[0])
    return out, {name: t.type_name for name, t in contents.topics.items()}, contents


def decimated(bag_a: Path, bag_b: Path, topic: str) -> bool:
    """Whether ``bag_b`` holds a subset of ``bag_a``'s messages on ``topic`` (each with its
    stamps and bytes, in order): the same series recorded at a lower rate."""
    (a, _, _), (b, _, _) = _raw(bag_a), _raw(bag_b)
    kept = iter(a.get(topic, []))
    return bool(b.get(topic)) and all(any(m == x for x in kept) for m in b[topic])


def _unreadable(contents: BagContents, side: str) -> dict[str, str]:
    """topic -> why it cannot be compared on this side; "*" for every topic of the bag."""
    out = {topic: f"{side}: {why}" for topic, why in contents.unreadable.items()}
    for topic, lost in contents.lost.items():
        out[topic] = f"{side}: {lost.count} of its messages are in a damaged chunk"
    unknown = [d for d in contents.damage if not d.lost and not d.summary]
    if unknown:
        out["*"] = f"{side}: {unknown[0].line()}; which topics it cost is unknown"
    return out


def _first_difference(ma: list, mb: list) -> str:
    """Where two topics' series first differ (index and log time), for counts that differ."""
    for i, (x, y) in enumerate(zip(ma, mb)):
        if x != y:
            return f"message {i}, log time {x[0] * 1e-9:.9f} s"
    i = min(len(ma), len(mb))
    extra = (ma if len(ma) > i else mb)[i]
    return f"message {i}, log time {extra[0] * 1e-9:.9f} s (only in {'A' if len(ma) > i else 'B'})"


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
    (a, types, contents_a), (b, types_b, contents_b) = _raw(bag_a), _raw(bag_b)
    types = {**types_b, **types}
    bad = {**_unreadable(contents_b, f"B ({bag_b})"), **_unreadable(contents_a, f"A ({bag_a})")}
    diff = BagDiff(warnings=list(dict.fromkeys(
        [f"A: {w}" for w in damage_warnings(contents_a)] + [f"B: {w}" for w in damage_warnings(contents_b)])))
    for topic in sorted(set(a) | set(b) | set(contents_a.topics) | set(contents_b.topics) | set(bad) - {"*"}):
        ma, mb = a.get(topic, []), b.get(topic, [])
        t = diff.topics[topic] = TopicDiff(topic, len(ma), len(mb), unreadable=bad.get(topic) or bad.get("*", ""))
        if t.unreadable:
            continue
        if len(ma) != len(mb):
            t.first_difference = _first_difference(ma, mb)
        _compare_topic(t, ma, mb, types[topic], rel_tol, abs_floor)
    return diff


def _compare_topic(t: TopicDiff, ma: list, mb: list, type_name: str, rel_tol: float, abs_floor: float) -> None:
    """Fill ``t`` from the two series of one topic: stamps, bytes, then decoded values."""
    differing = []
    for i, (x, y) in enumerate(zip(ma, mb)):
        if x[0] != y[0] or x[1] != y[1]:
            if t.stamps_equal and len(ma) == len(mb):
                t.first_difference = f"message {i}: times {x[:2]} vs {y[:2]} (log time {x[0] * 1e-9:.9f} s)"
            t.stamps_equal = False
        if x[2] != y[2]:
            if t.byte_identical and t.stamps_equal and len(ma) == len(mb):
                t.first_difference = f"message {i}, log time {x[0] * 1e-9:.9f} s"
            t.byte_identical = False
            differing.append(i)
    _compare_values(t, ma, mb, differing, type_name, rel_tol, abs_floor)


def _compare_values(t: TopicDiff, ma: list, mb: list, differing: list[int], type_name: str, rel_tol: float,
                    abs_floor: float) -> None:
    """Decode the payloads that differ in bytes and compare their fields (floats to the bit,
    or within ``rel_tol``)."""
    for i in differing:
        la = list(_leaves(_decode(ma[i][2], type_name)))
        lb = list(_leaves(_decode(mb[i][2], type_name)))
        stamp = f"message {i} (log time {ma[i][0] * 1e-9:.9f} s)"
        if [p for p, _ in la] != [p for p, _ in lb]:
            t.values_equal = t.within_tolerance = False
            t.first_difference = f"{stamp}: different fields or array lengths"
            continue
        for (path, va), (_, vb) in zip(la, lb):
            if _same(va, vb):
                continue
            if t.values_equal:
                t.first_difference = f"{stamp} {path}"
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
                t.first_difference = f"{stamp} {path}: {va!r} vs {vb!r}"
