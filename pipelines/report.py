"""Report stage: pull every artefact of the study from the cache (computing what is missing) and
write ``outputs/reports/<study>-<tag>/`` (index.html, report.md, figures/, tables/).

The report needs every upstream artefact, so this is the study chain itself; when everything is
cached it only draws the figures and writes the page.

    python pipelines/report.py experiment=quick
"""

from __future__ import annotations

import sys

from study import main  # the same @hydra.main entry point (pipelines/ is on sys.path as the script dir)
from taskcomplexity.cli import check_overrides

if __name__ == "__main__":
    check_overrides(sys.argv)
    main()
