"""Post-import hooks (taskcomplexity.post_import): a function called once a module is imported, never importing it."""

from __future__ import annotations

import subprocess
import sys
import textwrap


def run(code: str) -> str:
    done = subprocess.run([sys.executable, "-c", textwrap.dedent(code)], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    return done.stdout.strip()


def test_a_hook_runs_once_after_the_modules_own_code_and_the_module_keeps_its_loader():
    assert run("""
        import sys
        from taskcomplexity.post_import import when_imported
        seen = []
        when_imported("colorsys", lambda module: seen.append((module.__name__, hasattr(module, "rgb_to_hsv"))))
        assert "colorsys" not in sys.modules and seen == []
        import colorsys
        import colorsys
        print(seen, type(colorsys.__loader__).__name__, type(colorsys.__spec__.loader).__name__)
    """) == "[('colorsys', True)] SourceFileLoader SourceFileLoader"


def test_a_module_imported_already_runs_the_hook_at_once_and_a_cancelled_hook_never_runs():
    assert run("""
        import json
        from taskcomplexity.post_import import cancel, when_imported
        seen = []
        when_imported("json", lambda module: seen.append(module.__name__))
        hook = lambda module: seen.append("never")
        when_imported("colorsys", hook)
        print(cancel("colorsys", hook), cancel("colorsys", hook))
        import colorsys
        print(seen)
    """).splitlines() == ["True False", "['json']"]
