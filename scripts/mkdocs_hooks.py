"""MkDocs hooks of the docs site (``mkdocs.yml``: ``hooks``).

The figures that ``deltacal demo`` and the paper scripts write live in ``results/``, outside
``docs/``. The pages link them as ``../results/NAME.png`` so that the same Markdown shows them on
GitHub; this hook adds those files to the site under ``results/`` so that the links resolve there
too (``mkdocs build --strict`` refuses a link to a file it does not know).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from mkdocs.structure.files import File, Files


def on_files(files: Files, config: Any) -> Files:
    """Add the repository's ``results/*.png`` to the site's files.

    Args:
        files: The files MkDocs found in ``docs/``.
        config: The MkDocs configuration (``docs_dir``, ``site_dir``, ``use_directory_urls``).

    Returns:
        The same collection, with each figure of ``results/`` known by the path the pages link it
        by (``../results/NAME.png``, relative to ``docs/``) and copied to ``results/NAME.png`` in
        the site.
    """
    results = Path(config["docs_dir"]).parent / "results"
    for figure in sorted(results.glob("*.png")):
        files.append(File(f"../results/{figure.name}", config["docs_dir"], config["site_dir"],
                          config["use_directory_urls"], dest_uri=f"results/{figure.name}"))
    return files
