"""Error models of a linear Delta printer: sensitivities against finite differences of exact kinematics."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from deltacal.errormodels import get_model
from deltacal.errormodels.base import (
    N_ELEMENTARY,
    apply_elementary,
    elementary_jacobian,
    elementary_sensitivity,
)
from deltacal.exceptions import GeometryError
from deltacal.geometry import Tolerances
from deltacal.io.robot import load_nominal
from deltacal.kinematics import exact
from deltacal.printer.files.robot_file import load_printer

MODELS = Path(__file__).resolve().parents[1] / "deltacal" / "models"


@pytest.fixture(scope="module")
def printer():
    nominal = load_printer(MODELS / "kossel.toml")
    return nominal.geometry().perturbed(Tolerances.printer_kit(), np.random.default_rng(24))


@pytest.fixture(scope="module")
def travels():
    return np.array([[200.0, 210.0, 190.0], [250.0, 240.0, 262.0], [150.0, 171.0, 160.0],
                     [320.0, 330.0, 300.0]])


def _displacement(geometry, q, moved_plus, moved_minus, h):
    """Central difference of the plate pose: (dx, dalpha) per unit parameter, (N, 6)."""
    plus, minus = exact.forward(moved_plus, q), exact.forward(moved_minus, q)
    dp = (plus.position - minus.position) / (2 * h)
    dR = (plus.rotation - minus.rotation) / (2 * h)
    W = np.einsum("nij,nkj->nik", dR, exact.forward(geometry, q).rotation)
    return np.concatenate([dp, np.stack([W[:, 2, 1], W[:, 0, 2], W[:, 1, 0]], axis=-1)], axis=1)


def test_elementary_sensitivity_of_a_printer_matches_finite_differences(printer, travels):
    S = elementary_sensitivity(printer, travels)
    h = 1e-6
    for k in range(N_ELEMENTARY):
        e = np.zeros(N_ELEMENTARY)
        e[k] = h
        fd = _displacement(printer, travels, apply_elementary(printer, e), apply_elementary(printer, -e), h)
        scale = max(1.0, float(np.abs(S[:, :, k]).max()))
        assert np.abs(fd - S[:, :, k]).max() < 1e-6 * scale, k


@pytest.mark.parametrize("name", ["printer", "klipper"])
def test_printer_model_sensitivity_matches_finite_differences(printer, travels, name):
    model = get_model(name)
    S = model.sensitivity(printer, travels)
    h = 1e-6
    for k in range(model.size):
        dk = np.zeros(model.size)
        dk[k] = h
        fd = _displacement(printer, travels, model.apply(printer, dk), model.apply(printer, -dk), h)
        scale = max(1.0, float(np.abs(S[:, :, k]).max()))
        assert np.abs(fd - S[:, :, k]).max() < 1e-6 * scale, model.names[k]


def test_moved_rods_of_a_printer_equal_the_jacobian(printer, travels):
    pose = exact.forward(printer, travels)
    e = np.random.default_rng(5).normal(size=N_ELEMENTARY) * 1e-3
    full = elementary_jacobian(printer, travels, pose) @ e
    np.testing.assert_allclose(elementary_jacobian(printer, travels, pose, e), full, atol=1e-14)


def test_printer_parameters_mean_what_their_names_say(printer):
    model = get_model("printer")
    dk = np.zeros(model.size)
    dk[model.names.index("endstop2")] = 0.5
    dk[model.names.index("scale3")] = 0.3
    dk[model.names.index("lean1t")] = 1e-3
    moved = model.apply(printer, dk)
    assert moved.encoder_offset[1] == pytest.approx(printer.encoder_offset[1] - 0.5)
    assert moved.joint_scale[2] == pytest.approx(printer.joint_scale[2] * 1.0 + 0.003)
    # a positive lean about t_i moves the tower's top outward
    radial = np.dot(moved.axis_direction[0] - printer.axis_direction[0], printer.radial[0])
    assert radial == pytest.approx(1e-3, rel=1e-3)


def test_models_refuse_the_other_chain(printer):
    rotary = load_nominal(MODELS / "bai2015.toml").geometry()
    q = np.zeros((1, 3))
    with pytest.raises(GeometryError, match="linear Delta printers"):
        get_model("printer").sensitivity(rotary, q)
    with pytest.raises(GeometryError, match="rotary Delta robots"):
        get_model("complete").sensitivity(printer, np.full((1, 3), 200.0))
