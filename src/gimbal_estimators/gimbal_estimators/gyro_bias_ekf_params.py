"""Parameters of the gyro-bias EKF (:mod:`.gyro_bias_ekf`), readable without ROS, declared once:
the core's frozen :class:`GyroBiasEkfParams` and the node's own :class:`GyroBiasEkfNodeParams`
(its docstring is the node's --help text) give the ``gyro_bias_ekf`` node's parameter table
:data:`PARAMS`; and
:meth:`GyroBiasEkfParams.from_values`, the one mapping from the node's values to the core's
parameters, which the node and the no-ROS core loop both use.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from gimbal_kinematics.maths.validate import finite, nonneg_finite, positive
from gimbal_kinematics.params.table import CLOCK_JUMP_ALIASES, TimedParams, declaration, from_values, param


@dataclass(frozen=True)
class GyroBiasEkfNodeParams(TimedParams):
    """Paper 1 gyro-bias EKF: propagates the inner-gimbal attitude C(n,m) with the two-axis gimbal gyro (roll rate
    reconstructed from the INS and encoders, earth and transport rate included) and fuses the attitude built
    from the INS Euler angles and the encoders. Publishes the gyro-bias estimate and its 1-sigma (~/bias,
    ~/bias_sigma), the attitude estimate (~/attitude) and health (/diagnostics).
    """

    sim_rate_hz: float = param(1000.0, "lockstep rate: maps gyro stamps to steps for ~/progress", 1.0, 100000.0,
                               unit="Hz")
    progress_every_steps: int = param(10, "report the next step needed on ~/progress every N gyro steps", 1, 10**6)
    diagnostics_period_s: float = param(1.0, "health on /diagnostics every this much sim time", 1e-3, 1e6, unit="s")
    nis_window: int = param(100, "measurement updates in the NIS window on /diagnostics (free timing)", 1, 10**6)
    clock_jump_s: float = param(0.5, "a stamp this far behind resets the filter (bag loop)", 1e-9, 1e9, unit="s",
                                aliases=CLOCK_JUMP_ALIASES)


@dataclass(frozen=True)
class GyroBiasEkfParams:
    """Filter parameters (engineering units at this edge; validated, immutable), each a node
    parameter of the same name.

    The gimbal gyro's (q, r axes) and the roll channel's (the INS-rate part of eq. 4, from the
    INS gyro specification) bias instability and correlation time set the random-walk PSD
    2σ²/τ (τ = inf: random constant). ``ins_error_states`` chooses the augmented INS
    attitude error states (default) or paper 1's white-noise treatment;
    ``attitude_noise_floor_deg`` is added to R for unmodelled residuals (module docstring,
    "Synchronisation").
    """

    lat_deg: float = param(0.0, "site latitude (earth rate, transport rate)", -89.999, 89.999, unit="deg")
    height_m: float = param(0.0, "site height", -1e4, 1e5, unit="m")
    velocity_n_m_s: tuple[float, float, float] = param((0.0, 0.0, 0.0), "NED velocity for the transport rate",
                                                       unit="m/s")
    gyro_arw_deg_rt_h: float = param(0.15, "gimbal gyro angle random walk", 0.0, 1e4, unit="deg/sqrt(h)")
    gyro_bias_sigma_deg_h: float = param(104.4, "prior 1-sigma of the lumped gimbal gyro bias", 1e-6, 1e6,
                                         unit="deg/h")
    gyro_bias_instability_deg_h: float = param(30.0, "gimbal gyro Gauss-Markov bias instability RMS (sets the "
                                               "bias random walk)", 0.0, 1e6, unit="deg/h")
    gyro_bias_tau_s: float = param(100.0, "gimbal gyro bias correlation time", 1e-3, 1e9, unit="s")
    roll_arw_deg_rt_h: float = param(0.1, "INS gyro angle random walk", 0.0, 1e4, unit="deg/sqrt(h)")
    roll_bias_sigma_deg_h: float = param(1.42, "prior 1-sigma of the roll-channel (INS gyro) bias", 1e-6, 1e6,
                                         unit="deg/h")
    roll_bias_instability_deg_h: float = param(1.0, "INS gyro Gauss-Markov bias instability RMS", 0.0, 1e6,
                                               unit="deg/h")
    roll_bias_tau_s: float = param(60.0, "INS gyro bias correlation time", 1e-3, 1e9, unit="s")
    ins_roll_pitch_rms_deg: float = param(0.05, "INS roll/pitch error RMS", 0.0, 90.0, unit="deg")
    ins_heading_rms_deg: float = param(0.2, "INS heading error RMS", 0.0, 180.0, unit="deg")
    ins_attitude_tau_s: float = param(300.0, "INS attitude error correlation time (with ins_error_states)",
                                      1e-6, 1e9, unit="s")
    ins_error_states: bool = param(True, "model the INS attitude errors as Gauss-Markov states (false: paper 1's "
                                   "white measurement noise)")
    encoder_noise_deg: float = param(0.05, "encoder noise 1-sigma", 1e-9, 10.0, unit="deg")
    attitude_noise_floor_deg: float = param(0.02, "isotropic white attitude noise added to R for unmodelled "
                                            "residuals", 1e-9, 10.0, unit="deg")
    gate_probability: float = param(0.9999, "chi-square innovation gate probability (3 dof)", 1e-6, 0.999999999,
                                    unit="-")
    max_consecutive_gated: int = param(100, "gated updates in a row before the attitude is re-aligned", 1, 10**9)
    max_gyro_gap_s: float = param(0.1, "gyro gap that forces a re-alignment", 1e-6, 1e6, unit="s")
    covariance_period_s: float = param(0.05, "longest interval between covariance propagations", 1e-6, 1e6,
                                       unit="s")
    max_sync_wait_s: float = param(0.05, "longest a gyro sample waits for its encoder and INS-rate samples",
                                   1e-6, 1e6, unit="s")

    def __post_init__(self) -> None:
        finite("lat_deg", self.lat_deg)
        if abs(self.lat_deg) >= 90.0:
            raise ValueError(f"lat_deg must be within (-90, 90), got {self.lat_deg}")
        finite("height_m", self.height_m)
        try:
            vel = tuple(float(v) for v in self.velocity_n_m_s)
        except (TypeError, ValueError):
            raise ValueError(f"velocity_n_m_s must be 3 numbers, got {self.velocity_n_m_s!r}") from None
        if len(vel) != 3 or not all(math.isfinite(v) for v in vel):
            raise ValueError(f"velocity_n_m_s must be 3 finite numbers, got {self.velocity_n_m_s!r}")
        object.__setattr__(self, "velocity_n_m_s", vel)
        for name in ("gyro_arw_deg_rt_h", "gyro_bias_instability_deg_h", "roll_arw_deg_rt_h",
                     "roll_bias_instability_deg_h", "ins_roll_pitch_rms_deg", "ins_heading_rms_deg"):
            nonneg_finite(name, getattr(self, name))
        for name in ("gyro_bias_sigma_deg_h", "roll_bias_sigma_deg_h", "encoder_noise_deg",
                     "attitude_noise_floor_deg", "max_gyro_gap_s", "covariance_period_s",
                     "max_sync_wait_s"):
            positive(name, getattr(self, name))
        for name in ("gyro_bias_tau_s", "roll_bias_tau_s", "ins_attitude_tau_s"):
            positive(name, getattr(self, name), allow_inf=True)
        if not isinstance(self.ins_error_states, bool):
            raise ValueError(f"ins_error_states must be a bool, got {self.ins_error_states!r}")
        if self.ins_error_states:
            for name in ("ins_roll_pitch_rms_deg", "ins_heading_rms_deg"):
                if getattr(self, name) <= 0.0:
                    raise ValueError(f"{name} must be > 0 with ins_error_states (a zero-variance state "
                                     "makes P singular); use ins_error_states=False for a perfect INS")
        finite("gate_probability", self.gate_probability)
        if not 0.0 < self.gate_probability < 1.0:
            raise ValueError(f"gate_probability must be in (0, 1), got {self.gate_probability}")
        if not isinstance(self.max_consecutive_gated, int) or isinstance(self.max_consecutive_gated, bool) \
                or self.max_consecutive_gated < 1:
            raise ValueError(f"max_consecutive_gated must be an int >= 1, got {self.max_consecutive_gated!r}")

    @classmethod
    def from_values(cls, values: dict) -> GyroBiasEkfParams:
        """The parameters from a ``gyro_bias_ekf`` node's values (name -> value, as declared
        in :data:`PARAMS`); :class:`ParameterError` names the parameter refused."""
        return from_values(cls, {**values, "velocity_n_m_s": tuple(values["velocity_n_m_s"])})


PARAMS, DESCRIPTION = declaration(GyroBiasEkfNodeParams, GyroBiasEkfParams)
