"""A mesh written as a binary STL file, atomically (the printed calibration object of a printer)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from .atomic import atomic_write_bytes


def write_stl(path: str | Path, mesh: Any) -> Path:
    """Write a ``trimesh.Trimesh`` as a binary STL [mm], atomically; returns the path."""
    data = mesh.export(file_type="stl")
    return atomic_write_bytes(path, data if isinstance(data, bytes) else bytes(data))
