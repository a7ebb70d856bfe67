"""Names, colours, markers and groups of a study's tasks come from the study file alone."""

from __future__ import annotations

import seaborn as sns

from taskcomplexity.cli import CONF_DIR
from taskcomplexity.report.labels import kind_label, task_styles
from taskcomplexity.study_data import load_study_file, study_from_config

SEVEN_TASKS = load_study_file(CONF_DIR / "study" / "seven_tasks.yaml")


def test_the_paper_tasks_keep_their_labels_colours_and_group_markers():
    styles = task_styles(SEVEN_TASKS)
    assert list(styles) == list(SEVEN_TASKS.ids)  # study order
    assert styles["one_link_1m0-dense"].name == "1-link, L = 1.0 m, dense"  # label shared with the sparse twin
    assert styles["two_link_obstacle-dense"].name == "2-link + obstacle"  # a unique label stays as it is
    assert styles["one_link_1m0-dense"].colour == "#1f5aa6" and styles["two_link-sparse"].colour == "#f1948a"
    assert {s.marker for s in styles.values() if s.group == "dense"} == {"o"}
    assert {s.marker for s in styles.values() if s.group == "sparse"} == {"^"}


def test_a_task_keeps_its_colour_whichever_tasks_are_shown():
    study = study_from_config({"name": "three", "tasks": [{"id": "a", "task": "cartpole"},
                                                          {"id": "b", "task": "pendulum"},
                                                          {"id": "c", "task": "acrobot", "color": "#123456"}]})
    everything = task_styles(study)
    palette = sns.color_palette("colorblind", 6).as_hex()
    assert [everything[t].colour for t in "abc"] == [palette[0], palette[1], "#123456"]
    assert task_styles(study, ["b", "c"])["b"].colour == everything["b"].colour
    assert {s.marker for s in everything.values()} == {"o"}  # no groups: one marker
    assert [everything[t].name for t in "abc"] == ["a", "b", "c"]  # no label: the id


def test_an_id_the_study_lacks_is_named_by_itself_and_gets_a_spare_colour():
    styles = task_styles(SEVEN_TASKS, ["two_link-dense", "three_link-dense"])
    assert list(styles) == ["two_link-dense", "three_link-dense"]
    assert styles["three_link-dense"].name == "three_link-dense"
    assert styles["three_link-dense"].colour not in {s.colour for s in task_styles(SEVEN_TASKS).values()}


def test_relation_kinds_are_shown_as_the_study_writes_them():
    assert kind_label("degrees_of_freedom") == "degrees of freedom"
    assert kind_label("swing-up") == "swing-up"
