"""What a bag's reading found, in words: damage, losses per topic, and metadata that lies.

Every command that reads a bag (``gimbal-bag info|play|recover``, ``gimbal-report``,
``gimbal-bench compare``) says the same things the same way: one warning per damaged part
(:func:`damage_warnings`), and, where a person decides what to do next, per topic what was
kept and what was lost with its time range (:func:`topic_lines`). ``metadata.yaml`` is a
claim about the files; :func:`metadata_mismatches` checks each claim against what was read.
"""
from __future__ import annotations

from .reader import BagContents


def _span(first_ns: int, last_ns: int, origin_ns: int) -> str:
    return f"{(first_ns - origin_ns) * 1e-9:.3f}..{(last_ns - origin_ns) * 1e-9:.3f} s"


def origin_ns(contents: BagContents) -> int:
    """The earliest log time read or lost: the zero of the spans :func:`topic_lines` prints."""
    starts = [s[0] for s in contents.spans.values()] + [lost.first_ns for lost in contents.lost.values()]
    starts += [d.start_ns for d in contents.damage if d.start_ns is not None]
    return min(starts, default=0)


def damage_warnings(contents: BagContents) -> list[str]:
    """One line per damaged part (skipped, the rest read) and per topic that cannot be read."""
    lines = [f"warning: {d.line()}: skipped, reading on" for d in contents.damage]
    lines += [f"warning: topic {topic} cannot be read: {why}" for topic, why in sorted(contents.unreadable.items())]
    return lines


def topic_lines(contents: BagContents) -> list[str]:
    """Per topic: messages kept and lost, each with its time range (s after the bag's first
    stamp); the damage whose losses the file does not attribute, with its time range."""
    zero = origin_ns(contents)
    names = sorted(set(contents.topics) | set(contents.lost) | set(contents.unreadable))
    width = max((len(n) for n in names), default=0)
    lines = []
    for name in names:
        record, lost, span = contents.topics.get(name), contents.lost.get(name), contents.spans.get(name)
        kept = f"kept {record.count if record else 0:>8}" + (f" ({_span(*span, zero)})" if span else "")
        if name in contents.unreadable:
            kept += f"  UNREADABLE: {contents.refused.get(name, 0)} messages skipped (see above)"
        gone = f"  lost {lost.count} ({_span(lost.first_ns, lost.last_ns, zero)})" if lost else ""
        lines.append(f"  {name:<{width}}  {kept}{gone}")
    for d in contents.damage:
        if not d.lost and not d.summary:
            where = "" if d.start_ns is None else f" in {_span(d.start_ns, d.end_ns, zero)}"
            lines.append(f"  (unknown topics)  lost{where}: {d.line()}; the file does not say which messages")
    return lines


def _claimed_topics(metadata: dict) -> dict[str, tuple[str, int]]:
    out = {}
    for entry in metadata.get("topics_with_message_count") or []:
        try:
            meta = entry["topic_metadata"]
            out[meta["name"]] = (meta.get("type", "?"), int(entry.get("message_count", 0)))
        except (KeyError, TypeError, ValueError):
            continue
    return out


def _nanoseconds(metadata: dict, key: str, inner: str) -> int | None:
    try:
        return int(metadata[key][inner])
    except (KeyError, TypeError, ValueError):
        return None


def metadata_mismatches(metadata: dict | None, contents: BagContents) -> list[str]:
    """Each claim of ``metadata.yaml`` (rosbag2_bagfile_information) that the files contradict:
    total and per-topic message counts, topics, types and time range."""
    if not metadata:
        return []
    out = []
    claimed = _claimed_topics(metadata)
    total = metadata.get("message_count")
    if isinstance(total, int) and total != contents.message_count and not contents.unreadable:
        out.append(f"message_count: metadata says {total}, the files hold {contents.message_count}")
    for name, (type_name, count) in sorted(claimed.items()):
        record = contents.topics.get(name)
        if name in contents.unreadable:
            continue
        if record is None:
            out.append(f"topic {name}: metadata lists it ({count} messages of {type_name}), the files hold none")
            continue
        if type_name != record.type_name:
            out.append(f"topic {name}: metadata says type {type_name}, the files say {record.type_name}")
        if count != record.count:
            out.append(f"topic {name}: metadata says {count} messages, the files hold {record.count}")
    for name in sorted(set(contents.topics) - set(claimed)):
        out.append(f"topic {name}: the files hold {contents.topics[name].count} messages of "
                   f"{contents.topics[name].type_name}, metadata does not list it")
    start = _nanoseconds(metadata, "starting_time", "nanoseconds_since_epoch")
    duration = _nanoseconds(metadata, "duration", "nanoseconds")
    if contents.start_ns is not None and start is not None and duration is not None:
        # rosbag2 writers differ by one nanosecond on whether the last stamp is inside the duration
        if start != contents.start_ns or abs(start + duration - contents.end_ns) > 1:
            out.append(f"time range: metadata says {start * 1e-9:.9f} s + {duration * 1e-9:.9f} s, the files span "
                       f"{contents.start_ns * 1e-9:.9f} s + {(contents.end_ns - contents.start_ns) * 1e-9:.9f} s")
    return out
