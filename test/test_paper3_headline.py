"""Paper 3's headline on the engine, with bags: rotation modulation makes the platform INS
navigate about five times better (§4.3: 0.38 n mile/h CEP rotating, "improved by almost 5
times" over the original system's 2 n mile/h).

What is pinned here is the part this toolkit reproduces: at the same (perfect) alignment and
the same sensors (paired seeds), the rotating platform's radial error is smaller on every seed
and the CEP50 ratio not rotating / rotating is at least :data:`RATIO_BOUND` after one hour
(the bound this toolkit sets beside the paper's 5×; docs/results/paper3.md gives the 3-hour
campaign). The runs are scenario ``rotational_ins_navigation``'s 5 Hz variants, each with its
bag, and the figure is the ``navigation`` report's, read from that bag.

The paper's other comparison, its original system (gyrocompass-aligned, not rotating) against
the upgraded one, is measured by the campaign's ``original_system`` and ``upgraded`` variants
and not pinned as an ordering: on a static base with run-constant biases the gyrocompass's
azimuth error, −εE/(Ω cos L), cancels the east drift in navigation (eq. 5), so this model does
not reproduce the paper's 2 n mile/h (docs/results/paper3.md says by how much). The
gyrocompass's own figure, 8.95′ against the paper's 9′, is pinned in test_rotation_alignment.py."""
import dataclasses

import numpy as np

from gimbal_sim.experiments.engine_runs import run_on_engine
from gimbal_sim.experiments.navigation import median_interval
from gimbal_sim.graph.scenario import load, variant

SEEDS = range(1, 6)
DURATION_S = 3600.0
#: CEP50 not rotating / rotating after 1 h: paper 3 ≈ 5 (at 3 h); the bound this toolkit sets.
RATIO_BOUND = 3.0


def _radial_rate(name: str, seed: int, out) -> float:
    s = dataclasses.replace(variant(load("rotational_ins_navigation"), name), seed=seed, duration_s=DURATION_S)
    return run_on_engine(s, out / f"{name}_{seed}", compress=False)["navigation"]["final_radial_rate_nmi_h"]


def test_rotating_the_platform_beats_holding_it_on_every_seed_and_by_three_at_the_median(tmp_path):
    on = np.array([_radial_rate("rotation_on_5hz", s, tmp_path) for s in SEEDS])
    off = np.array([_radial_rate("rotation_off_5hz", s, tmp_path) for s in SEEDS])
    assert np.all(off > on), (on, off)
    ratio = median_interval(off)[0] / median_interval(on)[0]
    assert ratio >= RATIO_BOUND, (ratio, on, off)
