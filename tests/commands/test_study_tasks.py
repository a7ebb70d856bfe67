"""``python -m taskcomplexity.commands.study_tasks <study>``: the ids a sweep over ``sac.entry`` or ``rwg.entry`` takes
(``make paper-jobs``, ``make atlas-cluster``) are the tasks the study itself runs, for every packaged study."""

from __future__ import annotations

import pytest

from taskcomplexity.cli import CONF_DIR
from taskcomplexity.commands.study_tasks import study_task_ids
from taskcomplexity.study.plan import study_from

STUDIES = sorted(p.stem for p in (CONF_DIR / "study").glob("*.yaml"))


@pytest.mark.parametrize("name", STUDIES)
def test_the_ids_are_the_composed_studys_tasks(name, compose_config):
    # furuta_benchmark extends classic_control through its defaults list: composed, not read as a file
    assert study_task_ids(name) == [entry.id for entry in study_from(compose_config(f"study={name}")).tasks]


def test_an_unknown_study_is_one_line(capsys):
    with pytest.raises(SystemExit) as exit:
        study_task_ids("nosuch")
    assert exit.value.code == 2
    assert capsys.readouterr().err.startswith("error: study=nosuch is not a known study (allowed: ablation, ")
