"""Issue 21, item 14: a mistake in one station only is named (it was "no single cause stands out").

Measurements of two points from two free stations, simulated on the Pinocchio closed loop; the
west station's point labels swapped, or its positions written in metres.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from test_identification_frames import FAR, OTHER, in_frames

from deltacal import Tolerances
from deltacal.exceptions import IdentificationError, PoorFitError
from deltacal.identification import identify
from deltacal.planning import d_optimal
from deltacal.simulation import Metrology, simulate_measurements


@pytest.fixture(scope="module")
def two_stations(bai):
    truth = bai.geometry().perturbed(Tolerances.bai2015(), np.random.default_rng(4))
    poses = d_optimal(bai, "complete", 40, rng=np.random.default_rng(2)).poses
    meas = simulate_measurements(truth, poses.q, np.random.default_rng(5),
                                 Metrology(points=("smr_centre", "smr_offset"), orientation=False))
    n = len(meas)
    meas = replace(meas, station=["east" if k < n // 2 else "west" for k in range(n)])
    return in_frames(meas, {"east": FAR, "west": OTHER})


@pytest.mark.long
def test_labels_swapped_in_one_station_are_named(bai, two_stations):
    west = np.array(two_stations.station) == "west"
    swap = {"smr_centre": "smr_offset", "smr_offset": "smr_centre"}
    labels = [swap[p] if w else p for p, w in zip(two_stations.point, west, strict=True)]
    meas = replace(two_stations, point=labels)
    with pytest.raises(PoorFitError, match="'smr_centre' and 'smr_offset' are swapped in station 'west'"):
        identify(bai.geometry(), meas, "complete", frame="free")


def test_one_station_in_metres_is_named(bai, two_stations):
    west = np.array(two_stations.station)[:, None] == "west"
    position = np.where(west, two_stations.position / 1000.0, two_stations.position)
    meas = replace(two_stations, position=position)
    with pytest.raises(IdentificationError, match="station\\(s\\) 'west' spread about 1000 times less"):
        identify(bai.geometry(), meas, "complete", frame="free")
    # the right file identifies
    assert identify(bai.geometry(), two_stations, "complete", frame="free").variance_factor < 1.3
