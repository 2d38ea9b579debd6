"""Unit conversions used at the configuration edge of the sensor models.

Parameter dataclasses carry engineering units in their field names (``_deg_h``,
``_deg_rt_h``, ``_ug`` ...); each constant below converts one such unit to SI once, at
construction. Inside the models everything is rad, s, m/s².
"""
from __future__ import annotations

import math

#: Standard gravity [m/s²] used to convert µg (the accelerometer spec unit).
G0 = 9.80665

DEG = math.pi / 180.0
#: arc-second -> rad
ARCSEC = DEG / 3600.0
#: °/h -> rad/s
DEG_H = DEG / 3600.0
#: °/√h (angle random walk) -> rad/√s
DEG_RT_H = DEG / 60.0
#: °/h/√h (rate random walk) -> rad/s/√s
DEG_H_RT_H = DEG_H / 60.0
#: µg -> m/s²
UG = 1e-6 * G0
#: µg/√Hz (white acceleration noise density) -> m/s²/√Hz = m/s/√s
UG_RT_HZ = UG
