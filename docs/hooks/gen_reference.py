"""The generated reference pages, written at build time by mkdocs-gen-files (``mkdocs.yml``).

``gen_config_reference.pages()`` (every config group, option and key, from ``conf/``) and
``gen_api_reference.pages()`` (one mkdocstrings page per module) and ``gen_backends_reference.pages()`` (the
backends' table, from their registry) each map a page's path to its text; run by
hand (``python docs/hooks/gen_reference.py``) this prints them instead.
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))  # the sibling modules, also under runpy.run_path

import gen_api_reference  # noqa: E402
import gen_backends_reference  # noqa: E402
import gen_config_reference  # noqa: E402


def pages() -> dict[str, str]:
    """Every generated page: its path under docs/ → its Markdown."""
    return {**gen_config_reference.pages(), **gen_api_reference.pages(), **gen_backends_reference.pages()}


def main() -> None:
    """Write the pages through mkdocs-gen-files (at build time) or print them (by hand)."""
    if __name__ == "<run_path>":  # runpy.run_path: mkdocs-gen-files is building the site
        import mkdocs_gen_files

        for path, text in pages().items():
            with mkdocs_gen_files.open(path, "w") as page:
                page.write(text)
    else:
        for path, text in pages().items():
            print(f"===== {path}\n{text}")


if __name__ in {"__main__", "<run_path>"}:
    main()
