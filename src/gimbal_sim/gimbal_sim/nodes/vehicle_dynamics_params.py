"""The ``vehicle_dynamics`` node's parameter table and --help text, readable without ROS (the
node declares them; the config generator and the scenario checks read them). The mapping to
the core's config is :meth:`..world.vehicle.VehicleConfig.from_values`.
"""
from __future__ import annotations

from gimbal_kinematics.gimbal.gimbal_params import GIMBAL_MODELS
from gimbal_kinematics.params import COMMAND_INTERFACE_PARAM, ROS2_CONTROL_TOPIC_PARAM, Param

from ..world.plant.motion_profiles import PROFILE_NAMES
from ..world.vehicle import PLANTS

DESCRIPTION = (
    "Simulated host vehicle and gimbal/platform dynamics. Owns /clock and publishes the "
    "truth topics every step; in lockstep it integrates step k -> k+1 only after the "
    "command stamped k has arrived."
)

PARAMS = (
    Param("profile", "paper1_land_vehicle", "host motion profile", choices=PROFILE_NAMES),
    Param("profile_params", "{}", "profile parameters as a YAML mapping, e.g. "
          "'{lat_deg: 39.9}' (docs/interfaces.md: host motion profiles)"),
    Param("plant", "two_axis_gimbal", "plant carried by the host", choices=PLANTS),
    Param("gimbal_model", "paper1", "two-axis gimbal mass properties, friction and torque limits: paper1 "
          "(~10 kg payload) or uav_small (paper 2's ~1 kg UAV gimbal)", choices=tuple(GIMBAL_MODELS)),
    Param("sim_rate_hz", 1000.0, "simulation (lockstep) rate [Hz]", 1.0, 100000.0),
    Param("duration_s", 120.0, "simulated duration [s]; the node stops stepping there", 1e-3, 1e7),
    Param("earth_rate", True, "include the earth rate in inertial rates (false: NED is inertial)"),
    Param("initial_gimbal_deg", [0.0, 0.0], "initial gimbal azimuth psi_m and elevation theta_m [deg]"),
    Param("initial_platform_deg", [0.0, 0.0, 0.0, 0.0],
          "initial platform loop angles azimuth, inner roll, pitch, outer roll [deg]"),
    Param("timing", "lockstep", "lockstep: step on commands/events; realtime: pace to the wall clock",
          choices=("lockstep", "realtime"), aliases=("mode",)),
    Param("real_time_factor", 1.0, "realtime timing: simulated seconds per wall-clock second [s/s] (1: real time; "
          "below 1 slows the wall clock down, giving a loaded machine headroom; stamps stay sim time)",
          0.01, 10.0),
    Param("controlled", False, "a controller commands the plant (lockstep waits for its command)"),
    COMMAND_INTERFACE_PARAM,
    ROS2_CONTROL_TOPIC_PARAM,
    Param("wait_for_subscribers", 1, "matched subscriptions each truth topic needs before step 0", 0, 1000),
    Param("subscriber_counts", [], "per-topic overrides of wait_for_subscribers, as 'topic=count' entries",
          array_type="string_array"),
    Param("topic_subscriber_counts", [], "before step 0, wait until the ROS graph shows this many subscriptions "
          "on topics the vehicle does not publish, as 'topic=count' entries (realtime runs: free-timing nodes "
          "that report no readiness, e.g. '/gimbal/imu=3')", array_type="string_array"),
    Param("pace_topics", [], "rosgraph_msgs/Clock progress topics (time of the next step the reader "
          "needs) of readers to wait for and not outrun",
          array_type="string_array"),
    Param("pace_window_steps", 50, "steps the vehicle may run ahead of the slowest pace topic", 1, 10**6),
    Param("exit_at_end", False, "exit the process after the last step"),
    Param("platform_substeps", 4, "four_gimbal_platform: RK4 substeps per step of the DC-motor loops (electrical "
          "time constant ~1 ms: keep a substep <= 2 ms at low sim_rate_hz)", 1, 10**4),
    Param("position_truth_every_steps", 0, "publish the host's true position (/truth/host/fix, NavSatFix) and "
          "NED velocity (/truth/host/velocity, m/s) every N steps; 0: not published", 0, 10**9),
)
