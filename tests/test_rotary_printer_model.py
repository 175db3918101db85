"""A rotary Delta printer's error model (54: Savoure's complete model and each arm's step scale) on the
revolute chain: its sensitivities against finite differences through the exact kinematics, the joint
scale the chain now honours, the bed's modes and the prior.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from numpy.testing import assert_allclose

from deltacal.errormodels.base import N_ELEMENTARY, elementary_jacobian, joint_scale_index
from deltacal.geometry import Tolerances
from deltacal.io.geometry_file import load_geometry, save_geometry
from deltacal.kinematics import exact
from deltacal.printer.firmware.klipper.config import read_klipper_config
from deltacal.printer.firmware.klipper.rotary_config import rotary_from_config
from deltacal.printer.identification.errormodels import SCALE_TURN_RAD, RotaryPrinterModel, bed_modes
from tests.test_errormodels import FD_RTOL, _column_norms, _sensitivity_and_differences
from tests.test_klipper_rotary import EXAMPLE

#: The effector deltacal's geometry gives Klipper's point effector (radius, rod spacing, nozzle drop).
EFFECTOR = (30.0, 50.0, 40.0)
#: Step scales of the arms (a gear ratio off by 0.2 %, -0.1 %, 0.15 %).
SCALES = np.array([1.002, 0.999, 1.0015])


def _printer(seed: int = 1):
    """Klipper's example rotary printer in its bed's frame, perturbed (rotary tolerances), its arms' step
    scales off; and readings of 6 nozzle targets over the volume (Klipper's nominal inverse)."""
    k = rotary_from_config(read_klipper_config(EXAMPLE))
    nominal = k.geometry(*EFFECTOR).moved_rigidly(np.eye(3), np.array([0.0, 0.0, k.base_height(EFFECTOR[2])]))
    rng = np.random.default_rng(seed)
    geometry = replace(nominal.perturbed(Tolerances(), rng), joint_scale=SCALES)
    targets = np.column_stack([rng.uniform(-40.0, 40.0, (6, 2)), rng.uniform(0.0, 100.0, 6)])
    return geometry, k.readings(k.shoulder_angles(targets))


def test_the_model_is_the_complete_one_and_the_step_scales():
    model = RotaryPrinterModel()
    assert model.size == 54 and model.names[-3:] == ["scale1", "scale2", "scale3"]
    assert model.preferred[:6] == ["beta1t", "beta2t", "beta3t", "scale1", "scale2", "scale3"]
    assert sorted(model.preferred) == sorted(model.names)
    sigma = dict(zip(model.names, model.prior_sigma(Tolerances(joint_scale=0.002)), strict=True))
    assert sigma["scale2"] == SCALE_TURN_RAD * 0.002 and sigma["beta1t"] == Tolerances().encoder_offset
    assert sigma["b11z"] == pytest.approx(np.hypot(0.05, 0.2)) and sigma["l32"] == 0.05


def test_sensitivity_matches_finite_differences():
    """Every one of the 54 columns, step scales included, against central differences through the exact
    forward kinematics of the moved geometry (a printer whose scales are not 1): relative 1e-6."""
    model = RotaryPrinterModel()
    geometry, q = _printer()
    S, F = _sensitivity_and_differences(model, geometry, q)
    pos_norm, pos_err = _column_norms(S[:, :3]), _column_norms(S[:, :3] - F[:, :3])
    assert np.all(pos_norm > 0.1)
    assert np.max(pos_err / pos_norm) < FD_RTOL
    ori_norm, ori_err = _column_norms(S[:, 3:]), _column_norms(S[:, 3:] - F[:, 3:])
    assert np.all(ori_norm > 1e-4)
    assert np.max(ori_err / ori_norm) < FD_RTOL
    # the scale columns are the arm's turn times its reading over 100 deg: not the encoder offsets' (q is
    # not 1)
    scale, offset = S[..., model.names.index("scale1")], S[..., model.names.index("beta1t")]
    assert np.linalg.norm(scale - offset * q[:, :1] / SCALE_TURN_RAD) < 1e-9 * np.linalg.norm(scale)


def test_joint_scale_moves_without_forming_the_jacobian():
    """``J_k e`` (the compensators' path, a revolute chain's circles) equals ``J_k @ e`` with the joint
    scales moved too, on a printer whose scales are not 1."""
    geometry, q = _printer(2)
    pose = exact.forward(geometry, q)
    e = np.random.default_rng(3).standard_normal(N_ELEMENTARY)
    full = np.einsum("nke,e->nk", elementary_jacobian(geometry, q, pose), e)
    atol = 1e-12 * np.abs(full).max()
    assert_allclose(elementary_jacobian(geometry, q, pose, moves=e), full, rtol=0, atol=atol)
    only = np.zeros(N_ELEMENTARY)
    only[joint_scale_index(1)] = 1.0
    assert np.abs(elementary_jacobian(geometry, q, pose, moves=only)).max() > 10.0


def test_bed_modes_move_the_printer_rigidly():
    """The least-squares rise moves the plate up 1 mm (5e-3: the balls move in the plate's frame, tilted
    by the errors), without a turn; the tilts turn it about x and y by 1 rad (the complete model holds a
    rigid turn to 2 %)."""
    model = RotaryPrinterModel()
    geometry, q = _printer(4)
    pose = exact.forward(geometry, q)
    moved = model.sensitivity(geometry, q, pose) @ bed_modes(model, geometry)  # (N, 6, 3)
    assert_allclose(moved[:, :, 2], np.tile([0.0, 0.0, 1.0, 0.0, 0.0, 0.0], (len(q), 1)), rtol=0, atol=5e-3)
    for k, omega in enumerate(np.eye(3)[:2]):
        turn = np.concatenate([np.cross(omega, pose.position), np.tile(omega, (len(q), 1))], axis=1)
        assert np.linalg.norm(moved[:, :, k] - turn) < 0.02 * np.linalg.norm(turn)
    factor = model.prior_factor(Tolerances(joint_scale=0.002), geometry)
    assert factor.shape == (54, 54) and np.allclose(factor, np.tril(factor))
    with pytest.raises(ValueError, match="not a value of Klipper's rotary calibration: arm_length_a"):
        model.prior_factor(Tolerances(joint_scale=0.002), geometry, calibrated=("arm_length_a",))


def test_a_rotary_printers_step_scales_are_kept_in_its_geometry_file(tmp_path):
    """A rotary printer's joint scales written and read back; a rotary robot's file has no such key."""
    geometry, q = _printer(5)
    save_geometry(geometry, tmp_path / "printer.toml")
    back = load_geometry(tmp_path / "printer.toml")
    assert_allclose(back.joint_scale, SCALES, rtol=0, atol=0)
    assert_allclose(exact.forward(back, q).position, exact.forward(geometry, q).position, rtol=0, atol=1e-9)
    save_geometry(replace(geometry, joint_scale=np.ones(3)), tmp_path / "robot.toml")
    assert "joint_scale" not in (tmp_path / "robot.toml").read_text()
