"""The ``platform_servo`` node's parameters and --help text, declared once in
:class:`PlatformServoNodeParams`. The mapping to the core's parameters is
:meth:`.platform_servo.PlatformServoParams.from_values`.
"""
from __future__ import annotations

from dataclasses import dataclass

from gimbal_kinematics.params.table import CLOCK_JUMP_ALIASES, SHARED, CommandingParams, declaration, param, same_as

INF = float("inf")


@dataclass(frozen=True)
class PlatformServoNodeParams(CommandingParams):
    """Paper 3 four-gimbal platform servo: four PID loops (azimuth, inner roll, pitch, outer roll) on the emulated
    gyro pickoffs resolved through the gimbal angles (eq. 1), outer roll holding the inner roll at null,
    bidirectional azimuth modulation at +-1.2 deg/s with the integrator preset at reversals. Publishes
    /platform/voltage_cmd for each step.
    """

    sim_rate_hz: float = param(1000.0, "lockstep rate; one command per step. In free timing: the platform gyro's "
        "nominal rate (the drop count)", 1.0, 100000.0, unit="Hz")
    max_input_age_s: float = param(0.1, "free timing: the newest resolver sample may be this much older than the "
        "gyro sample; older (or none): the command is zeroed, counted", 1e-4, 100.0, unit="s")
    diagnostics_period_s: float = same_as(SHARED["diagnostics_period_s"])
    imu_rate_hz: float = param(1000.0, "platform gyro rate = the control rate (paper 3: 1 kHz); divides sim_rate_hz",
        1e-3, 100000.0, unit="Hz")
    resolver_rate_hz: float = param(1000.0, "gimbal resolver rate; divides sim_rate_hz", 1e-3, 100000.0, unit="Hz")
    lat_deg: float = param(45.0, "site latitude for the earth-rate part of the command", -89.999, 89.999, unit="deg")
    rotation: str = param("bidirectional", "azimuth modulation: bidirectional (out through sweep_deg and back) or "
        "off (hold phi_z = 0)", choices=("bidirectional", "off"))
    rate_deg_s: float = param(1.2, "modulation rate (paper 3: 1.2)", 1e-6, 1000.0, unit="deg/s")
    sweep_deg: float = param(360.0, "sweep of one leg between reversals", 1e-6, 1e6, unit="deg")
    reversal_time_s: float = param(0.0, "duration of a reversal ramp (0: instantaneous)", 0.0, 1e6, unit="s")
    azimuth_bandwidth_hz: float = param(12.0, "azimuth loop pole-placement bandwidth (triple pole)",
        1e-3, 10000.0, unit="Hz")
    level_bandwidth_hz: float = param(12.0, "inner-roll and pitch loop bandwidth (triple pole)",
        1e-3, 10000.0, unit="Hz")
    outer_roll_bandwidth_hz: float = param(4.0, "outer-roll null loop bandwidth (triple pole)",
        1e-3, 10000.0, unit="Hz")
    outer_roll_derivative_tau_s: float = param(0.005, "low-pass time constant of the outer-roll D term",
        0.0, 10.0, unit="s")
    preset_integrator: bool = param(True, "preset the azimuth integrator at each reversal (paper 3)")
    friction_coulomb_nm: float = param(0.01, "azimuth bearing Coulomb friction for the preset", 0.0, INF, unit="N*m")
    friction_viscous_nm_s_rad: float = param(5e-4, "azimuth bearing viscous friction for the preset",
        0.0, INF, unit="N*m*s/rad")
    friction_smoothing_rad_s: float = param(0.01, "rate scale of the Coulomb tanh for the preset",
        1e-9, INF, unit="rad/s")
    drift_deg_h: tuple[float, ...] = param((0.0, 0.0, 0.0), "platform drift estimate (the negative of the gyro rate "
        "bias, as platform_alignment's ~/gyro_drift) subtracted from the command, platform x, y, z", unit="deg/h")
    command_source: str = param("internal", "level command rate: internal (earth rate at lat_deg minus drift_deg_h) "
        "or navigator (the platform_navigator's ~/command_rate, NED; lat_deg and drift_deg_h then serve only before "
        "its first command and when it is stale)", choices=("internal", "navigator"))
    command_max_age_s: float = param(0.5, "navigator: a command older than this at a tick gives way to the internal "
        "one, counted", 1e-6, INF, unit="s")
    max_gap_s: float = param(0.05, "a longer gap between gyro samples restarts the pickoff integration",
        1e-6, INF, unit="s")
    clock_jump_s: float = param(1.0, "a stamp this far before the last one restarts the servo (bag loop)",
        1e-6, INF, unit="s", aliases=CLOCK_JUMP_ALIASES)
    gyro_source: str = param("rate_triad", "what the loops close on: rate_triad (the platform gyro triad on "
        "/platform/imu, its rates integrated into emulated pickoffs) or dtg (paper 3's two DTGs: their pickoff angles "
        "on /platform/dtg_pickoffs, the command rate put into them as torquer currents on ~/torquer_current, "
        "JointState efforts [A], published every step; the gains placed in discrete time at imu_rate_hz, the "
        "pickoffs' read rate)", choices=("rate_triad", "dtg"))
    dtg_torquer_scale_deg_h_ma: float = param(72.0, "dtg: the torquers' nominal scale factor the processor converts "
        "the command rate with (paper 3's own numbers: 4320 deg/h at 60 mA)", 1e-9, INF, unit="deg/h/mA")
    dtg_max_current_ma: float = param(200.0, "dtg: the torquing electronics' range +-; a larger command is clipped",
        1e-9, INF, unit="mA")
    diagnostics_every_steps: int = param(1, "publish ~/control_error and ~/modulation every N control ticks",
        1, 10**6)
    modulation_next: bool = param(False, "publish on ~/modulation_next, at each gyro step, phi_z and its rate at the "
        "next gyro step, stamped with that step (the schedule is a function of time): what platform_navigator's "
        "azimuth_source servo reads in lockstep. Its first sample has none, so the servo's first step waits for no "
        "navigator command")


PARAMS, DESCRIPTION = declaration(PlatformServoNodeParams)
