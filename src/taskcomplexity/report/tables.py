"""Paper-style tables, written as Markdown, LaTeX and CSV side by side."""

from __future__ import annotations

from pathlib import Path

import pandas as pd

ARM_ORDER = ("one_link_1m0", "one_link_1m65", "two_link", "two_link_obstacle")
ARM_LABELS = {
    "one_link_1m0": "1-link, L = 1.0 m",
    "one_link_1m65": "1-link, L = 1.65 m",
    "two_link": "2-link",
    "two_link_obstacle": "2-link + obstacle",
}
REWARD_ORDER = ("dense", "sparse")


def split_task_id(task_id: str) -> tuple[str, str]:
    arm, _, reward = task_id.rpartition("-")
    return arm, reward


def task_sort_key(task_id: str) -> tuple[int, int, str]:
    arm, reward = split_task_id(task_id)
    return (
        REWARD_ORDER.index(reward) if reward in REWARD_ORDER else 99,
        ARM_ORDER.index(arm) if arm in ARM_ORDER else 99,
        task_id,
    )


def mean_sd(mean: float, sd: float, digits: int = 3) -> str:
    return f"{mean:.{digits}f} ± {sd:.{digits}f}"


def table1(metrics: pd.DataFrame, *, digits: int = 3) -> pd.DataFrame:
    """Table 1 of the paper: PIC and POIC as bootstrap mean ± sd, rows reward × arm.

    Parameters
    ----------
    metrics : DataFrame
        One row per task with ``task``, ``pic_mean``, ``pic_sd``, ``poic_mean``, ``poic_sd``.
    """
    rows = []
    for _, r in metrics.sort_values("task", key=lambda s: s.map(task_sort_key)).iterrows():
        arm, reward = split_task_id(r["task"])
        rows.append(
            {
                "Reward": reward,
                "Arm": ARM_LABELS.get(arm, arm),
                "PIC": mean_sd(r["pic_mean"], r["pic_sd"], digits),
                "POIC": mean_sd(r["poic_mean"], r["poic_sd"], digits),
            }
        )
    return pd.DataFrame(rows).set_index(["Reward", "Arm"])


def write_table(table: pd.DataFrame, directory: Path, name: str, *, caption: str = "") -> list[Path]:
    """Write ``name.md``, ``name.tex`` and ``name.csv``; return their paths."""
    directory.mkdir(parents=True, exist_ok=True)
    flat = table.reset_index() if not isinstance(table.index, pd.RangeIndex) else table
    md = directory / f"{name}.md"
    tex = directory / f"{name}.tex"
    csv = directory / f"{name}.csv"
    text = flat.to_markdown(index=False)
    md.write_text((f"**{caption}**\n\n" if caption else "") + text + "\n")
    tex.write_text(
        flat.to_latex(index=False, caption=caption or None, label=f"tab:{name}", escape=True).replace("±", r"$\pm$")
    )
    flat.to_csv(csv, index=False)
    return [md, tex, csv]
