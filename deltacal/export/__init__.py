"""Exports of an identified robot to other programs' formats (MJCF for MuJoCo and Pinocchio)."""

from .mjcf import HOME_KEY, mjcf_model, write_mjcf

__all__ = ["HOME_KEY", "mjcf_model", "write_mjcf"]
