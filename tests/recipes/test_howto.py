"""The convention of the how-to pages' blocks (howto.py): which blocks change a file, and how."""

from __future__ import annotations

import pytest
from howto import Block, apply, blocks, skip_if_followed, stated_counts, touched

PAGE = '''# A page

Change **two files**, then **one more file**.

```python
# src/package/new.py
VALUE = 1
```

```bash
.venv/bin/python pipelines/study.py
```

## Second part

```yaml
# conf/config.yaml: insert after: - a: default
  - b: default
```

```yaml
# conf/config.yaml: insert before: - a: default
  - first: default
```

```python
# src/package/new.py: append
OTHER = 2
```

```python
# an example to read, not a file
print("hello")
```
'''


def test_only_blocks_that_name_a_file_change_one_in_page_order():
    found = blocks(PAGE)
    assert [(b.path, b.how, b.line, b.section) for b in found] == [
        ("src/package/new.py", "file", "", ""),  # no second-level heading above it
        ("conf/config.yaml", "after", "- a: default", "Second part"),
        ("conf/config.yaml", "before", "- a: default", "Second part"),
        ("src/package/new.py", "append", "", "Second part")]
    assert touched(found) == ["src/package/new.py", "conf/config.yaml"]
    assert stated_counts(PAGE) == [2, 1]


def test_blocks_create_append_and_insert_around_one_line(tmp_path):
    (tmp_path / "conf").mkdir()
    (tmp_path / "conf" / "config.yaml").write_text("defaults:\n  - a: default\n  - c: default\n")
    changed = apply(tmp_path, blocks(PAGE))
    assert changed == [tmp_path / "src" / "package" / "new.py", tmp_path / "conf" / "config.yaml"]
    assert (tmp_path / "src" / "package" / "new.py").read_text() == "VALUE = 1\nOTHER = 2\n"
    assert (tmp_path / "conf" / "config.yaml").read_text() == (
        "defaults:\n  - first: default\n  - a: default\n  - b: default\n  - c: default\n")


def test_an_unknown_marker_or_an_anchor_not_there_once_is_refused(tmp_path):
    with pytest.raises(ValueError, match=r"block for conf/x.yaml: unknown marker 'add the line' \(allowed: append"):
        blocks("```yaml\n# conf/x.yaml: add the line\nkey: 1\n```\n")
    (tmp_path / "x.yaml").write_text("a: 1\na: 1\n")
    twice = Block("x.yaml", "after", "a: 1", "b: 2\n", "")
    with pytest.raises(ValueError, match=r"x.yaml: the line 'a: 1' is there 2 times, not once"):
        apply(tmp_path, [twice])
    with pytest.raises(ValueError, match=r"is there 0 times"):
        apply(tmp_path, [Block("x.yaml", "before", "c: 3", "b: 2\n", "")])


def test_a_page_already_followed_in_the_repository_is_skipped_not_declared_twice(tmp_path):
    chosen = blocks(PAGE)
    skip_if_followed(chosen, source=tmp_path)  # not followed: the test goes on
    apply(tmp_path, chosen[:1])
    with pytest.raises(pytest.skip.Exception, match=r"already holds this page's example \(src/package/new.py\)"):
        skip_if_followed(chosen, source=tmp_path)
