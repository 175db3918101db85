"""Error models: parameterisations of small deviations of a DeltaGeometry.

* ``classical``: perfect parallelograms, 24 parameters (Vischer and Clavel; Bai model 24).
* ``bai42``: Bai's model 42 (Eq. 6-9); ``bai18``, ``bai36``, ``bai32``: its reductions for
  distance measurements (Eq. 11, §3.2); ``bai24``: model 24 with Bai's names.
* ``complete``: Savoure's complete model, 51 parameters (Eq. 12-22).
* ``printer``: the complete model of a linear Delta printer (54); ``klipper``: the values the
  firmware holds, as deviations of the printer's full geometry (13); ``rotary_printer``: the complete
  model of a rotary Delta printer (51, and each arm's step scale: 54).
"""

from __future__ import annotations

import importlib
from collections.abc import Callable

from .bai import DISTANCE_GAUGE, MODEL32_REMOVED, BaiModel
from .base import ErrorModel, SubModel
from .classical import ClassicalModel
from .complete import CompleteModel


def _distance_model(orientation: bool, removed: list[str], name: str) -> ErrorModel:
    """Bai's model for distance measurements: without the gauge (Eq. 11), rigid motion left free."""
    model = BaiModel(orientation=orientation).without(removed, name)
    model.rigid_motion_free = True  # Bai's Eq. 11 gauge
    return model


#: The rotary Delta's error models: name -> the model, made anew.
_MODELS: dict[str, Callable[[], ErrorModel]] = {
    "classical": ClassicalModel,
    "bai42": lambda: BaiModel(orientation=True),
    "complete": CompleteModel,
    "bai24": lambda: BaiModel(orientation=False),
    "bai18": lambda: _distance_model(False, DISTANCE_GAUGE, "bai18"),
    "bai36": lambda: _distance_model(True, DISTANCE_GAUGE, "bai36"),
    "bai32": lambda: _distance_model(True, DISTANCE_GAUGE + MODEL32_REMOVED, "bai32"),
}
#: The names of the rotary Delta's models (:func:`get_model`).
MODEL_NAMES = tuple(_MODELS)
#: The models of a Delta printer (linear; rotary: ``rotary_printer``), defined in its wing: name ->
#: (module, class). Imported on first use, so the engine never imports the wing.
_PRINTER_MODELS = {
    "printer": ("deltacal.printer.identification.errormodels", "PrinterModel"),
    "klipper": ("deltacal.printer.identification.errormodels", "FirmwareErrorModel"),
    "rotary_printer": ("deltacal.printer.identification.errormodels", "RotaryPrinterModel"),
}
PRINTER_MODEL_NAMES = tuple(_PRINTER_MODELS)


def get_model(name: str) -> ErrorModel:
    """The error model of a name in :data:`MODEL_NAMES` or :data:`PRINTER_MODEL_NAMES`.

    Raises:
        ValueError: an unknown name, naming the models.
    """
    if name in _PRINTER_MODELS:
        module, cls = _PRINTER_MODELS[name]
        model_class: type[ErrorModel] = getattr(importlib.import_module(module), cls)
        return model_class()
    if name not in _MODELS:
        known = ", ".join(MODEL_NAMES + PRINTER_MODEL_NAMES)
        raise ValueError(f"unknown model {name!r}; choose one of {known}")
    return _MODELS[name]()


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
