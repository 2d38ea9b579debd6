"""The live view's scene description: what it needs of a run besides the messages.

The run's graph (``gimbal_sim.graph.live_scene``) makes it from the scenario and writes it
beside the bag (:data:`SCENE_FILE`), before any node starts; the recorder and ``gimbal-bag
play`` read it back and hand it to the live view they build. ROS-free: the no-ROS engine
writes it too.
"""
from __future__ import annotations

import json
from dataclasses import asdict, dataclass, fields as dataclass_fields
from pathlib import Path

#: The scene description beside a run's bag, written by the run's graph.
SCENE_FILE = "live_scene.json"
_DEFAULTS = "the live view draws no geo target and takes heading 0 deg, latitude 0 deg, the earth turning"


@dataclass(frozen=True)
class SceneConfig:
    """What the live view needs besides the messages, from the run's scenario: the geo target,
    NED from the vehicle [m] (None: no geo-pointing), the heading the platform alignment
    assumes [rad], the site's latitude [rad] and whether the earth turns (the LOS drift's
    inertial frame, as ``reports.common.vehicle_site`` reads them)."""

    target_n: tuple[float, float, float] | None = None
    platform_heading_rad: float = 0.0
    site_lat_rad: float = 0.0
    earth_rate: bool = True

    def to_json(self) -> str:
        return json.dumps(asdict(self), indent=2) + "\n"

    @classmethod
    def from_json(cls, text: str) -> SceneConfig:
        """Raises ValueError (or TypeError) on text that is not a scene description."""
        fields = json.loads(text)
        if not isinstance(fields, dict) or set(fields) != {f.name for f in dataclass_fields(cls)}:
            raise ValueError(f"not a scene description: {str(fields)[:80]}")
        target = fields["target_n"]
        return cls(None if target is None else tuple(float(c) for c in target), float(fields["platform_heading_rad"]),
                   float(fields["site_lat_rad"]), bool(fields["earth_rate"]))

    @classmethod
    def beside(cls, bag_dir: Path) -> tuple[SceneConfig, str | None]:
        """The scene description written beside the bag in ``bag_dir``, and why the defaults
        were taken instead (no such file: a bag recorded elsewhere; a damaged one), or None."""
        path = Path(bag_dir) / SCENE_FILE
        try:
            return cls.from_json(path.read_text()), None
        except FileNotFoundError:
            return cls(), f"no {SCENE_FILE} beside the bag: {_DEFAULTS}"
        except (OSError, ValueError, TypeError, KeyError) as exc:
            return cls(), f"{path} unreadable ({exc}): {_DEFAULTS}"
