"""The engineering units of the YAML/CLI edge, in SI: one constant per unit, for every package.

Parameters carry their unit in the name (``bias_deg_h``, ``arw_deg_rt_h``, ``noise_ug_rt_hz``
...); multiplying by the constant of that unit gives SI once, at construction
(``bias_deg_h * DEG_H`` is rad/s), and dividing by it turns an SI figure back for a report
(``error / ARCSEC`` is arc-seconds). Inside the models everything is rad, s, m, m/s².
"""
from __future__ import annotations

import math

#: Standard gravity [m/s²], the g of the accelerometer units.
G0 = 9.80665

#: degree -> rad
DEG = math.pi / 180.0
#: arc-minute -> rad
ARCMIN = DEG / 60.0
#: arc-second -> rad
ARCSEC = DEG / 3600.0
#: °/h -> rad/s (numerically one arc-second: 1 °/h = 1 ″/s)
DEG_H = DEG / 3600.0
#: °/√h (angle random walk) -> rad/√s
DEG_RT_H = DEG / 60.0
#: °/h/√h (rate random walk) -> rad/s/√s
DEG_H_RT_H = DEG_H / 60.0
#: rad -> arc-seconds, and rad/s -> °/h: the reciprocal of :data:`ARCSEC`, as a factor
ARCSEC_PER_RAD = math.degrees(1.0) * 3600.0
#: rad/s -> °/h, the reciprocal of :data:`DEG_H`, as a factor
DEG_H_PER_RAD_S = ARCSEC_PER_RAD

#: µrad -> rad
URAD = 1e-6
#: ppm (parts per million: a scale-factor error or asymmetry) -> dimensionless
PPM = 1e-6

#: µg -> m/s²
UG = 9.80665e-6
#: µg -> m/s² as 1e-6 · G0, one ulp below :data:`UG`: the sensor models' conversion, kept
#: apart so that the simulated accelerometers record the same data to the bit
UG_G0 = 1e-6 * G0
#: µg/√Hz (white acceleration noise density) -> m/s²/√Hz = m/s/√s, the sensor models'
UG_RT_HZ = UG_G0

#: nautical mile [m]
NMI_M = 1852.0
