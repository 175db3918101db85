"""Controllers: a robot controller's own model, corrected targets for it, and the fit of its values.

* :mod:`.model`: :class:`Controller`, the classical Delta with per-limb values that an industrial
  controller, a PLC's Delta transform or a firmware runs (conventions, "Controllers").
* :mod:`.targets`: :func:`corrected_targets`, the targets to send it so the real TCP lands on the
  targets (exact compensation, then the controller's forward model of those readings; a printer's
  only where its calibration holds, :func:`weighted_targets` with each correction's weight).
* :mod:`.limits`: :class:`CommandLimits`, the limits a controller puts on its commands, and
  :class:`RefusedCommands`, those of a file it refuses.
* :mod:`.fit`: :func:`fit_controller`, the joint offsets or per-limb values that best represent an
  identified robot over a workspace.
"""

from .fit import FIT_KINDS, ControllerFit, fit_controller
from .limits import CommandLimits, RefusedCommands
from .model import Controller
from .targets import CommandModel, CorrectedTargets, WeightedTargets, corrected_targets, weighted_targets

__all__ = ["FIT_KINDS", "CommandLimits", "CommandModel", "Controller", "ControllerFit", "CorrectedTargets",
           "RefusedCommands", "WeightedTargets", "corrected_targets", "fit_controller", "weighted_targets"]
