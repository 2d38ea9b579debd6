"""``gimbal-bag``: inspect, play and recover rosbag2-style MCAP bags.

Exit codes: 0 success, 1 the bag is damaged (info) or playback failed, 2 bad input (not a
bag, bad options). Nothing is ever overwritten.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from .reader import BagError, recover, scan


def _fmt_time(ns: int | None) -> str:
    return "-" if ns is None else f"{ns / 1e9:.9f} s"


def cmd_info(args: argparse.Namespace) -> int:
    contents = scan(Path(args.bag))
    info = {
        "bag": str(contents.directory), "file": contents.mcap_path.name,
        "closed_cleanly": contents.closed_cleanly, "metadata.yaml": contents.has_metadata,
        "problem": contents.error, "messages": contents.message_count,
        "start": contents.start_ns, "end": contents.end_ns,
        "duration_s": None if contents.start_ns is None else (contents.end_ns - contents.start_ns) / 1e9,
        "topics": {t.name: {"type": t.type_name, "count": t.count} for t in contents.topics.values()},
    }
    if args.json:
        print(json.dumps(info, indent=2))
    else:
        print(f"Bag:        {info['bag']} ({info['file']})")
        state = "yes" if contents.closed_cleanly else f"NO ({contents.error or 'no metadata.yaml'})"
        print(f"Closed cleanly: {state}")
        print(f"Messages:   {contents.message_count}" + ("" if contents.closed_cleanly else " (readable part)"))
        print(f"Start:      {_fmt_time(contents.start_ns)}")
        print(f"End:        {_fmt_time(contents.end_ns)}")
        print(f"Duration:   {info['duration_s'] if info['duration_s'] is not None else '-'} s")
        print("Topics:")
        width = max((len(t) for t in info["topics"]), default=0)
        for name, t in sorted(info["topics"].items()):
            print(f"  {name:<{width}}  {t['count']:>9}  {t['type']}")
    return 0 if contents.closed_cleanly else 1


def cmd_recover(args: argparse.Namespace) -> int:
    out, contents = recover(Path(args.bag), args.out)
    print(f"recovered {contents.message_count} messages ({len(contents.topics)} topics) from every complete chunk "
          f"of {args.bag} into {out}" + (f"; the original stopped: {contents.error}" if contents.error else ""))
    return 0


def cmd_play(args: argparse.Namespace) -> int:
    import rclpy
    from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor

    from gimbal_kinematics.ros.ros_domain import localhost_env
    from .player import BagPlayer, PlayOptions, parse_remaps

    options = PlayOptions(rate=args.rate, clock=args.clock, topics=args.topics, remap=parse_remaps(args.remap),
                          start_offset_s=args.start_offset, loop=args.loop,
                          wait_for_subscribers=args.wait_for_subscribers, pace_topics=args.pace)
    localhost_env()
    rclpy.init(args=[])  # our own --remap OLD:=NEW must not be read as a global ROS remap rule
    player = None
    try:
        player = BagPlayer(Path(args.bag), options)
        executor = SingleThreadedExecutor()
        executor.add_node(player)
        count = player.play(executor)
        print(f"played {count} messages ({player.retries} publish retries under back-pressure)")
        return 0
    except (KeyboardInterrupt, ExternalShutdownException):
        return 0
    finally:
        if player is not None:
            player.destroy_node()
        rclpy.try_shutdown()


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="gimbal-bag", description="Inspect, play back and recover "
                                     "rosbag2-style MCAP bags (the ones gimbal-run records).")
    sub = parser.add_subparsers(dest="command", required=True)
    info = sub.add_parser("info", help="topics, types, counts, time span and whether the bag was closed cleanly")
    info.add_argument("bag", help="bag directory")
    info.add_argument("--json", action="store_true", help="print JSON")
    info.set_defaults(func=cmd_info)
    play = sub.add_parser("play", help="publish the bag's messages (reliably: nothing is dropped)")
    play.add_argument("bag", help="bag directory")
    play.add_argument("--rate", type=float, default=1.0, help="playback speed factor; 0 = as fast as possible")
    play.add_argument("--clock", action="store_true", help="publish /clock from bag time")
    play.add_argument("--topics", nargs="+", help="only these topics")
    play.add_argument("--remap", nargs="+", default=[], metavar="OLD:=NEW", help="rename topics")
    play.add_argument("--start-offset", type=float, default=0.0, metavar="S", help="skip the first S seconds")
    play.add_argument("--loop", action="store_true", help="play again and again (bag time jumps back)")
    play.add_argument("--wait-for-subscribers", type=int, default=0, metavar="N",
                      help="wait until every topic has N matched subscriptions")
    play.add_argument("--pace", nargs="+", default=[], metavar="TOPIC",
                      help="progress topics (rosgraph_msgs/Clock) of readers not to outrun")
    play.set_defaults(func=cmd_play)
    rec = sub.add_parser("recover", help="write every complete chunk of a damaged bag to a new bag beside it")
    rec.add_argument("bag", help="bag directory")
    rec.add_argument("--out", type=Path, help="new bag directory (default <bag>_recovered)")
    rec.set_defaults(func=cmd_recover)
    return parser


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        return args.func(args)
    except BagError as exc:
        print(f"gimbal-bag: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
