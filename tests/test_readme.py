"""The README is a front page whose commands run as printed and whose links lead somewhere.

The documentation site's own links are checked by ``make docs`` (``mkdocs build --strict``).
"""

from __future__ import annotations

import os
import re
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
FRONT_PAGE_BYTES = 15_000
"""A front page, not a manual: the anchors' READMEs are 6–42 KB; the rest lives in docs/."""


def shell_blocks(text: str) -> list[str]:
    """The ```bash blocks of a Markdown text, in order."""
    return re.findall(r"```bash\n(.*?)```", text, flags=re.DOTALL)


def test_the_readme_is_a_front_page():
    assert README.stat().st_size <= FRONT_PAGE_BYTES


def test_every_relative_link_of_the_readme_leads_to_a_file():
    links = re.findall(r"\]\(([^)#]+)(?:#[^)]*)?\)", README.read_text(encoding="utf-8"))
    relative = [link for link in links if not re.match(r"[a-z]+://", link)]
    assert relative, "the README links into the docs"
    assert [link for link in relative if not (ROOT / link).exists()] == []


def test_the_readme_and_the_docs_name_no_commit():
    # History belongs in commits; a page that names one is telling it. Hex words that are no commit of this
    # repository (a number's digits, a cache key) are fine.
    texts = [README, *sorted((ROOT / "docs").rglob("*.md"))]
    words = {w for path in texts for w in re.findall(r"\b[0-9a-f]{7,40}\b", path.read_text(encoding="utf-8"))
             if re.search(r"[a-f]", w) and re.search(r"\d", w)}
    commits = [w for w in words if subprocess.run(["git", "cat-file", "-e", f"{w}^{{commit}}"], cwd=ROOT,
                                                  capture_output=True).returncode == 0]
    assert commits == []


@pytest.mark.skipif(not (ROOT / ".venv" / "bin" / "python").exists(), reason="the README's commands use .venv")
def test_measure_your_own_task_runs_as_printed(tmp_path):
    # The README's own-task block, as a new user pastes it, at smoke size (experiment=quick takes minutes): its
    # study file goes to a temporary $HOME, its outputs under $TASKCOMPLEXITY_OUTPUTS.
    section = README.read_text(encoding="utf-8").split("## Measure your own task", 1)[1].split("\n## ", 1)[0]
    (block,) = shell_blocks(section)
    assert "experiment=quick" in block
    environment = {**os.environ, "HOME": str(tmp_path), "TASKCOMPLEXITY_OUTPUTS": str(tmp_path / "outputs")}
    environment.pop("HYDRA_FULL_ERROR", None)
    done = subprocess.run(["bash", "-euo", "pipefail", "-c", block.replace("experiment=quick", "experiment=smoke")],
                          cwd=ROOT, env=environment, capture_output=True, text=True, timeout=900)
    assert done.returncode == 0, done.stderr[-3000:]
    assert list((tmp_path / "outputs" / "reports").glob("mine*/index.html")), done.stdout[-2000:]
