"""Paper 1's headline on the engine, with bags: the LOS drifts 3–4° in 120 s without the
gyro-bias EKF (paper 1 §6) and the EKF fed back holds it under 0.3° (the bound this toolkit
sets beside the paper's "the LOS drift is removed"), on the headline scenario as it ships
(Schuler-correlated INS, the 25 Hz loop), over seeds.

Statistical: the seed mean of the drift carries sampling spread (the gyro's Gauss-Markov
bias instability), so the paper's band is checked against the 99 % Student-t interval of
that mean; the EKF's bound holds on every seed. The drift is the ``sighting`` report's, from
each run's bag (the truth LOS recorded at 10 Hz: the figure is its final value)."""
import dataclasses

import numpy as np
from scipy import stats

from gimbal_sim.experiments.engine_runs import run_on_engine
from gimbal_sim.graph.scenario import load, variant
from gimbal_sim.reports.sighting import TRUTH_LOS, TRUTH_BIAS

SEEDS = range(1, 7)
PAPER_BAND_DEG = (3.0, 4.0)   # paper 1: without the EKF the LOS drifts 3–4° in 120 s
EKF_BOUND_DEG = 0.3           # with it, the bound this toolkit sets


def _drift_deg(mode: str, seed: int, out) -> np.ndarray:
    s = variant(load("sighting_land_vehicle"), mode)
    s = dataclasses.replace(s, seed=seed, record=[TRUTH_LOS, TRUTH_BIAS],
                            record_rates_hz={TRUTH_LOS: 10.0, TRUTH_BIAS: 10.0})
    d = run_on_engine(s, out / f"{mode}_{seed}", compress=False)["sighting"]["final_drift_deg"]
    return np.array([d["azimuth"], d["elevation"]])


def test_without_the_ekf_the_los_drifts_three_to_four_degrees_and_with_it_under_a_third(tmp_path):
    off = np.array([np.abs(_drift_deg("ekf_off", s, tmp_path)).mean() for s in SEEDS])
    on = np.array([np.abs(_drift_deg("ekf_on", s, tmp_path)).max() for s in SEEDS])
    mean, se = off.mean(), off.std(ddof=1) / np.sqrt(len(off))
    half = stats.t.ppf(0.995, len(off) - 1) * se
    assert mean - half <= PAPER_BAND_DEG[1] and mean + half >= PAPER_BAND_DEG[0], (mean, half, off)
    assert np.all(on < EKF_BOUND_DEG), on
    assert np.all(off > 10.0 * on)  # the EKF removes the drift on every seed, not on average
