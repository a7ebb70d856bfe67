"""The package's optional extras (``[project.optional-dependencies]`` of ``pyproject.toml``) and the pip command that
installs one: what the one line refusing a task whose extra is missing ends with."""

from __future__ import annotations

import json
from importlib import metadata
from urllib.parse import unquote, urlparse

DISTRIBUTION = "taskcomplexity"


def install_command(extra: str) -> str:
    """The pip command that adds ``extra`` to this installation of the package.

    An editable install (a checkout, ``pip install -e .``) gets ``pip install -e '.[extra]'``, run from the checkout;
    an install from a directory or an archive names it (its ``direct_url.json``, PEP 610); an install from an index
    gets ``pip install 'taskcomplexity[extra]'``.
    """
    try:
        recorded = metadata.distribution(DISTRIBUTION).read_text("direct_url.json")
        direct = json.loads(recorded) if recorded else {}
    except (metadata.PackageNotFoundError, ValueError):
        direct = {}
    if direct.get("dir_info", {}).get("editable"):
        return f"pip install -e '.[{extra}]'"
    url = urlparse(direct.get("url", ""))
    if url.scheme == "file":
        return f"pip install '{unquote(url.path)}[{extra}]'"
    return f"pip install '{DISTRIBUTION}[{extra}]'"
