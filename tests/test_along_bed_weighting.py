"""A correction along the bed weighted by its significance only for a calibration measured at one height.

From bed-level data (Klipper's saved ``DELTA_CALIBRATE`` / ``DELTA_ANALYZE``) a correction along the bed
comes through the model's coupling of leans and places with the heights: applied only where it stands
out of its σ (:func:`deltacal.holds.significance_weight`). Measured over the volume (deltacal's planned
object), it is measured at each height and applied whole where it holds (``scripts/along_bed_weighting.py``:
on 24 simulated Kossels with effects the model lacks, weighting it too left the 3-D max larger on 19 and the
local error larger on all 24).
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from script_module import load_script

from deltacal.holds import DEFAULT_BOUND, ONE_LAYER_MM, WhereItHolds, correction_weight, significance_weight


def _holds(measured_top: float) -> WhereItHolds:
    radius, azimuth, height = WhereItHolds.grid(80.0, 100.0)
    shape = (radius.size, azimuth.size, height.size)
    return WhereItHolds(radius, azimuth, height, np.full(shape, 0.01), np.full(shape, 0.01), measured_top)


def test_only_a_calibration_measured_at_one_height_weighs_the_significance_along_the_bed():
    points = np.array([[10.0, 0.0, 0.2], [40.0, 20.0, 30.0], [-50.0, 10.0, 80.0]])
    corrections = np.array([[0.005, 0.0, 0.02], [0.012, 0.009, 0.0], [0.05, -0.03, 0.01]])
    sizes = np.hypot(corrections[:, 0], corrections[:, 1])
    expected_whole = correction_weight(np.full(3, 0.01), DEFAULT_BOUND)
    for top, bed_level in ((0.0, True), (ONE_LAYER_MM - 0.1, True), (ONE_LAYER_MM, False), (100.0, False)):
        holds = _holds(top)
        assert holds.bed_level is bed_level
        weights = holds.weights(points, DEFAULT_BOUND, corrections)
        along = expected_whole * (significance_weight(sizes, np.full(3, 0.01)) if bed_level else 1.0)
        assert np.allclose(weights[:, 0], along, rtol=0.0, atol=1e-15)
        assert np.allclose(weights[:, 1], expected_whole, rtol=0.0, atol=1e-15)
    # the two differ here: the smallest correction (0.005 mm, half its σ) is not applied from bed-level data
    assert _holds(0.0).weights(points, DEFAULT_BOUND, corrections)[0, 0] == 0.0
    assert _holds(100.0).weights(points, DEFAULT_BOUND, corrections)[0, 0] == 1.0


@pytest.fixture(scope="module")
def study():
    return load_script("along_bed_weighting")


@pytest.mark.slow
def test_over_the_volume_the_whole_correction_along_the_bed_adds_no_step(study):
    """A well-built Kossel (seed 48801) measured with the planned object, identified, corrected through
    Klipper's nominal values: the correction along the bed applied whole where it holds leaves a smaller
    3-D max (0.025 against 0.049 mm weighted by its significance too) and a far smaller local error (the
    change of the true error between targets 10 mm apart: 0.005 against 0.040 mm)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        found = study.judged(48801, "well built", "plain")
    whole, weighted = found["whole"], found["weighted"]
    assert whole["max_3d_mm"] < weighted["max_3d_mm"], found
    assert 2.0 * whole["local_mm"] < weighted["local_mm"], found
    assert whole["local_mm"] <= 0.01, found

