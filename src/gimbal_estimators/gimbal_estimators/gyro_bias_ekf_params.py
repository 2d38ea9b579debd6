"""Parameters of the gyro-bias EKF (:mod:`.gyro_bias_ekf`), readable without ROS: the core's
frozen :class:`GyroBiasEkfParams`, the ``gyro_bias_ekf`` node's parameter table
:data:`PARAMS` (the core's fields plus the node's own: lockstep rate, progress and
diagnostics periods) and :meth:`GyroBiasEkfParams.from_values`, the one mapping from the
node's values to the core's parameters, which the node and the no-ROS core loop both use.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, fields

from gimbal_kinematics.params import CLOCK_JUMP_ALIASES, TIMING_PARAM, Param, ParameterError
from gimbal_kinematics.validate import finite, nonneg_finite, positive


@dataclass(frozen=True)
class GyroBiasEkfParams:
    """Filter parameters (engineering units at this edge; validated, immutable).

    Site: ``lat_deg`` [°], ``height_m`` [m], ``velocity_n_m_s`` NED velocity [m/s] (zero for
    a land vehicle at rest; sets the transport rate).

    Gimbal gyro (q, r axes): ``gyro_arw_deg_rt_h`` [°/√h]; lumped bias prior 1σ
    ``gyro_bias_sigma_deg_h`` [°/h]; ``gyro_bias_instability_deg_h`` [°/h] and
    ``gyro_bias_tau_s`` [s] set the random-walk PSD 2σ²/τ (τ = inf: random constant).

    Roll channel (the INS-rate part of eq. 4): ``roll_arw_deg_rt_h``,
    ``roll_bias_sigma_deg_h``, ``roll_bias_instability_deg_h``, ``roll_bias_tau_s``, from
    the INS gyro specification.

    INS attitude: ``ins_roll_pitch_rms_deg``, ``ins_heading_rms_deg`` [°], correlation time
    ``ins_attitude_tau_s`` [s] (inf = constant per run); ``ins_error_states`` chooses the
    augmented (default) or paper 1's white-noise treatment. ``encoder_noise_deg`` [°]
    (each of the three encoders); ``attitude_noise_floor_deg`` [°] isotropic white noise
    added to R for unmodelled residuals (module docstring, "Synchronisation").

    Robustness: ``gate_probability`` of the chi-square innovation gate (3 dof);
    ``max_consecutive_gated`` gated updates in a row before the attitude is re-aligned;
    ``clock_jump_s`` [s] backward stamp step that counts as a clock jump (reset), smaller
    ones are out-of-order samples; ``max_gyro_gap_s`` [s] gyro gap that forces a
    re-alignment; ``covariance_period_s`` [s] longest interval between covariance
    propagations; ``max_sync_wait_s`` [s] longest a gyro sample waits for the encoder and
    INS-rate samples it needs.
    """

    lat_deg: float = 0.0
    height_m: float = 0.0
    velocity_n_m_s: tuple[float, float, float] = (0.0, 0.0, 0.0)
    gyro_arw_deg_rt_h: float = 0.15
    gyro_bias_sigma_deg_h: float = 104.4
    gyro_bias_instability_deg_h: float = 30.0
    gyro_bias_tau_s: float = 100.0
    roll_arw_deg_rt_h: float = 0.1
    roll_bias_sigma_deg_h: float = 1.42
    roll_bias_instability_deg_h: float = 1.0
    roll_bias_tau_s: float = 60.0
    ins_roll_pitch_rms_deg: float = 0.05
    ins_heading_rms_deg: float = 0.2
    ins_attitude_tau_s: float = 300.0
    ins_error_states: bool = True
    encoder_noise_deg: float = 0.05
    attitude_noise_floor_deg: float = 0.02
    gate_probability: float = 0.9999
    max_consecutive_gated: int = 100
    clock_jump_s: float = 0.5
    max_gyro_gap_s: float = 0.1
    covariance_period_s: float = 0.05
    max_sync_wait_s: float = 0.05

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
                     "attitude_noise_floor_deg", "clock_jump_s", "max_gyro_gap_s", "covariance_period_s",
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
    def field_names(cls) -> tuple[str, ...]:
        return tuple(f.name for f in fields(cls))

    @classmethod
    def from_values(cls, values: dict) -> GyroBiasEkfParams:
        """The parameters from a ``gyro_bias_ekf`` node's values (name -> value, as declared
        in :data:`PARAMS`); :class:`ParameterError` names the parameter refused."""
        kw = {name: values[name] for name in cls.field_names()}
        kw["velocity_n_m_s"] = tuple(values["velocity_n_m_s"])
        try:
            return cls(**kw)
        except ValueError as exc:
            raise ParameterError(f"parameter {exc}") from exc


DESCRIPTION = (
    "Paper 1 gyro-bias EKF: propagates the inner-gimbal attitude C(n,m) with the two-axis gimbal "
    "gyro (roll rate reconstructed from the INS and encoders, earth and transport rate included) and "
    "fuses the attitude built from the INS Euler angles and the encoders. Publishes the gyro-bias "
    "estimate and its 1-sigma (~/bias, ~/bias_sigma), the attitude estimate (~/attitude) and health "
    "(/diagnostics)."
)

_EKF_DEFAULTS = GyroBiasEkfParams()
PARAMS = (
    TIMING_PARAM,
    Param("sim_rate_hz", 1000.0, "lockstep rate [Hz]: maps gyro stamps to steps for ~/progress", 1.0, 100000.0),
    Param("progress_every_steps", 10, "report the next step needed on ~/progress every N gyro steps", 1, 10**6),
    Param("diagnostics_period_s", 1.0, "health on /diagnostics every this much sim time [s]", 1e-3, 1e6),
    Param("nis_window", 100, "measurement updates in the NIS window on /diagnostics (free timing)", 1, 10**6),
    Param("lat_deg", _EKF_DEFAULTS.lat_deg, "site latitude [deg] (earth rate, transport rate)", -89.999, 89.999),
    Param("height_m", _EKF_DEFAULTS.height_m, "site height [m]", -1e4, 1e5),
    Param("velocity_n_m_s", list(_EKF_DEFAULTS.velocity_n_m_s), "NED velocity [m/s] for the transport rate"),
    Param("gyro_arw_deg_rt_h", _EKF_DEFAULTS.gyro_arw_deg_rt_h, "gimbal gyro angle random walk [deg/sqrt(h)]", 0.0, 1e4),
    Param("gyro_bias_sigma_deg_h", _EKF_DEFAULTS.gyro_bias_sigma_deg_h,
          "prior 1-sigma of the lumped gimbal gyro bias [deg/h]", 1e-6, 1e6),
    Param("gyro_bias_instability_deg_h", _EKF_DEFAULTS.gyro_bias_instability_deg_h,
          "gimbal gyro Gauss-Markov bias instability RMS [deg/h] (sets the bias random walk)", 0.0, 1e6),
    Param("gyro_bias_tau_s", _EKF_DEFAULTS.gyro_bias_tau_s, "gimbal gyro bias correlation time [s]", 1e-3, 1e9),
    Param("roll_arw_deg_rt_h", _EKF_DEFAULTS.roll_arw_deg_rt_h, "INS gyro angle random walk [deg/sqrt(h)]", 0.0, 1e4),
    Param("roll_bias_sigma_deg_h", _EKF_DEFAULTS.roll_bias_sigma_deg_h,
          "prior 1-sigma of the roll-channel (INS gyro) bias [deg/h]", 1e-6, 1e6),
    Param("roll_bias_instability_deg_h", _EKF_DEFAULTS.roll_bias_instability_deg_h,
          "INS gyro Gauss-Markov bias instability RMS [deg/h]", 0.0, 1e6),
    Param("roll_bias_tau_s", _EKF_DEFAULTS.roll_bias_tau_s, "INS gyro bias correlation time [s]", 1e-3, 1e9),
    Param("ins_roll_pitch_rms_deg", _EKF_DEFAULTS.ins_roll_pitch_rms_deg, "INS roll/pitch error RMS [deg]", 0.0, 90.0),
    Param("ins_heading_rms_deg", _EKF_DEFAULTS.ins_heading_rms_deg, "INS heading error RMS [deg]", 0.0, 180.0),
    Param("ins_attitude_tau_s", _EKF_DEFAULTS.ins_attitude_tau_s,
          "INS attitude error correlation time [s] (with ins_error_states)", 1e-6, 1e9),
    Param("ins_error_states", _EKF_DEFAULTS.ins_error_states,
          "model the INS attitude errors as Gauss-Markov states (false: paper 1's white measurement noise)"),
    Param("encoder_noise_deg", _EKF_DEFAULTS.encoder_noise_deg, "encoder noise 1-sigma [deg]", 1e-9, 10.0),
    Param("attitude_noise_floor_deg", _EKF_DEFAULTS.attitude_noise_floor_deg,
          "isotropic white attitude noise added to R for unmodelled residuals [deg]", 1e-9, 10.0),
    Param("gate_probability", _EKF_DEFAULTS.gate_probability,
          "chi-square innovation gate probability (3 dof) [-]", 1e-6, 0.999999999),
    Param("max_consecutive_gated", _EKF_DEFAULTS.max_consecutive_gated,
          "gated updates in a row before the attitude is re-aligned", 1, 10**9),
    Param("clock_jump_s", _EKF_DEFAULTS.clock_jump_s, "a stamp this far [s] behind resets the filter (bag loop)",
          1e-9, 1e9, aliases=CLOCK_JUMP_ALIASES),
    Param("max_gyro_gap_s", _EKF_DEFAULTS.max_gyro_gap_s, "gyro gap [s] that forces a re-alignment", 1e-6, 1e6),
    Param("covariance_period_s", _EKF_DEFAULTS.covariance_period_s,
          "longest interval between covariance propagations [s]", 1e-6, 1e6),
    Param("max_sync_wait_s", _EKF_DEFAULTS.max_sync_wait_s,
          "longest a gyro sample waits for its encoder and INS-rate samples [s]", 1e-6, 1e6),
)
