"""Damaged and lying bags, and the compare of two bags: each fault a data row.

The bags are written here by the ``mcap`` library's own writer (several small chunks, zstd
or uncompressed, CDR encoded by ``mcap_ros2``), then damaged the way a full disk, a power
cut or a bad sector damages them. What each command must keep is computed from the
undamaged file by the ``mcap`` library (its summary's chunk index, each chunk's records by
its own ``breakup_chunk``): every chunk that the damage does not touch.

Every row asserts the exit code, that no traceback was printed, that a message names the
problem, the messages kept against that count, and that no empty output folder is left.
"""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
from dataclasses import dataclass
from io import BytesIO
from pathlib import Path
from typing import Callable

import pytest
import yaml
from mcap.data_stream import ReadDataStream
from mcap.reader import make_reader
from mcap.records import Chunk, Footer, Message
from mcap.stream_reader import breakup_chunk
from mcap.writer import CompressionType, Writer
from mcap_ros2._dynamic import serialize_dynamic

from gimbal_sim.bag.cli import main as bag_main
from gimbal_sim.reports.dispatch import main as report_main
from gimbal_sim.tools.bench import main as bench_main

VENV_BIN = Path(sys.executable).parent
T0 = 1_700_000_000_000_000_000
TYPE = "geometry_msgs/msg/Vector3Stamped"
SCHEMA = """std_msgs/Header header
geometry_msgs/Vector3 vector
================================================================================
MSG: std_msgs/Header
builtin_interfaces/Time stamp
string frame_id
================================================================================
MSG: builtin_interfaces/Time
int32 sec
uint32 nanosec
================================================================================
MSG: geometry_msgs/Vector3
float64 x
float64 y
float64 z
"""
#: topic -> rate [Hz]; 2 s of them in ~3 kB chunks: a dozen chunks
TOPICS = {"/gimbal/rate": 100, "/gimbal/angle": 50, "/gimbal/cmd": 10}
ENCODE = serialize_dynamic(TYPE, SCHEMA)[TYPE]


def _message(t_ns: int, value: float) -> bytes:
    sec, nsec = divmod(t_ns, 1_000_000_000)
    return ENCODE({"header": {"stamp": {"sec": sec, "nanosec": nsec}, "frame_id": "gimbal"},
                   "vector": {"x": value, "y": -value, "z": 0.5 * value}})


def stamped(duration_s: float = 2.0, offset: float = 0.0) -> list[tuple[str, int, float]]:
    """(topic, log time, value) of every message, in log-time order."""
    out = []
    for topic, rate in TOPICS.items():
        out += [(topic, T0 + round(i * 1e9 / rate), offset + i * 0.01 + len(topic))
                for i in range(int(duration_s * rate))]
    return sorted(out, key=lambda m: (m[1], m[0]))


def write_mcap(path: Path, messages, compression: str = "zstd", schemaless: set[str] = frozenset(),
               chunk_size: int = 3000) -> None:
    with open(path, "wb") as f:
        w = Writer(f, chunk_size=chunk_size,
                   compression=CompressionType.ZSTD if compression == "zstd" else CompressionType.NONE)
        w.start(profile="ros2", library="test_faults")
        schema_id = w.register_schema(TYPE, "ros2msg", SCHEMA.encode())
        channels = {t: w.register_channel(t, "cdr", 0 if t in schemaless else schema_id,
                                          {"offered_qos_profiles": ""}) for t in TOPICS}
        for seq, (topic, t_ns, value) in enumerate(messages):
            w.add_message(channels[topic], t_ns, _message(t_ns, value), t_ns, seq)
        w.finish()


def write_metadata(bag: Path, files: list[str], messages, lie: Callable[[dict], None] | None = None) -> None:
    counts = {t: sum(1 for m in messages if m[0] == t) for t in TOPICS}
    stamps = [m[1] for m in messages]
    info = {"version": 9, "storage_identifier": "mcap", "relative_file_paths": files,
            "starting_time": {"nanoseconds_since_epoch": min(stamps)},
            "duration": {"nanoseconds": max(stamps) - min(stamps)}, "message_count": len(messages),
            "topics_with_message_count": [{"topic_metadata": {"name": t, "type": TYPE, "serialization_format": "cdr",
                                                              "offered_qos_profiles": ""}, "message_count": n}
                                          for t, n in counts.items()]}
    if lie:
        lie(info)
    (bag / "metadata.yaml").write_text(yaml.safe_dump({"rosbag2_bagfile_information": info}))


def make_bag(root: Path, name: str, compression: str = "zstd", messages=None, **kw) -> Path:
    bag = root / name
    bag.mkdir()
    messages = messages if messages is not None else stamped()
    write_mcap(bag / f"{name}_0.mcap", messages, compression, **kw)
    write_metadata(bag, [f"{name}_0.mcap"], messages)
    return bag


@dataclass
class ChunkInfo:
    offset: int          # the Chunk record's first byte
    length: int          # the Chunk record's length, opcode and length fields included
    index_end: int       # where its MessageIndex records end
    messages: int        # Message records in it (the mcap library's breakup_chunk)


def chunks_of(path: Path) -> list[ChunkInfo]:
    """The chunks of an undamaged file, by the mcap library."""
    data = path.read_bytes()
    with open(path, "rb") as f:
        indexes = make_reader(f).get_summary().chunk_indexes
    out = []
    for ci in indexes:
        chunk = Chunk.read(ReadDataStream(BytesIO(data[ci.chunk_start_offset + 9:])))
        n = sum(isinstance(r, Message) for r in breakup_chunk(chunk, validate_crc=True))
        out.append(ChunkInfo(ci.chunk_start_offset, ci.chunk_length,
                             ci.chunk_start_offset + ci.chunk_length + ci.message_index_length, n))
    return out


def mcap_count(path: Path) -> int:
    """Messages the mcap library reads from every .mcap of a bag folder (or file)."""
    files = sorted(path.glob("*.mcap")) if path.is_dir() else [path]
    total = 0
    for file in files:
        with open(file, "rb") as f:
            total += sum(1 for _ in make_reader(f).iter_messages())
    return total


# --- the damage ---------------------------------------------------------------------------------

def _flip(path: Path, at: int) -> None:
    data = bytearray(path.read_bytes())
    data[at] ^= 0x5A
    path.write_bytes(bytes(data))


def _cut(path: Path, at: int) -> None:
    path.write_bytes(path.read_bytes()[:at])


def damage_cut_in_chunk(bag: Path) -> tuple[int, str]:
    file = next(bag.glob("*.mcap"))
    chunks = chunks_of(file)
    k = len(chunks) // 2
    _cut(file, chunks[k].offset + chunks[k].length // 2)
    (bag / "metadata.yaml").unlink()   # a cut recording never wrote it
    return sum(c.messages for c in chunks[:k]), "ends inside a Chunk record"


def damage_cut_in_index(bag: Path) -> tuple[int, str]:
    file = next(bag.glob("*.mcap"))
    chunks = chunks_of(file)
    k = len(chunks) // 2
    _cut(file, chunks[k].offset + chunks[k].length + 12)   # inside its first MessageIndex record
    (bag / "metadata.yaml").unlink()
    return sum(c.messages for c in chunks[:k + 1]), "ends inside a MessageIndex record"


def _flip_chunk(k: int) -> Callable[[Path], tuple[int, str]]:
    def damage(bag: Path) -> tuple[int, str]:
        file = next(bag.glob("*.mcap"))
        chunks = chunks_of(file)
        kk = k % len(chunks)
        _flip(file, chunks[kk].offset + chunks[kk].length - 40)   # in the chunk's (compressed) records
        return sum(c.messages for c in chunks) - chunks[kk].messages, "chunk"
    return damage


def _flip_chunk_length(k: int) -> Callable[[Path], tuple[int, str]]:
    """A flipped byte in the chunk's record length: the reader must find the next record."""
    def damage(bag: Path) -> tuple[int, str]:
        file = next(bag.glob("*.mcap"))
        chunks = chunks_of(file)
        _flip(file, chunks[k].offset + 6)   # the length's 6th byte: far beyond the file's end
        return sum(c.messages for c in chunks) - chunks[k].messages, "unreadable bytes skipped"
    return damage


@dataclass
class Row:
    name: str
    compression: str
    damage: Callable[[Path], tuple[int, str]]


ROWS = [
    Row("cut_in_chunk", "zstd", damage_cut_in_chunk),
    Row("cut_in_index", "zstd", damage_cut_in_index),
    Row("flip_zstd_chunk", "zstd", _flip_chunk(4)),
    Row("flip_first_zstd_chunk", "zstd", _flip_chunk(0)),      # the chunk that defines schemas and channels
    Row("flip_uncompressed_chunk", "none", _flip_chunk(5)),
    Row("flip_zstd_chunk_length", "zstd", _flip_chunk_length(2)),
    Row("flip_uncompressed_chunk_length", "none", _flip_chunk_length(2)),
]


def run(main, argv: list[str], capsys) -> tuple[int, str]:
    code = main(argv)
    out = capsys.readouterr()
    text = out.out + out.err
    assert "Traceback" not in text and "this is a bug" not in text, text
    return code, text


@pytest.mark.parametrize("row", ROWS, ids=lambda r: r.name)
def test_damaged_bag_keeps_every_intact_chunk(row: Row, tmp_path, capsys):
    bag = make_bag(tmp_path, "run", row.compression)
    expected, problem = row.damage(bag)
    assert 0 < expected < len(stamped())

    code, text = run(bag_main, ["info", str(bag)], capsys)
    assert code == 1 and problem in text, text
    assert f"Messages:   {expected} " in text, text

    out = tmp_path / "recovered"
    code, text = run(bag_main, ["recover", str(bag), "--out", str(out)], capsys)
    assert code == 0 and problem in text, text
    assert mcap_count(out) == expected, text
    assert "kept" in text and "/gimbal/rate" in text
    if "cut" not in row.name and "length" not in row.name:   # the MessageIndex after the chunk says what it held
        assert f"{len(stamped()) - expected} messages known lost" in text, text


def test_damage_in_the_summary_costs_no_message(tmp_path, capsys):
    bag = make_bag(tmp_path, "run", "zstd")
    file = next(bag.glob("*.mcap"))
    summary_start = Footer.read(ReadDataStream(BytesIO(file.read_bytes()[-28:-8]))).summary_start
    assert summary_start > 0
    _flip(file, summary_start + 5)   # the first summary record's length: its framing is gone
    code, text = run(bag_main, ["info", str(bag)], capsys)
    assert code == 1 and "in the summary section" in text and f"Messages:   {len(stamped())} " in text, text
    code, text = run(bench_main, ["compare", str(bag), str(make_bag(tmp_path, "copy", "none"))], capsys)
    assert code == 0 and "same data" in text, text


def test_one_bad_chunk_of_nine_loses_only_that_chunk(tmp_path, capsys):
    """The acceptance case in miniature: nine chunks, one flipped byte, eight kept."""
    messages = stamped(duration_s=1.0)
    bag = make_bag(tmp_path, "nine", "zstd", messages, chunk_size=1500)
    chunks = chunks_of(next(bag.glob("*.mcap")))
    assert len(chunks) >= 9
    expected, _ = _flip_chunk(3)(bag)
    out = tmp_path / "out"
    code, text = run(bag_main, ["recover", str(bag), "--out", str(out)], capsys)
    assert code == 0 and mcap_count(out) == expected == len(messages) - chunks[3].messages


def test_report_on_a_damaged_bag_warns_and_on_an_unreadable_one_leaves_no_folder(tmp_path, capsys):
    bag = make_bag(tmp_path, "run", "zstd")
    expected, _ = damage_cut_in_index(bag)
    code, text = run(report_main, [str(bag)], capsys)
    assert code == 0 and "ends inside a MessageIndex record" in text, text
    metrics = yaml.safe_load((bag / "report" / "metrics.json").read_text())
    assert metrics["message_count"] == expected and not metrics["closed_cleanly"]

    # a report that fails part-way (this one needs truth topics) leaves no report/ behind
    (bag / "metadata.yaml").write_text("")   # not rosbag2 metadata either: refused by name
    code, text = run(report_main, [str(bag)], capsys)
    assert code == 2 and "metadata.yaml: not rosbag2 metadata" in text, text
    (bag / "metadata.yaml").unlink()
    shutil.rmtree(bag / "report")
    code, text = run(report_main, [str(bag), "--report", "sighting"], capsys)
    assert code == 2 and "/truth/gimbal/imu" in text and not (bag / "report").exists(), text

    dead = tmp_path / "dead"
    dead.mkdir()
    (dead / "dead_0.mcap").write_bytes(b"\x89MCAP0\r\n" + bytes(range(256)) * 4)
    code, text = run(report_main, [str(dead)], capsys)
    assert code == 2 and "no message can be read" in text, text
    assert not (dead / "report").exists()


# --- bags that are whole but unusual, or lie ------------------------------------------------------

def test_schemaless_channel_is_refused_by_name_and_breaks_no_other_topic(tmp_path, capsys):
    messages = stamped()
    bag = tmp_path / "bag"
    bag.mkdir()
    write_mcap(bag / "bag_0.mcap", messages, schemaless={"/gimbal/cmd"})   # schema_id 0, as MCAP allows
    others = sum(1 for m in messages if m[0] != "/gimbal/cmd")
    code, text = run(bag_main, ["info", str(bag)], capsys)
    assert code == 1 and "/gimbal/cmd" in text and "no schema (schema_id 0)" in text, text
    assert f"UNREADABLE: {len(messages) - others} messages skipped" in text, text
    assert f"Messages:   {others}" in text and "KeyError" not in text
    out = tmp_path / "out"
    code, text = run(bag_main, ["recover", str(bag), "--out", str(out)], capsys)
    assert code == 0 and mcap_count(out) == others and "/gimbal/cmd" in text

    # with metadata.yaml naming its type, the topic is read (the type the rosbag2 bag states)
    write_metadata(bag, ["bag_0.mcap"], messages)
    code, text = run(bag_main, ["info", str(bag)], capsys)
    assert code == 0 and f"Messages:   {len(messages)}\n" in text, text


def _lie_counts(info):
    info["message_count"] *= 10
    info["topics_with_message_count"][0]["message_count"] *= 10


def _lie_dropped_topic(info):
    del info["topics_with_message_count"][1]


def _lie_type(info):
    info["topics_with_message_count"][2]["topic_metadata"]["type"] = "sensor_msgs/msg/Imu"


def _lie_time(info):
    info["duration"]["nanoseconds"] += 5_000_000_000


@pytest.mark.parametrize("lie, named", [
    (_lie_counts, "message_count: metadata says 3200"),
    (_lie_dropped_topic, "topic /gimbal/angle: the files hold 100 messages"),
    (_lie_type, "topic /gimbal/cmd: metadata says type sensor_msgs/msg/Imu"),
    (_lie_time, "time range: metadata says"),
], ids=["counts_x10", "dropped_topic", "wrong_type", "time_range"])
def test_info_checks_metadata_against_the_files(lie, named, tmp_path, capsys):
    messages = stamped()
    bag = make_bag(tmp_path, "run")
    write_metadata(bag, ["run_0.mcap"], messages, lie)
    code, text = run(bag_main, ["info", str(bag)], capsys)
    assert code == 1 and "metadata.yaml does not match the files" in text and named in text, text
    assert f"Messages:   {len(messages)}" in text and mcap_count(bag) == len(messages)


def _two_files(root: Path) -> tuple[Path, int]:
    bag = root / "two"
    bag.mkdir()
    first, second = stamped(1.0), stamped(1.0, offset=100.0)
    write_mcap(bag / "a.mcap", first)
    write_mcap(bag / "b.mcap", second)
    return bag, len(first) + len(second)


@pytest.mark.parametrize("command", ["info", "recover"])
def test_two_mcap_files_without_metadata_are_refused_unless_merge(command, tmp_path, capsys):
    bag, total = _two_files(tmp_path)
    out = tmp_path / "out"
    extra = ["--out", str(out)] if command == "recover" else []
    code, text = run(bag_main, [command, str(bag), *extra], capsys)
    assert code == 2 and "a.mcap" in text and "b.mcap" in text and "--merge" in text, text
    assert not out.exists()
    code, text = run(bag_main, [command, str(bag), *extra, "--merge"], capsys)
    if command == "info":
        assert f"Messages:   {total}" in text, text
    else:
        assert code == 0 and mcap_count(out) == total == mcap_count(bag)


def _split(root: Path, name: str, messages, second=None) -> Path:
    """A rosbag2 split bag: the first half of the messages in one file, the rest in another."""
    bag = root / name
    bag.mkdir()
    half = len(messages) // 2
    write_mcap(bag / f"{name}_0.mcap", messages[:half])
    write_mcap(bag / f"{name}_1.mcap", second if second is not None else messages[half:])
    write_metadata(bag, [f"{name}_0.mcap", f"{name}_1.mcap"], messages)
    return bag


def test_split_bag_is_read_whole_in_metadata_order(tmp_path, capsys):
    messages = stamped()
    bag = _split(tmp_path, "split", messages)
    code, text = run(bag_main, ["info", str(bag)], capsys)
    assert code == 0 and f"Messages:   {len(messages)}\n" in text and mcap_count(bag) == len(messages), text
    out = tmp_path / "out"
    code, text = run(bag_main, ["recover", str(bag), "--out", str(out)], capsys)
    assert code == 0 and mcap_count(out) == len(messages) and "nothing was damaged" in text


# --- compare: the four false verdicts, each with its true one ------------------------------------

def _compare_rows(root: Path) -> dict[str, tuple[Path, Path]]:
    messages = stamped()
    whole = make_bag(root, "whole", messages=messages)
    half = len(messages) // 2
    changed = [(t, ns, v + (1e-3 if i == 7 else 0.0)) for i, (t, ns, v) in enumerate(messages[half:])]
    damaged = make_bag(root, "damaged", "none", messages=messages)
    _flip_chunk(3)(damaged)
    two, _ = _two_files(root)
    return {"split_second_files_differ": (_split(root, "s1", messages), _split(root, "s2", messages, changed)),
            "split_copy_of_itself": (whole, _split(root, "copy", messages)),
            "refused_bag_against_itself": (two, two),
            "crc_damaged_against_itself": (damaged, damaged)}


COMPARE = [  # row, exit code, what the output must say
    ("split_second_files_differ", 1, "DIFFERENT: max |Δ| 0.001"),
    ("split_copy_of_itself", 0, "same data"),
    ("refused_bag_against_itself", 2, "a.mcap, b.mcap"),
    ("crc_damaged_against_itself", 2, "chunk failed its CRC check"),
]


@pytest.mark.parametrize("row, code, says", COMPARE, ids=[r[0] for r in COMPARE])
def test_compare_tells_the_truth(row, code, says, tmp_path, capsys):
    a, b = _compare_rows(tmp_path)[row]
    got, text = run(bench_main, ["compare", str(a), str(b)], capsys)
    assert got == code and says in text, text
    if row == "split_second_files_differ":
        t = stamped()[len(stamped()) // 2 + 7]
        assert f"{t[0]}  DIFFERENT" in text and f"log time {t[1] * 1e-9:.9f} s" in text, text
        assert sum("identical" in line for line in text.splitlines()) == len(TOPICS) - 1
    if row == "crc_damaged_against_itself":
        assert "same data" not in text and "UNREADABLE" in text and "NOT COMPARABLE" in text


# --- a closed pipe, and play on a damaged bag ------------------------------------------------------

def test_info_into_a_closed_pipe_ends_quietly(tmp_path):
    bag = make_bag(tmp_path, "run")
    read_end, write_end = os.pipe()
    os.close(read_end)   # the reader is gone before the first line: every write meets EPIPE
    proc = subprocess.run([str(VENV_BIN / "gimbal-bag"), "info", str(bag)], stdout=write_end,
                          stderr=subprocess.PIPE, text=True, timeout=60)
    os.close(write_end)
    assert proc.returncode == 141 and proc.stderr == "", proc.stderr


def test_play_warns_per_damaged_chunk_and_plays_the_rest(tmp_path, ros_domain_env):
    bag = make_bag(tmp_path, "run", "zstd")
    expected, _ = _flip_chunk(4)(bag)
    proc = subprocess.run([str(VENV_BIN / "gimbal-bag"), "play", str(bag), "--rate", "0"], env=ros_domain_env,
                          capture_output=True, text=True, timeout=120)
    text = proc.stdout + proc.stderr
    assert proc.returncode == 0 and "Traceback" not in text, text
    assert "does not decompress" in text or "failed its CRC check" in text, text
    assert f"played {expected} messages" in text, text


def _seeded_damage(rng, pristine: bytes, kind: int) -> tuple[bytes, int, int]:
    """A damaged copy and the byte range [lo, hi) the damage touches: a zeroed block (a lost
    disk block), a cut (a power cut), or three random bytes within 64 (a bad copy)."""
    at = rng.randrange(len(pristine))
    if kind == 0:
        span = rng.choice([16, 512, 4096])
        return pristine[:at] + bytes(len(pristine[at:at + span])) + pristine[at + span:], at, at + span
    if kind == 1:
        return pristine[:at], at, len(pristine)
    data = bytearray(pristine)
    for _ in range(3):
        data[min(at + rng.randrange(64), len(data) - 1)] ^= rng.randrange(1, 256)
    return bytes(data), at, at + 64


def test_damage_anywhere_keeps_every_untouched_chunk_and_invents_nothing(tmp_path):
    """Seeded damage all over a file (header, chunks, indexes, summary, footer): the reader
    never raises, every message it gives was written (topic, stamp and bytes, once), and
    every message of a chunk the damage does not touch is among them."""
    import random

    from gimbal_sim.bag.reader import read_messages

    written = {(m[0], m[1], _message(m[1], m[2])) for m in stamped()}
    rng = random.Random(7)
    for compression in ("zstd", "none"):
        bag = make_bag(tmp_path, f"fuzz_{compression}", compression)
        file = next(bag.glob("*.mcap"))
        pristine, chunks = file.read_bytes(), chunks_of(file)
        for trial in range(45):
            data, lo, hi = _seeded_damage(rng, pristine, trial % 3)
            file.write_bytes(data)
            messages, contents = read_messages(bag)
            got = [(m.topic, m.log_time_ns, m.data) for m in messages]
            assert set(got) <= written and len(got) == len(set(got)), (compression, lo, contents.error)
            untouched = sum(c.messages for c in chunks if not (c.offset < hi and lo < c.offset + c.length))
            assert len(got) >= untouched, (compression, lo, hi, [c.offset for c in chunks], contents.error)
