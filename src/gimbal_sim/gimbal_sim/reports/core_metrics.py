"""A paper runner's series from the engine's bus, without a bag: the same metrics the
scenario's report computes from a bag.

A collector watches each step's bus (an observer of
:func:`gimbal_sim.core.core_loop.run_stages`) and keeps what the graph would have recorded,
with the stamps the nodes would have put on it; its metrics come from the report's own
function on those series (for ``sighting``: :func:`..reports.sighting.sighting_figures`), so
the two are one computation on the same numbers. A scenario run on the engine writes its bag
and gets its report from it (``gimbal_sim.core.engine_run``).
"""
from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from gimbal_kinematics.timing.stamps import step_stamp_ns
from ..graph.scenario import Scenario
from .common import vehicle_site
from .geo_pointing import analyse_series as geo_pointing_series, geo_pointing_figures
from .operator import operator_figures, operator_tolerance
from .sighting import SightingSeries, sighting_figures


def _seconds(ns: list[int]) -> np.ndarray:
    """Log times as a bag reader computes them: ns * 1e-9, one float multiply each."""
    return np.array([v * 1e-9 for v in ns])


class _AttitudeCollector:
    """``/truth/gimbal/imu``'s quat_nm at every step, with the step stamps."""

    def __init__(self, scenario: Scenario) -> None:
        self.rate = scenario.sim_rate_hz
        self.t_ns: list[int] = []
        self.quat: list[tuple[float, ...]] = []

    def _record_attitude(self, bus: Any) -> int:
        """Record the step's attitude; returns its stamp [ns]."""
        t_ns = step_stamp_ns(bus.k, self.rate)
        self.t_ns.append(t_ns)
        self.quat.append(tuple(bus.truth.quat_nm))
        return t_ns


class SightingCollector(_AttitudeCollector):
    """What the ``sighting`` report reads, as the graph records it: ``/truth/gimbal/imu``
    (quat_nm at every step), ``/truth/gimbal/gyro_bias`` ((0, q, r) at each gyro sample) and
    the EKF's ``~/bias`` / ``~/bias_sigma`` at each of its outputs (stamp: the output's t)."""

    def __init__(self, scenario: Scenario) -> None:
        super().__init__(scenario)
        self.tb_ns: list[int] = []
        self.bias: list[tuple[float, ...]] = []
        self.te_ns: list[int] = []
        self.est: list[tuple[float, ...]] = []
        self.sig: list[tuple[float, ...]] = []

    def __call__(self, bus: Any) -> None:
        t_ns = self._record_attitude(bus)
        if bus.gyro is not None:
            self.tb_ns.append(t_ns)
            self.bias.append((0.0, *bus.gyro.true_bias))
        out = getattr(bus, "ekf", None)
        if out is not None:
            self.te_ns.append(int(round(out.t * 1e9)))  # the node's stamp of its output
            self.est.append(tuple(float(v) for v in out.bias))
            self.sig.append(tuple(float(v) for v in out.bias_sigma))

    def series(self) -> SightingSeries:
        """The series as a bag gives them (:class:`~.sighting.SightingSeries`)."""
        ekf = {}
        if self.te_ns:
            ekf = dict(t_ekf=_seconds(self.te_ns), bias_est=np.array(self.est), bias_sigma=np.array(self.sig))
        return SightingSeries(_seconds(self.t_ns), np.array(self.quat), _seconds(self.tb_ns),
                              np.array(self.bias).reshape(-1, 3), **ekf)

    def metrics(self, run_dir: Path) -> dict[str, Any]:
        lat, earth_rate = vehicle_site(run_dir)
        return {"sighting": sighting_figures(self.series(), lat, earth_rate)}


class SightingOperatorCollector(SightingCollector):
    """The ``sighting_operator`` report's series: the sighting ones, plus the operator's
    ``/operator/los_rate`` and ``~/pointing_error`` at each of its steps."""

    def __init__(self, scenario: Scenario) -> None:
        super().__init__(scenario)
        self.to_ns: list[int] = []
        self.cmd: list[tuple[float, ...]] = []
        self.err: list[tuple[float, ...]] = []

    def __call__(self, bus: Any) -> None:
        super().__call__(bus)
        if bus.operator is not None:
            stamp, q, r = bus.operator
            self.to_ns.append(stamp)
            self.cmd.append((0.0, q, r))
            self.err.append(tuple(bus.operator_error))

    def metrics(self, run_dir: Path) -> dict[str, Any]:
        out = super().metrics(run_dir)
        out["operator"] = operator_figures(_seconds(self.to_ns), np.array(self.err),
                                           np.array(self.cmd), operator_tolerance(run_dir))
        return out


class GeoPointingCollector(_AttitudeCollector):
    """The ``geo_pointing`` report's series: ``/truth/gimbal/imu`` (quat_nm at every step) and
    ``/geo_pointer/budget`` at each step the pointer made one, with the nodes' stamps."""

    def __init__(self, scenario: Scenario) -> None:
        super().__init__(scenario)
        self.tb_ns: list[int] = []
        self.budget: list[tuple[float, ...]] = []

    def __call__(self, bus: Any) -> None:
        self._record_attitude(bus)
        if bus.geo_budget is not None:
            self.tb_ns.append(bus.geo_budget[0])
            self.budget.append(tuple(bus.geo_budget[1:]))

    def metrics(self, run_dir: Path) -> dict[str, Any]:
        a = geo_pointing_series(run_dir, _seconds(self.t_ns), np.array(self.quat), _seconds(self.tb_ns),
                                np.array(self.budget).reshape(-1, 3))
        return {"geo_pointing": geo_pointing_figures(a)}
