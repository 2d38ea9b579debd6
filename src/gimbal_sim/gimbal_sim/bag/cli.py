"""``gimbal-bag``: inspect, play and recover rosbag2 bags: ours, and any other writer's
(MCAP, compressed chunks included, and sqlite3 ``.db3``, read through ``rosbags``).

Exit codes: 0 success, 1 the bag is damaged (info) or playback failed, 2 bad input (not a
bag, bad options). Nothing is ever overwritten.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from gimbal_kinematics.cli.boundary import Interrupted, cli_boundary
from gimbal_kinematics.ros.ros_domain import localhost_env

from .checks import damage_warnings, metadata_mismatches, topic_lines
from .reader import BagError, locate, recover, scan
from .scene_config import SceneConfig


def _fmt_time(ns: int | None) -> str:
    """Integer ns as seconds with all nine decimals (a float would lose them at epoch times)."""
    if ns is None:
        return "-"
    sec, frac = divmod(ns, 1_000_000_000)
    return f"{sec}.{frac:09d} s"


def _compression(contents) -> str:
    """The MCAP chunk compressions met while reading, or sqlite3's answer."""
    if contents.storage != "mcap":
        return "none (sqlite3 rows)"
    return ", ".join(sorted(c or "none" for c in contents.compression)) or "none"


def _warn(lines: list[str]) -> None:
    for line in lines:
        print(line, file=sys.stderr)


def cmd_info(args: argparse.Namespace) -> int:
    contents = scan(Path(args.bag), merge=args.merge)
    mismatches = metadata_mismatches(locate(Path(args.bag), args.merge).metadata, contents)
    info = {
        "bag": str(args.bag), "file": contents.mcap_path.name,
        "files": [f.name for f in contents.files], "storage": contents.storage,
        "compression": _compression(contents),
        "closed_cleanly": contents.closed_cleanly, "metadata.yaml": contents.has_metadata,
        "problem": contents.error, "messages": contents.message_count,
        "start": contents.start_ns, "end": contents.end_ns,
        "duration_s": None if contents.start_ns is None else (contents.end_ns - contents.start_ns) * 1e-9,
        "topics": {t.name: {"type": t.type_name, "count": t.count} for t in contents.topics.values()},
        "damage": [d.line() for d in contents.damage],
        "lost": {t: {"count": v.count, "first": v.first_ns, "last": v.last_ns} for t, v in contents.lost.items()},
        "unreadable_topics": contents.unreadable, "metadata_mismatches": mismatches,
    }
    _warn(damage_warnings(contents))
    if args.json:
        print(json.dumps(info, indent=2))
    else:
        _print_info(args, contents, info, mismatches)
    return 0 if contents.closed_cleanly and not mismatches and not contents.unreadable else 1


def _print_info(args: argparse.Namespace, contents, info: dict, mismatches: list[str]) -> None:
    print(f"Bag:        {info['bag']} ({', '.join(info['files'])})")
    print(f"Storage:    {contents.storage}, compression: {info['compression']}")
    state = "yes" if contents.closed_cleanly else f"NO ({contents.error or 'no metadata.yaml'})"
    print(f"Closed cleanly: {state}")
    print(f"Messages:   {contents.message_count}" + ("" if contents.closed_cleanly else " (readable part)"))
    print(f"Start:      {_fmt_time(contents.start_ns)}")
    print(f"End:        {_fmt_time(contents.end_ns)}")
    print(f"Duration:   {'-' if contents.start_ns is None else _fmt_time(contents.end_ns - contents.start_ns)}")
    print("Topics:")
    width = max((len(t) for t in info["topics"]), default=0)
    for name, t in sorted(info["topics"].items()):
        print(f"  {name:<{width}}  {t['count']:>9}  {t['type']}")
    if contents.damage or contents.unreadable:
        print(f"Damaged:    {len(contents.damage)} part(s) skipped; per topic, what was read and what was lost:")
        print("\n".join(topic_lines(contents)))
        print(f"            `gimbal-bag recover {args.bag}` writes what was read to a new, valid bag")
    if mismatches:
        print(f"metadata.yaml does not match the files ({len(mismatches)}):")
        print("\n".join(f"  {m}" for m in mismatches))
        if contents.damage:
            print("  (the damaged parts above may hold the messages the metadata counts and the files no longer give)")


def cmd_recover(args: argparse.Namespace) -> int:
    out, contents = recover(Path(args.bag), args.out, merge=args.merge)
    _warn(damage_warnings(contents))
    lost = sum(v.count for v in contents.lost.values())
    print(f"recovered {contents.message_count} messages ({len(contents.topics)} topics) of {args.bag} into {out}: "
          f"every chunk that checks" + (f"; {len(contents.damage)} damaged part(s) skipped, {lost} messages known "
                                        f"lost" if contents.damage else "; nothing was damaged"))
    print("per topic (time in s after the bag's first stamp):")
    print("\n".join(topic_lines(contents)))
    return 0


def cmd_play(args: argparse.Namespace) -> int:
    import rclpy
    from rclpy.executors import ExternalShutdownException

    from gimbal_kinematics.ros.node_main import make_executor

    from .player import BagPlayer, PlayOptions, load_qos_overrides, parse_remaps

    options = PlayOptions(rate=args.rate, clock_hz=args.clock or 0.0, topics=args.topics,
                          exclude_topics=args.exclude_topics, remap=parse_remaps(args.remap),
                          start_offset_s=args.start_offset, playback_duration_s=args.playback_duration,
                          start_paused=args.start_paused, loop=args.loop,
                          wait_for_subscribers=args.wait_for_subscribers, pace_topics=args.pace,
                          wait_timeout_s=args.wait_timeout,
                          qos_overrides=load_qos_overrides(args.qos_profile_overrides_path),
                          merge=args.merge)
    live = _live_view(args)
    localhost_env()
    rclpy.init(args=[])  # our own --remap OLD:=NEW must not be read as a global ROS remap rule
    player = None
    try:
        player = BagPlayer(Path(args.bag), options, sink=live)
        executor = make_executor()
        executor.add_node(player)
        count = player.play(executor)
        print(f"played {count} messages ({player.retries} publish retries under back-pressure"
              + (f", {player.clocks} /clock" if player.clocks else "") + ")")
        return 0
    except (KeyboardInterrupt, ExternalShutdownException):
        done = f"after {player.published} of {len(player.messages)} messages" if player is not None else \
            "before playing"
        raise Interrupted(f"stopped playing {args.bag} {done}") from None
    finally:
        if player is not None:
            player.destroy_node()
        if live is not None:  # a bag refused before the player took it
            live.close()
        rclpy.try_shutdown()


def _live_view(args: argparse.Namespace):
    """``--live``: the live view the player hands what it plays, with the scene description
    beside the bag (:class:`.scene_config.SceneConfig`); None without ``--live``. An error
    inside it later is said once and turns it off; playing goes on."""
    if not 0.0 <= args.live_rate_hz < float("inf"):
        raise BagError(f"--live-rate-hz must be a finite rate >= 0 Hz, got {args.live_rate_hz}")
    if not args.live:
        return None
    if not 1 <= args.live_port <= 65535:
        raise BagError(f"--live-port must be in 1..65535, got {args.live_port}")
    from .live import LiveGuard, LivePortError, LiveRelay

    bag = Path(args.bag)
    scene, missing = SceneConfig.beside(bag if bag.is_dir() else bag.parent)  # a bag named by its .mcap too
    try:
        relay = LiveRelay("127.0.0.1", args.live_port, args.live_rate_hz, {}, scene)
    except LivePortError as exc:
        raise BagError(f"--live-port: {exc}") from None
    print(f"gimbal-bag play: live view on ws://127.0.0.1:{relay.port}" + (f"; {missing}" if missing else ""),
          file=sys.stderr, flush=True)
    return LiveGuard(relay, lambda line: print(f"gimbal-bag play: error: {line}", file=sys.stderr, flush=True))


MERGE_HELP = ("a folder of several .mcap files and no metadata.yaml: read them all as one bag, in name order "
              "(refused without it: they may be separate bags)")


def _positive(text: str) -> float:
    value = float(text)
    if not value > 0:
        raise argparse.ArgumentTypeError(f"must be > 0, got {text}")
    return value


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="gimbal-bag", description="Inspect, play back and recover rosbag2 "
                                     "bags: the ones gimbal-run records and any other writer's (MCAP, compressed "
                                     "or not, and sqlite3 .db3).")
    sub = parser.add_subparsers(dest="command", required=True)
    info = sub.add_parser("info", help="topics, types, counts, time span, storage, compression and whether the "
                                       "bag was closed cleanly")
    info.add_argument("bag", help="bag directory (or its .mcap / .db3 file)")
    info.add_argument("--json", action="store_true", help="print JSON")
    info.add_argument("--merge", action="store_true", help=MERGE_HELP)
    info.set_defaults(func=cmd_info)
    play = sub.add_parser("play", help="publish the bag's messages with the QoS they were recorded with")
    play.add_argument("bag", help="bag directory (or its .mcap / .db3 file)")
    play.add_argument("--rate", type=float, default=1.0, help="playback speed factor; 0 = as fast as possible")
    play.add_argument("--clock", type=_positive, nargs="?", const=40.0, default=None, metavar="RATE_HZ",
                      help="publish /clock from bag time, every 1/RATE_HZ s of bag time (default 40 Hz, "
                           "as rosbag2)")
    play.add_argument("--merge", action="store_true", help=MERGE_HELP)
    play.add_argument("--topics", nargs="+", help="only these topics")
    play.add_argument("--exclude-topics", nargs="+", default=[], metavar="TOPIC", help="all topics but these")
    play.add_argument("--remap", nargs="+", default=[], metavar="OLD:=NEW", help="rename topics")
    play.add_argument("--start-offset", type=float, default=0.0, metavar="S", help="skip the first S seconds")
    play.add_argument("--playback-duration", type=float, default=-1.0, metavar="S",
                      help="play S seconds of bag time from the start (offset); < 0 (default): to the end")
    play.add_argument("--start-paused", action="store_true",
                      help="wait for a keypress (a newline when stdin is not a terminal) before playing")
    play.add_argument("--qos-profile-overrides-path", type=Path, metavar="YAML",
                      help="rosbag2's per-topic QoS overrides: /topic: {reliability, durability, history, depth}")
    play.add_argument("--loop", action="store_true", help="play again and again (bag time jumps back)")
    play.add_argument("--live", action="store_true",
                      help="also serve the played topics to Foxglove or Lichtblick (ws://127.0.0.1:PORT)")
    play.add_argument("--live-port", type=int, default=8765, metavar="N", help="live view port (default 8765)")
    play.add_argument("--live-rate-hz", type=float, default=50.0, metavar="HZ",
                      help="rate each topic is relayed at (default 50; 0: every message)")
    play.add_argument("--wait-for-subscribers", type=int, default=0, metavar="N",
                      help="wait until every topic has N matched subscriptions")
    play.add_argument("--pace", nargs="+", default=[], metavar="TOPIC",
                      help="progress topics (rosgraph_msgs/Clock) of readers not to outrun")
    play.add_argument("--wait-timeout", type=float, default=30.0, metavar="S",
                      help="give up (exit 1) when --wait-for-subscribers / --pace readers do not come, or a paced "
                           "reader reports no progress, for S seconds (default 30)")
    play.set_defaults(func=cmd_play)
    rec = sub.add_parser("recover", help="write every chunk that checks of a damaged or cut bag to a new bag beside "
                                         "it; say per topic what was kept and what was lost, and when")
    rec.add_argument("bag", help="bag directory")
    rec.add_argument("--out", type=Path, help="new bag directory (default <bag>_recovered)")
    rec.add_argument("--merge", action="store_true", help=MERGE_HELP)
    rec.set_defaults(func=cmd_recover)
    return parser


@cli_boundary("gimbal-bag")
def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    return args.func(args)


if __name__ == "__main__":
    sys.exit(main())
