"""The one engine, no ROS: a scenario's cores stepped in one loop, the speed limit of its maths.

Each node of the scenario is replaced by its core (``VehicleCore``, ``SensorSuite``, the
controllers' and estimators' cores), built from the same parameter values the orchestrator
would give the node, and the loop passes between them exactly what the nodes' messages
carry (float64 fields, the Imu quaternion ↔ Euler conversions of the sensor node), in
lockstep order: truth k → sensors k → estimators k → commands k → step k → k+1 (:data:`STAGES`
holds the order). So for a seed the loop computes the same numbers as the graph; recorded
(``record``, :class:`.recording.EngineBag`), each stage hands over what its node publishes,
made by the node's own serialisation function, and the bag holds the graph's data
(:mod:`.engine_run`, ``gimbal-run --engine core``).

:func:`run_core_loop` runs a scenario (a node set that a compiled runner of :mod:`.compiled`
steps whole goes there: the same numbers, block by block); :func:`run_stages` is the loop
itself, which the analysis runners (``experiments.bias_ekf``, ``closed_loop``, ``flexure``)
call with their own stages (:mod:`.core_stages`, :mod:`.core_ideal`) and an observer of each
step's bus.

``python -m gimbal_sim.core.core_loop SCENARIO [--duration S] [--seed N] [--json]`` runs one
unrecorded (``gimbal-bench`` runs it in a subprocess, so that its peak RSS is its own).
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import sys
import time
from array import array
from typing import Any, Callable

from gimbal_kinematics.gimbal.gimbal_params import GIMBAL_MODELS
from gimbal_kinematics.timing.stamps import step_stamp_ns

from .core_stages import (
    Bus, encoder_fusion_stage, geo_pointer_stage, gyro_bias_ekf_stage, los_rate_controller_stage, operator_stage,
    sensor_stage, truth_stage,
)
from .estimator_stages import flexure_estimator_stage, free_gyro_positioning_stage, platform_alignment_stage
from .platform_stages import platform_navigator_node_stage, platform_servo_node_stage
from .compiled import compiled_runner
from .loop_plan import PASSIVE, CoreLoopResult, NoCoreError, node_values  # noqa: F401 (the loop's public names)
from ..graph.plan import process_stats
from ..graph.scenario import Scenario, ScenarioError, load
from ..world.vehicle import VehicleConfig, VehicleCore

#: executable -> the function making its stage from the node's parameter values and name, in
#: lockstep order (vehicle_dynamics is the loop itself).
STAGES: dict[str, Callable[[dict[str, Any], str], Callable[[Bus], None]]] = {
    "sensor_models": sensor_stage,
    "gyro_bias_ekf": gyro_bias_ekf_stage,
    "operator": operator_stage,
    "geo_pointer": geo_pointer_stage,
    "los_rate_controller": los_rate_controller_stage,
    "encoder_fusion_controller": encoder_fusion_stage,
    "platform_navigator": platform_navigator_node_stage,
    "platform_servo": platform_servo_node_stage,
    "flexure_estimator": flexure_estimator_stage,
    "platform_alignment": platform_alignment_stage,
    "free_gyro_positioning": free_gyro_positioning_stage,
}


def check_stages(values: dict[str, tuple[str, dict[str, Any]]]) -> None:
    """Raise :class:`NoCoreError` unless the nodes (:func:`node_values`) are one
    ``vehicle_dynamics`` and nodes that have a stage."""
    unknown = sorted({exe for exe, _ in values.values()} - set(STAGES) - {"vehicle_dynamics"})
    if unknown:
        raise NoCoreError(f"no engine stage for {', '.join(unknown)}")
    if [exe for exe, _ in values.values()].count("vehicle_dynamics") != 1:
        raise NoCoreError("the engine needs exactly one vehicle_dynamics")


def core_plan(scenario: Scenario) -> tuple[VehicleCore, bool, list[Callable[[Bus], None]]]:
    """The scenario's vehicle core, whether it takes commands, and its nodes' stages in
    lockstep order (the vehicle's messages first); raises :class:`NoCoreError`."""
    values = node_values(scenario)
    check_stages(values)
    name, v = next((n, v) for n, (exe, v) in values.items() if exe == "vehicle_dynamics")
    vehicle = VehicleCore(VehicleConfig.from_values(v), GIMBAL_MODELS[v["gimbal_model"]])
    stages = [truth_stage(vehicle.config.plant, v["position_truth_every_steps"], vehicle.profile.site, name)]
    stages += [STAGES[exe](v, n) for exe in STAGES for n, (e, v) in values.items() if e == exe]
    return vehicle, v["controlled"], stages


def run_core_loop(scenario: Scenario, keep_commands: bool = False,
                  observer: Callable[[Bus], None] | None = None,
                  record: Callable[[str, list], None] | None = None, keep_latency: bool = False,
                  compiled: bool = True) -> CoreLoopResult:
    """Step the scenario's cores (module docstring); raises :class:`NoCoreError`.

    ``observer(bus)``, when given, sees each step's bus after every stage ran and before the
    vehicle steps (what the step's messages carry: a run's metrics are computed from it);
    ``record`` (:class:`.recording.EngineBag`) gets every node's messages. A node set that a
    compiled runner steps (:mod:`.compiled`) runs there when no per-step Python is asked for
    (no ``observer`` or latencies kept; ``compiled=False``: always this loop): the same
    numbers, block by block."""
    if compiled and observer is None and not keep_latency:
        values = node_values(scenario)
        run = compiled_runner(values, keep_commands)
        if run is not None:
            return run(scenario, values, keep_commands, record)
    vehicle, controlled, stages = core_plan(scenario)
    return run_stages(vehicle, stages, controlled=controlled, keep_commands=keep_commands, observer=observer,
                      record=record, keep_latency=keep_latency)


def run_stages(vehicle: VehicleCore, stages: list[Callable[[Bus], None]], *, controlled: bool = True,
               keep_commands: bool = False, observer: Callable[[Bus], None] | None = None,
               record: Callable[[str, list], None] | None = None, keep_latency: bool = False) -> CoreLoopResult:
    """The loop itself: for k = 0 … n, the vehicle's truth of step k, then each stage in
    order, then ``observer``, then (k < n) the vehicle steps under the step's command (held
    at zero while no stage made one, or always when not ``controlled``).

    A paper runner that is no graph scenario (an idealised stabilizer or ideal sensors,
    :mod:`.core_ideal`) calls this with its own vehicle and stages; the stages at k = n see
    the final truth, which the graph's vehicle also publishes. ``keep_latency``: keep each
    step's wall time (8 bytes a step: 86 MB over a 3-hour run at 1 kHz, so only on request)."""
    bus = Bus()
    bus.record = record
    hold = (0.0,) * vehicle.config.command_size
    commands = [] if keep_commands else None
    lat = array("d")
    n = vehicle.config.n_steps
    rate = vehicle.config.sim_rate_hz
    clock = time.perf_counter
    c0 = time.process_time()
    t0 = prev = clock()
    for k in range(n + 1):
        bus.t_ns = step_stamp_ns(k, rate)
        bus.k, bus.t, bus.command = k, bus.t_ns * 1e-9, None  # a node's stamp in s
        bus.truth = vehicle.truth()
        for stage in stages:
            stage(bus)
        if observer is not None:
            observer(bus)
        command = bus.command if controlled and bus.command is not None else hold
        if commands is not None:
            commands.append(command)
        if k < n:
            vehicle.step(command)
        if keep_latency:
            now = clock()
            lat.append(now - prev)
            prev = now
    wall = clock() - t0
    return CoreLoopResult(n, n * vehicle.config.dt, wall, time.process_time() - c0, lat, commands)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m gimbal_sim.core.core_loop",
                                     description="Step a scenario's cores in one Python loop (no ROS) and time it.")
    parser.add_argument("scenario")
    parser.add_argument("--duration", type=float, help="simulated seconds (default: the scenario's)")
    parser.add_argument("--seed", type=int, help="seed (default: the scenario's)")
    parser.add_argument("--json", action="store_true", help="print the result as JSON (with per-step latencies)")
    args = parser.parse_args(argv)
    try:
        scenario = load(args.scenario)
        if args.duration is not None:
            scenario = dataclasses.replace(scenario, duration_s=args.duration)
        if args.seed is not None:
            scenario = dataclasses.replace(scenario, seed=args.seed)
        result = run_core_loop(scenario, keep_latency=args.json)
    except ScenarioError as exc:
        print(f"core_loop: {exc}", file=sys.stderr)
        return 2
    if args.json:
        json.dump({"steps": result.steps, "sim_s": result.sim_s, "wall_s": result.wall_s, "cpu_s": result.cpu_s,
                   "peak_rss_mb": process_stats().peak_rss_mb, "step_latency_s": result.step_latency_s.tolist()},
                  sys.stdout)
    else:
        print(f"{scenario.name}: {result.steps} steps in {result.wall_s:.2f} s wall ({result.steps_per_s:,.0f} "
              f"steps/s, {result.cpu_s:.2f} s CPU)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
