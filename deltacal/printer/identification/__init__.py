"""A printer's identification from its measurements.

The fit (:mod:`.fit`: :func:`~.fit.identify_printer`), its error models (:mod:`.errormodels`), the
tolerances' scale its evidence chooses (:mod:`.evidence`) and the measurements that do not fit the
others (:mod:`.outliers`).
"""

from .fit import PrinterFitOptions, PrinterMeasurements, identify_printer

__all__ = ["PrinterFitOptions", "PrinterMeasurements", "identify_printer"]
