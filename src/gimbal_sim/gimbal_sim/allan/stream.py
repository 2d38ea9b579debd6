"""Samples of one sensor_msgs/Imu field streamed out of any rosbag2 bag, and their time base.

:func:`read_imu_field` keeps only flat arrays (``array('q')`` stamps, ``array('d')`` values):
nothing per message survives its decoding, so memory grows by 32 bytes a message whatever
the bag's size. Each message is decoded by the struct CDR reader (``cdr.read_header_doubles``,
what ``messages.imu_from_cdr`` uses: about a microsecond); one it cannot read (e.g. big-endian
CDR) goes through rosbags' deserializer.

Covariance conventions read from each message (REP 145 and SPEC §2):

* ``covariance[0] == -1``: the field is not provided; asking for it is refused;
* a diagonal variance ``>= UNMEASURED_VARIANCE`` (in the field's unit squared): that axis is
  not measured (e.g. a two-axis gyro's roll), and is skipped;
* all zeros: "unknown", the data are used (what most drivers publish).

:func:`sampling` derives the sample interval from the header stamps (the log times when
every header stamp is zero) and finds where the sampling breaks: a gap (more than 1.5
intervals), a sample too early (less than 0.5), or a stamp that does not advance. The record
is then split into evenly sampled segments, or refused; nothing is interpolated.
"""
from __future__ import annotations

import math
from array import array
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..bag.any_reader import AnyBagError, iter_raw, open_bag, require_topic
from gimbal_kinematics.ros.cdr import CdrError, read_header_doubles

IMU_TYPES = ("sensor_msgs/msg/Imu",)
#: Field -> (index of its first value, index of its covariance[0]) among an Imu's 37 doubles.
FIELDS = {"angular_velocity": (13, 16), "linear_acceleration": (25, 28)}
AXES = ("x", "y", "z")
#: A diagonal variance at or above this [field unit²] marks an unmeasured axis: (1000 rad/s)²
#: or (1000 m/s²)², far beyond any sensor's noise, the "very large variance" of SPEC §2.
UNMEASURED_VARIANCE = 1e6
#: A step between stamps outside [EARLY, GAP] sample intervals breaks the even sampling.
GAP = 1.5
EARLY = 0.5


@dataclass
class ImuField:
    """One field of an Imu topic: ``stamps_ns`` (n,) int64, ``values`` (n, 3) [SI].

    ``absent``: messages whose covariance[0] is -1; ``unmeasured`` (3,): messages whose
    diagonal variance of that axis is >= :data:`UNMEASURED_VARIANCE`; ``stamp_source``:
    "header" or "log" (every header stamp was zero).
    """

    topic: str
    field: str
    msgtype: str
    stamps_ns: np.ndarray
    values: np.ndarray
    absent: int
    unmeasured: np.ndarray
    stamp_source: str

    @property
    def count(self) -> int:
        return len(self.stamps_ns)


def _decode_fallback(reader, data: bytes, msgtype: str, field_name: str) -> tuple[int, tuple[float, ...]]:
    """(stamp [ns], the field's 3 values + 9 covariances) through rosbags' deserializer."""
    try:
        msg = reader.deserialize(data, msgtype)
    except Exception as exc:  # rosbags raises several types for bytes that are not a message
        raise AnyBagError(f"a message of type {msgtype} cannot be decoded: {exc}") from exc
    v = getattr(msg, field_name)
    cov = getattr(msg, f"{field_name}_covariance")
    return msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec, (v.x, v.y, v.z, *[float(c) for c in cov])


def read_imu_field(path: str | Path, topic: str, field_name: str, progress: bool | None = None) -> ImuField:
    """Stream ``topic``'s ``field_name`` (angular_velocity or linear_acceleration) out of the bag.

    ``progress``: a tqdm bar over the messages (None: only on a terminal). Raises
    :class:`AnyBagError` for a bag, topic or type it cannot use.
    """
    if field_name not in FIELDS:
        raise AnyBagError(f"field {field_name!r} is not one of {list(FIELDS)}")
    from tqdm import tqdm

    first, cov0 = FIELDS[field_name]
    stamps, logs, values = array("q"), array("q"), array("d")
    absent = 0
    unmeasured = [0, 0, 0]
    big = UNMEASURED_VARIANCE
    with open_bag(path) as reader:
        summary = require_topic(reader, topic, IMU_TYPES)
        bar = tqdm(total=summary.count, unit="msg", desc=f"reading {topic}", disable=None if progress is None
                   else not progress, mininterval=0.5, unit_scale=True)
        for log_ns, data in iter_raw(reader, topic):
            try:
                stamp, _, v = read_header_doubles(data, 37)  # what messages.imu_from_cdr reads
                v = v[first:first + 3] + v[cov0:cov0 + 9]
            except CdrError:
                stamp, v = _decode_fallback(reader, data, summary.msgtype, field_name)
            stamps.append(stamp)
            if logs is not None:  # needed only while every header stamp is zero (an unstamped driver)
                if stamp:
                    logs = None
                else:
                    logs.append(log_ns)
            values.extend(v[:3])
            if v[3] == -1.0:
                absent += 1
            if v[3] >= big:
                unmeasured[0] += 1
            if v[7] >= big:
                unmeasured[1] += 1
            if v[11] >= big:
                unmeasured[2] += 1
            bar.update()
        bar.close()
    # numpy views of the arrays' buffers: no copy of the samples
    st = np.frombuffer(stamps, dtype=np.int64) if len(stamps) else np.zeros(0, dtype=np.int64)
    source = "header"
    if logs is not None and len(logs):
        st, source = np.frombuffer(logs, dtype=np.int64), "log"
    return ImuField(topic, field_name, summary.msgtype, st,
                    np.frombuffer(values, dtype=float).reshape(-1, 3) if len(values) else np.zeros((0, 3)),
                    absent, np.array(unmeasured), source)


@dataclass
class Sampling:
    """The time base of a record: nominal interval ``tau0`` [s] (median step), the segments
    ``(start, stop)`` index pairs of evenly sampled runs, and what broke it."""

    tau0: float
    segments: list[tuple[int, int]]
    gaps: int = 0
    early: int = 0
    stalled: int = 0
    backwards: int = 0
    longest_gap_s: float = 0.0
    jitter_rms: float = 0.0  # RMS of (step - tau0) / tau0 inside the segments
    breaks_at_s: list[float] = field(default_factory=list)

    @property
    def regular(self) -> bool:
        return len(self.segments) == 1

    def describe(self) -> str:
        parts = []
        if self.gaps:
            parts.append(f"{self.gaps} gap(s) (longest {self.longest_gap_s:.6g} s)")
        if self.early:
            parts.append(f"{self.early} sample(s) less than {EARLY} intervals after the previous one")
        if self.stalled:
            parts.append(f"{self.stalled} repeated stamp(s)")
        if self.backwards:
            parts.append(f"{self.backwards} stamp(s) going backwards")
        return ", ".join(parts) or "evenly sampled"


def sampling(stamps_ns: np.ndarray) -> Sampling:
    """Sample interval and segments of ``stamps_ns`` (n,) (module docstring)."""
    if len(stamps_ns) < 3:
        raise ValueError(f"{len(stamps_ns)} samples: too few to find a sample interval")
    d = np.diff(stamps_ns).astype(float) * 1e-9
    forward = d[d > 0.0]
    if not len(forward):
        raise ValueError("the stamps never advance")
    tau0 = float(np.median(forward))
    ratio = d / tau0
    breaks = np.flatnonzero((ratio > GAP) | (ratio < EARLY))
    edges = [0, *(breaks + 1).tolist(), len(stamps_ns)]
    segments = [(a, b) for a, b in zip(edges[:-1], edges[1:]) if b > a]
    inside = np.ones(len(d), dtype=bool)
    inside[breaks] = False
    jitter = float(np.sqrt(np.mean((ratio[inside] - 1.0) ** 2))) if inside.any() else 0.0
    gap = ratio > GAP
    t0 = stamps_ns[0]
    return Sampling(tau0=tau0, segments=segments, gaps=int(gap.sum()),
                    early=int(((ratio < EARLY) & (d > 0.0)).sum()), stalled=int((d == 0.0).sum()),
                    backwards=int((d < 0.0).sum()), longest_gap_s=float(d[gap].max()) if gap.any() else 0.0,
                    jitter_rms=jitter if math.isfinite(jitter) else 0.0,
                    breaks_at_s=[float((stamps_ns[i + 1] - t0) * 1e-9) for i in breaks[:20]])
