"""Several seeds of the compiled platform chain stepping together: does it pay?

``python -m gimbal_sim.tools.engine_seeds [--seeds 4] [--duration 20] [--threads N]`` runs
``rotational_ins_navigation`` at its paper rate (:func:`.engine_speed.paper_rate_navigation`,
unrecorded) for ``--seeds`` seeds twice: one seed after another (each seed's own
:func:`..core.compiled_platform.run`, what a campaign does), and all seeds in one call of a
parallel block loop (numba ``prange`` over the seeds, each seed's block of steps the same
:func:`..core.compiled_platform.platform_block` over its own arrays). It prints the steps/s
of all seeds together and per CPU second for both, with the load average, and checks that
both leave every seed in the same final state. A batch gains only what the cores free for
it: the compiled step has no Python per step left to share.
"""
from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np
from numba import njit, prange, set_num_threads

from ..core.compiled_platform import BLOCK_STEPS, _block_normals, platform_block, run
from ..core.compiled_platform_setup import N_OUT, build_chain
from .engine_speed import paper_rate_navigation

#: the per-seed arrays of a chain, in :func:`platform_block`'s order (the normals apart)
FIELDS = ("config", "host", "x", "plant_params", "res_state", "acc", "acc_k", "acc_c", "gyr", "gyr_k", "gyr_c",
          "nav_state", "nav_params", "joint", "servo_state", "servo_params", "pid_state", "pid_gains", "base_last")


@njit(parallel=True, cache=True)
def seeds_block(k0, k1, stamps, c, host, x, pp, rstate, rz, acc, acc_k, acc_c, az, gyr, gyr_k, gyr_c, gz, ns, nq,
                joint, ss, sp, pid_s, pid_g, counts, base_last):
    """:func:`platform_block` of each seed (leading axis) over steps k0 … k1−1, in parallel
    (a static host: one row each)."""
    out = np.empty((0, N_OUT))
    for i in prange(c.shape[0]):
        platform_block(k0, k1, stamps, c[i], host[i], x[i], pp[i], rstate[i], rz[i], acc[i], acc_k[i], acc_c[i], az[i],
                       gyr[i], gyr_k[i], gyr_c[i], gz[i], ns[i], nq[i], joint[i], ss[i], sp[i], pid_s[i], pid_g[i],
                       counts[i], base_last[i], out)


def run_together(scenarios: list) -> tuple[float, float, np.ndarray]:
    """All seeds' chains stepped in one parallel call per block: (wall, CPU [s], final plant states)."""
    chains = [build_chain(s) for s in scenarios]
    stacked = {name: np.stack([getattr(ch, name) for ch in chains]) for name in FIELDS}
    stacked["host"] = stacked["host"].reshape(len(chains), 1, 9)
    n, rate = chains[0].n_steps, chains[0].rate_hz
    counts = np.zeros((len(chains), 3))
    c0, t0 = time.process_time(), time.perf_counter()
    for k0 in range(0, n + 1, BLOCK_STEPS):
        k1 = min(n + 1, k0 + BLOCK_STEPS)
        stamps = np.rint(np.arange(k0, k1) * 1e9 / rate)
        rz, az, gz = (np.stack(z) for z in zip(*(_block_normals(ch, k0, k1) for ch in chains)))
        counts[:, 1:] = 0.0
        a = stacked
        seeds_block(k0, k1, stamps, a["config"], a["host"], a["x"], a["plant_params"], a["res_state"], rz, a["acc"],
                    a["acc_k"], a["acc_c"], az, a["gyr"], a["gyr_k"], a["gyr_c"], gz, a["nav_state"], a["nav_params"],
                    a["joint"], a["servo_state"], a["servo_params"], a["pid_state"], a["pid_gains"], counts,
                    a["base_last"])
    return time.perf_counter() - t0, time.process_time() - c0, stacked["x"]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m gimbal_sim.tools.engine_seeds",
                                     description="Seeds of the compiled platform chain one after another, then "
                                                 "stepping together (prange): steps/s of both.")
    parser.add_argument("--seeds", type=int, default=4, help="seeds (default 4)")
    parser.add_argument("--duration", type=float, default=20.0, help="simulated seconds per seed (default 20)")
    parser.add_argument("--threads", type=int, help="numba threads (default: numba's, one per core)")
    args = parser.parse_args(argv)
    if args.seeds < 1 or not args.duration > 0.0:
        print("engine_seeds: --seeds must be >= 1 and --duration > 0", file=sys.stderr)
        return 2
    if args.threads is not None:
        set_num_threads(args.threads)
    scenarios = [paper_rate_navigation(args.duration, seed=seed) for seed in range(1, args.seeds + 1)]
    run_together([paper_rate_navigation(0.01, seed=s) for s in range(1, args.seeds + 1)])  # warm-up
    run(paper_rate_navigation(0.01))
    load = os.getloadavg()[0]
    chains = [build_chain(scenario) for scenario in scenarios]
    c0, t0 = time.process_time(), time.perf_counter()
    for scenario, chain in zip(scenarios, chains):
        run(scenario, None, chain=chain)
    wall_seq, cpu_seq = time.perf_counter() - t0, time.process_time() - c0
    wall_par, cpu_par, x = run_together(scenarios)
    steps = args.seeds * round(args.duration * 1000.0)
    same = all(np.array_equal(ch.x, b) for ch, b in zip(chains, x))
    print(f"{args.seeds} seeds x {args.duration:g} s at 1 kHz (1-min load {load:.2f} -> {os.getloadavg()[0]:.2f}):")
    print(f"  one after another  {steps / wall_seq:>10,.0f} steps/s  {steps / cpu_seq:>10,.0f} steps per CPU s")
    print(f"  together (prange)  {steps / wall_par:>10,.0f} steps/s  {steps / cpu_par:>10,.0f} steps per CPU s  "
          f"({wall_seq / wall_par:.2f}x wall)")
    print(f"  the same final states: {'yes' if same else 'NO'}")
    return 0 if same else 1


if __name__ == "__main__":
    sys.exit(main())
