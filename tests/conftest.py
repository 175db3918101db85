from pathlib import Path

import numpy as np
import pytest

from deltacal import NominalDelta

ROOT = Path(__file__).resolve().parents[1]
MODELS = ROOT / "deltacal" / "models"


@pytest.fixture(scope="session")
def bai() -> NominalDelta:
    return NominalDelta.from_toml(MODELS / "bai2015.toml")


@pytest.fixture(scope="session")
def flexpicker() -> NominalDelta:
    return NominalDelta.from_toml(MODELS / "flexpicker.toml")


def workspace_points(nominal: NominalDelta, n: int, rng: np.random.Generator) -> np.ndarray:
    """Random points in the workspace cylinder [mm]."""
    ws = nominal.workspace
    r = ws.radius * np.sqrt(rng.uniform(0.0, 1.0, n))
    a = rng.uniform(0.0, 2.0 * np.pi, n)
    z = rng.uniform(ws.bottom_z, ws.top_z, n)
    return np.stack([r * np.cos(a), r * np.sin(a), z], axis=1)
