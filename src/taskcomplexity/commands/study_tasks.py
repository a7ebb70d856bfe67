"""Print a study's task ids, comma-separated: the values of a Hydra sweep over ``sac.entry`` (``make paper-jobs``).

    python -m taskcomplexity.commands.study_tasks seven_tasks      # one_link_1m0-dense,…,two_link-sparse

The study is a file of the packaged ``conf/study/`` or a path to a study YAML file of your own.
"""

from __future__ import annotations

import sys
from pathlib import Path

from taskcomplexity.cli import CONF_DIR, fail


def study_task_ids(name: str) -> list[str]:
    """The ids of the tasks of study ``name`` (a packaged study's name or a YAML file's path), in study order.

    A packaged study is composed as the entry points compose it (a study may extend another through its Hydra
    defaults list: ``furuta_benchmark`` extends ``classic_control``); a file of your own is read as it is.
    """
    from taskcomplexity.study_data import load_study_file

    path = Path(name) if name.endswith((".yaml", ".yml")) else CONF_DIR / "study" / f"{name}.yaml"
    if not path.is_file():
        allowed = sorted(p.stem for p in (CONF_DIR / "study").glob("*.yaml"))
        fail(f"study={name} is not a known study (allowed: {', '.join(allowed)}, or a path to a .yaml file)")
    if path.parent != CONF_DIR / "study":
        return [entry.id for entry in load_study_file(path).tasks]
    from hydra import compose, initialize_config_dir

    from taskcomplexity.study.plan import study_from

    with initialize_config_dir(config_dir=str(CONF_DIR), version_base="1.3"):
        return [entry.id for entry in study_from(compose("config", overrides=[f"study={name}"])).tasks]


def main(argv: list[str] | None = None) -> None:
    args = sys.argv[1:] if argv is None else argv
    if len(args) != 1:
        fail("usage: python -m taskcomplexity.commands.study_tasks <study name or study .yaml>")
    print(",".join(study_task_ids(args[0])))


if __name__ == "__main__":
    main()
