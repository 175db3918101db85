"""MkDocs hooks of the docs site (``mkdocs.yml``: ``hooks``).

* The figures that ``deltacal demo`` and the paper scripts write live in ``results/``, outside
  ``docs/``. The pages link them as ``../results/NAME.png`` so that the same Markdown shows them
  on GitHub; :func:`on_files` adds those files to the site under ``results/`` so that the links
  resolve there too (``mkdocs build --strict`` refuses a link to a file it does not know).
* The docstrings are Google style with Sphinx roles for names (``:func:`fit```). mkdocstrings
  renders a role as its bare text; :func:`on_page_content` shows the name alone, as code.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

from mkdocs.structure.files import File, Files, InclusionLevel

#: A Sphinx role as mkdocstrings renders it: ``:func:<code>~.module.name</code>``.
_ROLE = re.compile(r":(?:py:)?(?:func|meth|class|mod|attr|data|exc|obj|const):<code>(~?)\.?([^<]*)</code>")


def on_files(files: Files, config: Any) -> Files:
    """Add the repository's ``results/*.png`` to the site's files.

    Args:
        files: The files MkDocs found in ``docs/``.
        config: The MkDocs configuration (``docs_dir``, ``site_dir``, ``use_directory_urls``).

    Returns:
        The same collection, with each figure of ``results/`` known by the path the pages link it
        by (``../results/NAME.png``, relative to ``docs/``) and copied to ``results/NAME.png`` in
        the site (included explicitly: a path that starts with a dot is excluded by default).
    """
    results = Path(config["docs_dir"]).parent / "results"
    for figure in sorted(results.glob("*.png")):
        files.append(File(f"../results/{figure.name}", config["docs_dir"], config["site_dir"],
                          config["use_directory_urls"], dest_uri=f"results/{figure.name}",
                          inclusion=InclusionLevel.INCLUDED))
    return files


def _name(match: re.Match[str]) -> str:
    """The code of a role: its last component after ``~`` (Sphinx's short form), else the target."""
    target = match.group(2)
    return f"<code>{target.rsplit('.', 1)[-1] if match.group(1) else target}</code>"


def on_page_content(html: str, **kwargs: Any) -> str:
    """Show each Sphinx role of a rendered page as the name it refers to, in code.

    Args:
        html: The page's HTML.
        **kwargs: MkDocs's other arguments (page, config, files), unused.

    Returns:
        The HTML with ``:func:<code>name</code>`` written ``<code>name</code>``.
    """
    return _ROLE.sub(_name, html)
