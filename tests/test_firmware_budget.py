"""What each firmware's best values leave per error source (``error_budget`` over the firmware interface).

On the same seeded kit printer the three firmwares' budgets behave as Klipper's: the sources their
models hold (endstops, rods' common lengths, step distances) leave nothing, those none holds (a
tower's lean, rods of a pair that differ) leave something, and removing a held source leaves the
whole printer's leftover as it was. On a printer whose only error is one the model holds (a tower
turned about the centre: Klipper's ``angle``, Marlin's ``M665 X Y Z``, RRF's ``M665 X Y``) nothing
is left.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from deltacal.geometry import Workspace
from deltacal.printer.files.robot_file import load_printer
from deltacal.printer.firmware.budget import BED_TILT, ErrorSource, error_budget, error_groups
from deltacal.printer.firmware.klipper.firmware import KLIPPER
from deltacal.printer.firmware.marlin.firmware import MARLIN
from deltacal.printer.firmware.rrf.firmware import RRF_FIRMWARE
from deltacal.printer.simulation import random_true_printer, typical_kit
from deltacal.rotations import rotation_from_vector

KOSSEL = load_printer(Path(__file__).resolve().parents[1] / "deltacal" / "models" / "kossel.toml")
WORKSPACE = Workspace(radius=92.0, height=100.0, top_z=100.0)
FIRMWARES = [KLIPPER, MARLIN, RRF_FIRMWARE]
GROUPS = {"tower position", "tower lean", "endstops", "step distances", "ball positions", "rod lengths",
          "rods of a pair that differ", BED_TILT}


def _budget(firmware, errors, rotation=None, mode="alone"):
    rotation = np.eye(3) if rotation is None else rotation
    return error_budget(firmware, KOSSEL.geometry(), errors, rotation, np.zeros(3), firmware.nominal(KOSSEL),
                        KOSSEL.step_distance, WORKSPACE, mode=mode)


def _tower_a_moved(tangential: float) -> dict[str, float]:
    """Tower A's axis moved along the bed about the centre (a tower angle's error) [mm]."""
    point = KOSSEL.geometry().axis_point[0]
    shift = tangential * np.array([-point[1], point[0]]) / np.hypot(point[0], point[1])
    return {"limb1.axis_point.x": float(shift[0]), "limb1.axis_point.y": float(shift[1])}


def test_error_groups_split_the_rods_and_keep_every_error():
    made = random_true_printer(KOSSEL, np.random.default_rng(5), typical_kit())
    groups = error_groups(made.errors)
    assert set(groups) == GROUPS and groups[BED_TILT] == {}
    assert list(groups) == list(ErrorSource) and set(ErrorSource) == GROUPS  # the labels, in order
    rods = [n for n in made.errors if n.endswith(".length")]
    for name in rods:  # each rod's error is its pair's common part plus its difference
        total = groups["rod lengths"][name] + groups["rods of a pair that differ"][name]
        assert abs(total - made.errors[name]) < 1e-12
    others = {n for label, group in groups.items() if "rod" not in label for n in group}
    # the nozzle's offset from the effector is in no group (the budget leaves it out)
    assert set(made.errors) - others - set(rods) == {"tool.x", "tool.y", "tool.z"}


@pytest.mark.parametrize("firmware", [KLIPPER, *(pytest.param(f, marks=pytest.mark.slow)
                                                for f in (MARLIN, RRF_FIRMWARE))], ids=lambda f: f.name)
def test_budget_rows_behave_as_klippers(firmware):
    made = random_true_printer(KOSSEL, np.random.default_rng(5), typical_kit())
    budget = _budget(firmware, made.errors, made.bed_rotation)
    assert set(budget) == GROUPS
    # each model's own values: endstops, the rods' common lengths, the step distances
    for held in ("endstops", "rod lengths", "step distances"):
        assert budget[held].max_3d < 1e-6, held
    # a lean, or rods of a pair that differ, no model holds
    assert budget["tower lean"].max_3d > 1e-3
    assert budget["rods of a pair that differ"].max_3d > 1e-4
    removed = _budget(firmware, made.errors, made.bed_rotation, mode="removed")
    whole = firmware.fit(made.geometry, firmware.nominal(KOSSEL), KOSSEL.step_distance, WORKSPACE).after
    assert abs(removed["endstops"].rms_3d - whole.rms_3d) < 1e-3 * whole.rms_3d
    assert removed["tower lean"].rms_3d < whole.rms_3d
    with pytest.raises(ValueError, match="mode must be 'alone' or 'removed', got 'other'"):
        _budget(firmware, made.errors, mode="other")


@pytest.mark.parametrize("firmware", FIRMWARES, ids=lambda f: f.name)
def test_a_turned_tower_is_held(firmware):
    errors = _tower_a_moved(0.3)
    turned = _budget(firmware, errors)["tower position"]
    assert turned.max_3d < 1e-5 and turned.flatness < 1e-5
    printer = KOSSEL.geometry().with_errors(errors)  # the nominal values leave it
    start = firmware.nominal(KOSSEL)
    assert firmware.fit(printer, start, KOSSEL.step_distance, WORKSPACE).before.max_3d > 0.05


def test_rrfs_bed_tilt_terms_hold_part_of_a_bed_tilt():
    """RRF's M666 A B take the tilt's height error linear in x, y; the volume's shear none holds."""
    tilt = rotation_from_vector(np.radians([0.05, 0.03, 0.0]))
    klipper = _budget(KLIPPER, {}, tilt)[BED_TILT]
    rrf = _budget(RRF_FIRMWARE, {}, tilt)[BED_TILT]
    assert rrf.rms_3d < 0.7 * klipper.rms_3d and rrf.max_3d < 0.8 * klipper.max_3d
    assert rrf.max_3d > 1e-3  # the walls still lean on the bed
