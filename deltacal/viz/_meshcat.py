"""The one import of meshcat (a dependency; a clear error if it is broken or missing)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from ..exceptions import ViewerError


# =============================================================================== meshcat helpers
def import_meshcat() -> Any:
    """Import meshcat (optional extra ``viz``), with a clear error when it is missing."""
    try:
        import meshcat
        import meshcat.animation  # noqa: F401
        import meshcat.geometry  # noqa: F401
    except ImportError as exc:  # pragma: no cover - depends on the environment
        raise ViewerError("deltacal.viz needs meshcat, a dependency of deltacal that is missing: "
                          "pip install 'meshcat>=0.3.2'") from exc
    return meshcat


def viewer_script() -> str:
    """Meshcat's bundled viewer (three.js and the scene tree), inlined into the HTML."""
    meshcat = import_meshcat()
    return (Path(meshcat.__file__).parent / "viewer" / "dist" / "main.min.js").read_text(encoding="utf-8")
