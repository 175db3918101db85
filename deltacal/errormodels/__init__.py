"""Error models: parameterisations of small deviations of a DeltaGeometry.

* ``classical``: perfect parallelograms, 24 parameters (Vischer and Clavel; Bai model 24).
* ``bai42``: Bai's model 42 (Eq. 6-9); ``bai18``, ``bai36``, ``bai32``: its reductions for
  distance measurements (Eq. 11, §3.2); ``bai24``: model 24 with Bai's names.
* ``complete``: Savoure's complete model, 51 parameters (Eq. 12-22).
* ``printer``: the complete model of a linear Delta printer (54); ``klipper``: the values the
  firmware holds, as deviations of the printer's full geometry (13).
"""

from __future__ import annotations

import importlib

from .bai import DISTANCE_GAUGE, MODEL32_REMOVED, BaiModel
from .base import ErrorModel, SubModel
from .classical import ClassicalModel
from .complete import CompleteModel

MODEL_NAMES = ("classical", "bai42", "complete", "bai24", "bai18", "bai36", "bai32")
#: The models of a linear Delta printer (a prismatic chain), defined in the printer's wing: name ->
#: (module, class). Imported on first use, so the engine never imports the wing.
_PRINTER_MODELS = {
    "printer": ("deltacal.printer.identification.errormodels", "PrinterModel"),
    "klipper": ("deltacal.printer.identification.errormodels", "FirmwareErrorModel"),
}
PRINTER_MODEL_NAMES = tuple(_PRINTER_MODELS)


def get_model(name: str) -> ErrorModel:
    """The error model of a name in :data:`MODEL_NAMES`."""
    if name == "classical":
        return ClassicalModel()
    if name == "complete":
        return CompleteModel()
    if name in _PRINTER_MODELS:
        module, cls = _PRINTER_MODELS[name]
        model_class: type[ErrorModel] = getattr(importlib.import_module(module), cls)
        return model_class()
    if name == "bai42":
        return BaiModel(orientation=True)
    if name == "bai24":
        return BaiModel(orientation=False)
    model: ErrorModel
    if name == "bai18":
        model = BaiModel(orientation=False).without(DISTANCE_GAUGE, "bai18")
    elif name == "bai36":
        model = BaiModel(orientation=True).without(DISTANCE_GAUGE, "bai36")
    elif name == "bai32":
        model = BaiModel(orientation=True).without(DISTANCE_GAUGE + MODEL32_REMOVED, "bai32")
    else:
        known = ", ".join(MODEL_NAMES + PRINTER_MODEL_NAMES)
        raise ValueError(f"unknown model {name!r}; choose one of {known}")
    model.rigid_motion_free = True  # Bai's Eq. 11 gauge
    return model


__all__ = [
    "MODEL_NAMES",
    "PRINTER_MODEL_NAMES",
    "BaiModel",
    "ClassicalModel",
    "CompleteModel",
    "ErrorModel",
    "SubModel",
    "get_model",
]
