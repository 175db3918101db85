"""The firmware interface (``printer.firmware.base.Firmware``), Klipper behind it, and the files of
either kind of robot (``deltacal.robots``) above the engine and the printer's wing."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose

import deltacal
from deltacal.controller import Controller
from deltacal.exceptions import InputError
from deltacal.geometry import NominalDelta
from deltacal.printer.files.robot_file import load_printer
from deltacal.printer.firmware import config_firmware, firmwares
from deltacal.printer.firmware.base import Firmware, FirmwareFit
from deltacal.printer.firmware.klipper.config import klipper_config_text, load_klipper
from deltacal.printer.firmware.klipper.firmware import KLIPPER
from deltacal.printer.firmware.klipper.fit import KlipperFit, fit_klipper
from deltacal.printer.firmware.klipper.model import KlipperController, KlipperDelta
from deltacal.printer.robot import NominalLinearDelta
from deltacal.printer.simulation import random_true_printer, typical_kit
from deltacal.robots import load_controller, load_robot

MODELS = Path(__file__).resolve().parents[1] / "deltacal" / "models"


@pytest.fixture(scope="module")
def kossel() -> NominalLinearDelta:
    return load_printer(MODELS / "kossel.toml")


def test_klipper_is_the_known_firmware_and_delegates(kossel, tmp_path):
    assert isinstance(KLIPPER, Firmware) and firmwares()[0] is KLIPPER and KLIPPER.name == "klipper"
    nominal = KLIPPER.nominal(kossel)
    reference = KlipperDelta.from_printer(kossel)
    for key in ("angle", "arm_length", "position_endstop", "step_distance"):
        assert np.array_equal(getattr(nominal, key), getattr(reference, key))
    assert nominal.delta_radius == reference.delta_radius
    start = KLIPPER.start(kossel.geometry())
    assert_allclose(start.position_endstop, reference.position_endstop, atol=1e-9, rtol=0)
    controller = KLIPPER.controller(nominal, kossel.step_distance)
    assert isinstance(controller, KlipperController)
    assert np.array_equal(controller.step_distance, kossel.step_distance)
    cfg = KLIPPER.save_config(tmp_path / "printer.cfg", nominal, title="nominal", complete=True)
    assert config_firmware(cfg) is KLIPPER and config_firmware(MODELS / "kossel.toml") is None
    assert cfg.read_text() == klipper_config_text(nominal, title="nominal", complete=True)
    assert KLIPPER.read_config(cfg).name == load_klipper(cfg).name == "printer.cfg"


def test_a_complete_configuration_reads_back_exactly(kossel, tmp_path):
    """``complete``: every key Klipper's delta kinematics needs, the values read back bit for bit."""
    made = random_true_printer(kossel, np.random.default_rng(3), typical_kit())
    values = KLIPPER.fit(made.geometry, KLIPPER.nominal(kossel), kossel.step_distance,
                         kossel.workspace).values
    text = KLIPPER.config_text(values, title="fitted", complete=True)
    assert text.startswith("# fitted\n") and "Replace these keys" not in text and "assumes" not in text
    for key in ("kinematics: delta", "max_velocity: 300", "max_accel: 3000", "microsteps: 16",
                "full_steps_per_rotation: 200"):
        assert key in text
    cfg = tmp_path / "fitted.cfg"
    cfg.write_text(text)
    back = load_klipper(cfg)
    assert back.delta_radius == values.delta_radius
    assert np.array_equal(back.arm_length, values.arm_length)
    assert np.array_equal(back.position_endstop, values.position_endstop)
    assert_allclose(back.angle, values.angle, atol=1e-15, rtol=0)
    assert_allclose(back.step_distance, values.step_distance, rtol=1e-15, atol=0)


def test_the_interfaces_fit_is_fit_klipper(kossel):
    made = random_true_printer(kossel, np.random.default_rng(4), typical_kit())
    start, step = KLIPPER.nominal(kossel), kossel.step_distance
    fit = KLIPPER.fit(made.geometry, start, step, kossel.workspace, first_layer_weight=30.0)
    direct = fit_klipper(made.geometry, start, step, kossel.workspace, first_layer_weight=30.0)
    assert type(fit) is type(direct) is FirmwareFit is KlipperFit  # one fit value for every firmware
    assert isinstance(fit.values, KlipperDelta)
    assert np.array_equal(fit.values.position_endstop, direct.values.position_endstop)


def test_files_of_either_kind(kossel, tmp_path):
    assert isinstance(load_robot(MODELS / "kossel.toml"), NominalLinearDelta)
    assert isinstance(load_robot(MODELS / "bai2015.toml"), NominalDelta)
    assert isinstance(load_controller(MODELS / "bai2015.toml"), Controller)
    cfg = KLIPPER.save_config(tmp_path / "printer.cfg", KLIPPER.nominal(kossel), complete=True)
    assert isinstance(load_controller(cfg), KlipperController)
    # the top-level names are these
    assert deltacal.load_robot is load_robot and deltacal.load_controller is load_controller


def test_towers_stepping_differently_need_the_step_distance(kossel, tmp_path):
    values = KLIPPER.nominal(kossel)
    odd = KlipperDelta(values.delta_radius, values.angle, values.arm_length, values.position_endstop,
                       np.array([0.0125, 0.0126, 0.0125]))
    cfg = KLIPPER.save_config(tmp_path / "odd.cfg", odd, complete=True)
    with pytest.raises(InputError, match=r"sections \[stepper_a..c\], key rotation_distance: the towers'"):
        KLIPPER.load_controller(cfg)
    assert KLIPPER.load_controller(cfg, 0.0125).step_distance.tolist() == [0.0125] * 3  # type: ignore[attr-defined]
