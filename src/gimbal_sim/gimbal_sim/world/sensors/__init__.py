"""Pure-Python sensor error models for the simulator (no rclpy; nodes wrap them).

Every model takes its own seeded ``numpy.random.Generator``; parameters are frozen
dataclasses with unit-suffixed fields, converted to SI once at construction.
"""
from .accelerometer import PAPER3_ACCELEROMETER, AccelerometerModel, AccelerometerParams
from .encoder import PAPER1_ENCODER, PAPER2_ENCODER, EncoderModel, EncoderParams
from .flexure import FlexureParams, ShipFlexureTruth
from .hull_flexure import NATO_SEA_STATES, HullFlexure, HullParams
from .free_gyro_sensor import (
    FREE_GYRO_TRIAD,
    FreeGyroSample,
    FreeGyroSensor,
    FreeGyroSensorParams,
)
from .gyro import (
    LGU1_GYRO,
    LGU2_GYRO,
    PAPER1_GIMBAL_GYRO,
    PAPER1_INS_GYRO,
    PAPER3_GYRO,
    GyroModel,
    GyroParams,
)
from .inertial_core import ErrorSpecSI, InertialErrorCore
from .ins import InsModel, InsParams
from .lgu import LguPair, lgu2_rate
from .markov import FirstOrderGaussMarkov, SecondOrderGaussMarkov, gm1_coefficients, gm2_discrete

__all__ = [
    "AccelerometerModel",
    "AccelerometerParams",
    "EncoderModel",
    "EncoderParams",
    "ErrorSpecSI",
    "FirstOrderGaussMarkov",
    "FlexureParams",
    "FREE_GYRO_TRIAD",
    "FreeGyroSample",
    "FreeGyroSensor",
    "FreeGyroSensorParams",
    "GyroModel",
    "GyroParams",
    "HullFlexure",
    "HullParams",
    "InertialErrorCore",
    "InsModel",
    "InsParams",
    "LGU1_GYRO",
    "LGU2_GYRO",
    "LguPair",
    "NATO_SEA_STATES",
    "PAPER1_ENCODER",
    "PAPER1_GIMBAL_GYRO",
    "PAPER1_INS_GYRO",
    "PAPER2_ENCODER",
    "PAPER3_ACCELEROMETER",
    "PAPER3_GYRO",
    "SecondOrderGaussMarkov",
    "ShipFlexureTruth",
    "gm1_coefficients",
    "gm2_discrete",
    "lgu2_rate",
]
