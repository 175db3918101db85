"""Joint commands of the planar mechanism: classical and Savoure's improved compensation (Eq. 29-35)."""

from __future__ import annotations

import numpy as np

from .geometry import PlanarGeometry, SimplifiedModel
from .identification import CompleteIdentification
from .kinematics import sensitivity


def command_classical(x: np.ndarray | float, model: SimplifiedModel) -> np.ndarray:
    """Joint commands by the simplified IPR_S (Eq. 35) of a (corrected) model [rad].

    With the nominal model this is the uncalibrated command; with the model of
    :func:`identify_simplified` it is the classical calibration.
    """
    return model.inverse(x)


def command_improved(
    x: np.ndarray | float, nominal: PlanarGeometry, identification: CompleteIdentification
) -> np.ndarray:
    """Joint commands by Savoure's approximate complete inverse model (Eq. 29-33, Fig. 2).

    ``q = IPR_S(x, k_S)`` (29); ``δX = S_C^b(q, k_C) δk_C^b`` (30) at the nominal
    geometry; ``δx = δX[0]`` (31); ``δq = J_S^m(q, k_S) δx`` (32); ``q - δq`` (33).

    Args:
        x: Desired tool positions along ``x_b`` [mm].
        nominal: The nominal mechanism with the tool in use (its h).
        identification: The complete identification (its base parameters).

    Returns:
        Corrected joint commands [rad], shape of x.
    """
    simple = SimplifiedModel.from_geometry(nominal)
    q = simple.inverse(x)
    S = sensitivity(q, nominal)
    S_b = S[..., :, identification.base.base]
    dX = S_b @ identification.estimate
    dq = simple.inverse_jacobian(q) * dX[..., 0]
    return q - dq
