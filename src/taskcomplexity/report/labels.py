"""How each task of a study is shown: its name, colour, marker and group, all from the study file.

A task's name is its study label, followed by its group when another task of the study has the same label (the
paper's "1-link, L = 1.0 m, dense" and "…, sparse"). Its colour is the study's ``color``, else its difficulty
group's when the study orders its groups, else the colour-blind palette at its position in the study, so a task
keeps its colour whichever tasks a figure shows. Markers distinguish the groups (one marker when the study has
none).
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

import seaborn as sns

from taskcomplexity.study_data import Study

MARKERS = ("o", "^", "s", "D", "v", "P", "X", "*")
"""Markers of the study's groups, in the order the groups first appear."""
GROUP_COLOURS = ("#1e8449", "#1f5aa6", "#d68910", "#c0392b", "#7d3c98", "#5d6d7e")
"""Colours of a study's ordered difficulty groups, easiest first (green → red): a task without a ``color`` of its
own takes its group's."""


@dataclass(frozen=True)
class TaskStyle:
    """How one task is shown.

    Attributes
    ----------
    id : str
        The study entry's id.
    label : str
        Its study label.
    name : str
        Unique display name (label, with the group when the label is not unique).
    group : str or None
        Its study group.
    colour : str
        Hex colour.
    marker : str
        Matplotlib marker of its group.
    """

    id: str
    label: str
    name: str
    group: str | None
    colour: str
    marker: str


def task_styles(study: Study, ids: Iterable[str] | None = None) -> dict[str, TaskStyle]:
    """Styles of ``ids`` (default: every study task), in study order; ids the study lacks come last."""
    ids = list(dict.fromkeys(study.ids if ids is None else ids))
    known = [t for t in study.tasks if t.id in ids]
    entries = [(t.id, t.label, t.group, t.color) for t in known]
    entries += [(i, i, None, None) for i in ids if i not in study.ids]
    palette = sns.color_palette("colorblind", max(len(study.tasks) + len(ids), 1)).as_hex()
    position = {task.id: i for i, task in enumerate(study.tasks)}
    extra = len(study.tasks)
    groups = list(dict.fromkeys(g for _, _, g, _ in entries if g is not None))
    ordered = list(study.groups.order) if study.groups is not None else []
    labels = [label for _, label, _, _ in entries]
    styles = {}
    for task_id, label, group, colour in entries:
        if task_id not in position:
            position[task_id], extra = extra, extra + 1
        name = label
        if labels.count(label) > 1:
            name = f"{label}, {group}" if group is not None else f"{label} ({task_id})"
        marker = MARKERS[groups.index(group) % len(MARKERS)] if group is not None else MARKERS[0]
        if colour is None and group in ordered:
            colour = GROUP_COLOURS[ordered.index(group) % len(GROUP_COLOURS)]
        styles[task_id] = TaskStyle(task_id, label, name, group, colour or palette[position[task_id] % len(palette)],
                                    marker)
    return styles


def kind_label(kind: str) -> str:
    """A relation kind as the study writes it, underscores as spaces (``link_length`` → ``link length``)."""
    return str(kind).replace("_", " ")


def has_groups(styles: dict[str, TaskStyle]) -> bool:
    """Whether any of the tasks has a group."""
    return any(s.group is not None for s in styles.values())
