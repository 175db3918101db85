import numpy as np
import pytest
from deltacal.controller import corrected_targets
from deltacal.printer.firmware.klipper.rotary_controller import KlipperRotaryController
from tests.test_rotary_printer_route import route, recalibrated, _layers, VOLUME  # noqa: F401
from tests import test_rotary_reanchor as R


def test_route_figs(route, recalibrated):
    printer, k2 = route["printer"], recalibrated["k2"]
    ours = _layers(printer, k2, corrected_targets(recalibrated["anchored"], KlipperRotaryController(k2), VOLUME).commands)
    own = _layers(printer, k2, VOLUME)
    recorded = _layers(printer, route["k"], corrected_targets(recalibrated["same"], route["controller"], VOLUME).commands)
    print("\nROUTE ours", np.round(ours, 3), "own", np.round(own, 3), "recorded", np.round(recorded, 3))


@pytest.mark.parametrize(("label", "tolerances", "seed"), R.PRINTERS)
def test_reanchor_figs(label, tolerances, seed):
    L = R._reanchored_layers(tolerances, seed)
    print(f"\nREANCHOR {label} {seed}:", " / ".join(" ".join(f"{v:.3f}" for v in L[k]) for k in ("own", "reanchored", "recorded")))
