"""A scenario's node plan, without ROS: every node with its final parameters and remaps
(what the orchestrator starts and the core loop steps), the run files they are started
with, and the /proc readings of a run's processes."""
from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

from ..bag.record_rates import rate_entries
from .live_scene import write_scene
from .registry import NODE_TYPES
from .scenario import Scenario, ScenarioError

RECORDER = "bag_recorder"


@dataclass
class PlannedNode:
    """A node to start: ``params`` every final value; ``graph_only`` the names among them that
    belong to the orchestrator's graph rather than to the node's configuration (the lockstep
    timing): passed as ``-p`` arguments, not written into the run's params file, so that file
    replays into the node started alone."""

    name: str
    executable: str
    params: dict[str, Any]
    remap: dict[str, str]
    params_file: Path | None = None
    graph_only: tuple[str, ...] = ()

    def ros_args(self) -> list[str]:
        args = ["--ros-args", "-r", f"__node:={self.name}", "--params-file", str(self.params_file)]
        for name in self.graph_only:
            args += ["-p", f"{name}:={self.params[name]}"]
        for old, new in self.remap.items():
            args += ["-r", f"{old}:={new}"]
        return args

    def file_params(self) -> dict[str, Any]:
        """What the run's ``params/<node>.yaml`` holds: every value but the graph's own."""
        return {k: v for k, v in self.params.items() if k not in self.graph_only}


@dataclass(frozen=True)
class ProcessStats:
    """CPU seconds (user + system) and peak resident memory of one process."""

    cpu_s: float
    peak_rss_mb: float


def process_stats(pid: int | str = "self") -> ProcessStats:
    """Read from /proc: utime + stime [s] and VmHWM [MiB] (Linux)."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    ticks = os.sysconf("SC_CLK_TCK")
    cpu = (int(fields[11]) + int(fields[12])) / ticks
    rss = 0.0
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmHWM:"):
            rss = int(line.split()[1]) / 1024.0
    return ProcessStats(cpu, rss)


def resident_mb(pid: int | str = "self") -> float:
    """Current resident memory (VmRSS) of a process [MiB]; 0 when it is gone."""
    try:
        for line in Path(f"/proc/{pid}/status").read_text().splitlines():
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024.0
    except OSError:
        pass
    return 0.0


def plan_nodes(scenario: Scenario, out_dir: Path, compress: bool = True,
               live: dict | None = None) -> list[PlannedNode]:
    """Every node with its final parameters: the scenario's, plus what the orchestrator
    owns (rate, seed, duration, readiness and pacing wiring, the recorder's output and
    whether it compresses the bag's chunks; ``live``: the recorder's live_* parameters)."""
    # a node in free timing is no lockstep reader: the vehicle neither waits for nor paces on it
    paced = [n for n, s in scenario.nodes.items()
             if "progress_every_steps" in {p.name for p in NODE_TYPES[s["executable"]].params}
             and s["params"].get("timing", "lockstep") != "free"]
    planned = []
    for name, spec in scenario.nodes.items():
        declared = {p.name for p in NODE_TYPES[spec["executable"]].params}
        params = dict(spec["params"])
        graph_only: tuple[str, ...] = ()
        if "sim_rate_hz" in declared:
            params["sim_rate_hz"] = scenario.sim_rate_hz
        if "seed" in declared:
            params["seed"] = scenario.seed
        if "timing" in declared and "timing" not in params:
            # the deterministic graph (a scenario may still ask a node for free timing)
            params["timing"] = "lockstep"
            graph_only = ("timing",)
        if spec["executable"] == "vehicle_dynamics":
            params["duration_s"] = scenario.duration_s
            params["pace_topics"] = [f"/{n}/progress" for n in paced + [RECORDER]]
            # /clock: the recorder and the run's monitor (which times every step)
            params.setdefault("subscriber_counts", ["/clock=2"])
        elif "wait_for_subscribers" in declared:
            # the recorder reads every output; a real-time scenario also counts its
            # free-timing readers (no readiness of their own: a sample sent before they
            # matched is lost)
            params.setdefault("wait_for_subscribers", 1)
        planned.append(PlannedNode(name, spec["executable"], params, spec["remap"], graph_only=graph_only))
    recorder = {"output_dir": str(out_dir), "compress": compress,
                "sim_rate_hz": scenario.sim_rate_hz, "end_time_s": scenario.duration_s,
                "topics": [] if scenario.record == "all" else list(scenario.record),
                "record_topic_rates": rate_entries(scenario.record_rates_hz),
                "wait_for_nodes": list(scenario.nodes), **(live or {})}
    # the recorder starts first so that it is listening before anyone publishes
    return [PlannedNode(RECORDER, RECORDER, recorder, {})] + planned


def check_nodes(scenario: Scenario, where: str = "") -> None:
    """Each node's final values (:func:`plan_nodes`: its defaults, the scenario's, variant's,
    params files' and ``--set`` values, and what the orchestrator sets) through the node's own
    start-up checks (:attr:`.registry.NodeType.check`, the ``from_values`` its ``__init__``
    runs): what a node would refuse is refused here, naming the node and the parameter,
    before anything starts; then the checks across nodes (:func:`_check_dtg`). Raises
    :class:`.scenario.ScenarioError`."""
    finals = {}
    for node in plan_nodes(scenario, Path("unused")):
        node_type = NODE_TYPES[node.executable]
        canonical = {alias: p.name for p in node_type.params for alias in (p.name, *p.aliases)}
        values = {p.name: p.default for p in node_type.params}
        values.update({canonical.get(k, k): v for k, v in node.params.items()})
        try:
            node_type.check(values)
        except (ValueError, TypeError) as exc:
            raise ScenarioError(f"{where}node {node.name!r}: {exc}") from None
        finals[node.name] = (node.executable, values)
    _check_dtg(finals, where)
    _check_servo_azimuth(finals, where)


def _check_servo_azimuth(finals: dict[str, tuple[str, dict[str, Any]]], where: str) -> None:
    """Paper 3's navigator on the servo's φz in lockstep (``azimuth_source: servo``) reads the
    servo's ``~/modulation_next`` (``modulation_next: true``), whose servo then waits for no
    command on its first step: one without the other waits for ever, or for a command never sent."""
    navs = [n for n, (exe, v) in finals.items() if exe == "platform_navigator" and v["timing"] == "lockstep"]
    servos = [n for n, (exe, v) in finals.items() if exe == "platform_servo" and v["timing"] == "lockstep"
              and v["command_source"] == "navigator"]
    if not navs or not servos:
        return
    on_phi = any(finals[n][1]["azimuth_source"] == "servo" for n in navs)
    ahead = any(finals[n][1]["modulation_next"] for n in servos)
    if on_phi != ahead:
        raise ScenarioError(f"{where}parameters 'azimuth_source' of {navs[0]!r} "
                            f"({'servo' if on_phi else 'resolver'}) and 'modulation_next' of {servos[0]!r} "
                            f"({str(ahead).lower()}) disagree: in lockstep the navigator on phi_z reads the servo's "
                            "~/modulation_next")


def _check_dtg(finals: dict[str, tuple[str, dict[str, Any]]], where: str) -> None:
    """Paper 3's DTGs come with the servo that torques them: where a scenario runs both
    ``sensor_models`` and ``platform_servo``, the sensor ``dtg`` and ``gyro_source: dtg`` go
    together (either alone waits for ever: the gyros for currents, the servo for pickoffs)."""
    sensors = [n for n, (exe, v) in finals.items() if exe == "sensor_models"]
    servos = [n for n, (exe, v) in finals.items() if exe == "platform_servo"]
    if not sensors or not servos:
        return
    has_dtg = any("dtg" in finals[n][1]["sensors"] for n in sensors)
    on_dtg = any(finals[n][1]["gyro_source"] == "dtg" for n in servos)
    if has_dtg != on_dtg:
        raise ScenarioError(f"{where}parameters 'sensors' of {sensors[0]!r} ({'with' if has_dtg else 'without'} dtg) "
                            f"and 'gyro_source' of {servos[0]!r} ({'dtg' if on_dtg else 'rate_triad'}) disagree: "
                            "the DTGs need the servo's torquer currents and the servo on them their pickoffs")


def write_run_files(scenario: Scenario, nodes: list[PlannedNode], out_dir: Path) -> None:
    (out_dir / "params").mkdir(parents=True)
    (out_dir / "logs").mkdir()
    (out_dir / "scenario.yaml").write_text(scenario.to_yaml())
    write_scene(scenario, out_dir)  # what the live view needs of it, recorder and replay alike
    for node in nodes:
        node.params_file = out_dir / "params" / f"{node.name}.yaml"
        node.params_file.write_text(yaml.safe_dump({node.name: {"ros__parameters": node.file_params()}},
                                                   sort_keys=False))
