"""docs/how-to/add-a-task.md, followed on a scratch copy: its one file is a task preset that composes into a
gymnasium task, and random policies run on it."""

from __future__ import annotations

import pandas as pd
from howto import apply, blocks, commands, page, stated_counts, touched

PAGE = "add-a-task.md"
PRESET = "pendulum_mars"


def test_the_page_adds_a_task_preset_in_the_file_it_states(scratch):
    text = page(PAGE)
    chosen = blocks(text)
    assert touched(chosen) == [f"src/taskcomplexity/conf/task/{PRESET}.yaml"]
    assert stated_counts(text)[0] == len(touched(chosen)) == 1
    apply(scratch.root, chosen)

    scratch.pytest("tests/tasks/test_config.py", "-k", f"every_task_preset and {PRESET}")

    ((env, words),) = commands(text)  # the page's command: random policies on the new preset
    assert words[1:3] == ["pipelines/rwg.py", f"task={PRESET}"]
    run = scratch.command(env, words)
    # The preset's name is the task id (its env's constructor arguments follow it in the label).
    assert f"returns {PRESET}(g=3.7) " in run.stdout + run.stderr
    (returns,) = (scratch.root / "outputs" / "cache" / "rwg").glob("*/returns.parquet")
    policies, episodes = (int(w.split("=")[1]) for w in words if w.startswith(("rwg.policies=", "rwg.episodes=")))
    assert len(pd.read_parquet(returns)) == policies * episodes
