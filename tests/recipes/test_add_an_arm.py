"""docs/how-to/add-an-arm.md, followed on a scratch copy: its one file keeps the tests that go over the arm
presets green, and random policies run on the new arm."""

from __future__ import annotations

import pandas as pd
from howto import apply, blocks, commands, page, stated_counts, touched

PAGE = "add-an-arm.md"
ARM = "one_link_1m3"


def test_the_page_adds_an_arm_in_the_file_it_states(scratch):
    text = page(PAGE)
    chosen = blocks(text)
    assert touched(chosen) == [f"src/taskcomplexity/conf/arm/{ARM}.yaml"]
    assert stated_counts(text)[0] == len(touched(chosen)) == 1
    apply(scratch.root, chosen)

    # the tests over every preset, on the new arm, and those that count or name the presets
    scratch.pytest("tests/tasks/test_config.py", "tests/tasks/test_pybullet_env.py", "tests/tasks/test_urdf.py",
                   "tests/tasks/test_batched.py", "tests/rl/test_settings.py",
                   "-k", f"{ARM} or unknown_arm or gym_ids or protocol_adds_her")

    ((env, words),) = commands(text)  # the page's command: random policies on the new arm
    assert words[1:3] == ["pipelines/rwg.py", f"arm={ARM}"]
    run = scratch.command(env, words)
    assert f"{ARM}-dense" in run.stdout + run.stderr
    (returns,) = (scratch.root / "outputs" / "cache" / "rwg").glob("*/returns.parquet")
    table = pd.read_parquet(returns)
    policies, episodes = (int(w.split("=")[1]) for w in words if w.startswith(("rwg.policies=", "rwg.episodes=")))
    assert len(table) == policies * episodes and table["return"].notna().all()
