"""Identification of a robot's geometry from measurements (see :mod:`.estimate`)."""

from ..exceptions import PoorFitError
from .estimate import fit, identify
from .options import FitOptions
from .outliers import OUTLIER_THRESHOLD, data_snooping
from .result import IdentificationResult, ResidualStats

__all__ = [
    "OUTLIER_THRESHOLD",
    "FitOptions",
    "IdentificationResult",
    "PoorFitError",
    "ResidualStats",
    "data_snooping",
    "fit",
    "identify",
]
