"""Identification of a robot's geometry from measurements (see :mod:`.estimate`)."""

from .estimate import identify
from .outliers import OUTLIER_THRESHOLD, data_snooping
from .result import IdentificationResult, ResidualStats

__all__ = ["OUTLIER_THRESHOLD", "IdentificationResult", "ResidualStats", "data_snooping", "identify"]
