"""Identification of a robot's geometry from measurements (see :mod:`.estimate`)."""

from .estimate import fit, identify
from .outliers import OUTLIER_THRESHOLD, data_snooping
from .quality import PoorFitError
from .result import IdentificationResult, ResidualStats

__all__ = [
    "OUTLIER_THRESHOLD",
    "IdentificationResult",
    "PoorFitError",
    "ResidualStats",
    "data_snooping",
    "fit",
    "identify",
]
