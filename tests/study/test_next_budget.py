"""The next budget a report recommends, re-checked by the tool: a generated study (a study file written here, which
leaves N and M out, as the own-task tutorial's does) is run at a small budget, then again with the overrides its
report prints; the second report says what became of each relation the first one sized, and that account is true
of the second run's verdict table."""

from __future__ import annotations

import json
import sys
from collections import Counter
from pathlib import Path

import pandas as pd

import preloaded

ROOT = Path(__file__).resolve().parents[2]

STUDY = """\
name: generated
tasks:
  - {id: cart, env_id: CartPole-v1, label: "CartPole"}
  - {id: acro, env_id: Acrobot-v1, label: "Acrobot"}
relations:
  - {easier: cart, harder: acro, kind: swing-up}
network: pic_h2_64
prior: normal
"""


def study(tmp_path: Path, *overrides: str) -> Path:
    """Run the generated study with ``overrides``; the directory of the report it wrote."""
    command = [sys.executable, str(ROOT / "pipelines" / "study.py"), f"hydra.searchpath=[file://{tmp_path}/conf]",
               "study=generated", "metrics.resamples=20", f"paths.outputs={tmp_path}/outputs", *overrides]
    done = preloaded.run(command, cwd=ROOT, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-3000:]
    report = next(line for line in done.stdout.splitlines() if line.startswith("Report: "))
    return Path(report.removeprefix("Report: ")).parent


def test_a_run_at_the_recommended_budget_says_what_became_of_each_relation_the_first_sized(tmp_path):
    (tmp_path / "conf" / "study").mkdir(parents=True)
    (tmp_path / "conf" / "study" / "generated.yaml").write_text(STUDY)
    first = study(tmp_path, "study.policies=40", "study.episodes=10", "metrics.bins=200")
    recommended = json.loads((first / "summary.json").read_text())["next_budget"]
    assert recommended["now"] == [40, 10] and recommended["sized"], recommended
    # the overrides the headline prints, as a researcher copies them
    overrides = next(s for s in json.loads((first / "summary.json").read_text())["headline"]
                     if s.startswith("Next budget:")).rpartition("; ")[2].rstrip(").").split()
    assert overrides[0] == f"study.policies={recommended['policies']}"
    second = study(tmp_path, *overrides)
    assert second.parent == first.parent and second != first  # two runs, two reports
    headline = json.loads((second / "summary.json").read_text())["headline"]
    recheck = next(s for s in headline if s.startswith("This run reaches the next budget"))
    assert (f"(N = 40 × M = 10) recommended, N = {recommended['policies']} × M = {recommended['episodes']}, "
            "B = 200 held" in recheck), recheck  # both sizes under 1 000 in this study: printed as they are
    verdict = pd.read_csv(second / "tables" / "verdict_tidy.csv")
    outcomes = {(r.metric, r.easier, r.harder): r.outcome for r in verdict.itertuples()}
    for by, letter in (("policies", "N"), ("episodes", "M")):
        sized = [outcomes[(r["metric"], r["easier"], r["harder"])] for r in recommended["sized"] if r["by"] == by]
        if sized:
            counted = ", ".join(f"{n} {o}" for o, n in sorted(Counter(sized).items(), key=lambda kv: -kv[1]))
            relations = "1 relation" if len(sized) == 1 else f"{len(sized)} relations"
            assert f"of the {relations} it sized by {letter}, now {counted}" in recheck, (recheck, sized)
    still_open = [k for k, o in outcomes.items() if o in ("not significant", "uninformative")
                  and any((r["metric"], r["easier"], r["harder"]) == k for r in recommended["sized"])]
    assert any(s.startswith("Still open:") for s in headline) == bool(still_open)
