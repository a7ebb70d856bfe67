"""Post-import hooks: call a function once a module is imported, without importing it (PEP 369's idea, as
``wrapt.when_imported`` provides it).

What needs a heavy library only once something else loads it waits for that import instead of forcing it: the
package's gymnasium ids are registered when gymnasium is imported (:mod:`taskcomplexity`), and an entry point
listens to numba's compilations once numba is imported (:mod:`taskcomplexity.commands.compilation`). So a command
refused for its config, or ``--help``, loads neither.

A module already imported runs the hook at once. Otherwise a finder at the front of ``sys.meta_path`` finds the
module's spec with the other finders, as the import would, and runs the hooks right after the module's own code;
the module keeps its own loader.
"""

from __future__ import annotations

import sys
import threading
from collections.abc import Callable
from types import ModuleType

Hook = Callable[[ModuleType], None]


class _Loader:
    """Runs a module's own loader, then its hooks (an importlib loader: ``create_module``, ``exec_module``)."""

    def __init__(self, loader, hooks: list[Hook]):
        self._loader = loader
        self._hooks = hooks

    def create_module(self, spec):
        return self._loader.create_module(spec)

    def exec_module(self, module: ModuleType) -> None:
        module.__loader__ = module.__spec__.loader = self._loader  # the module keeps its own loader
        self._loader.exec_module(module)
        for hook in self._hooks:
            hook(module)


class _Finder:
    """The front of ``sys.meta_path`` (an importlib meta path finder: ``find_spec``): for a module with hooks, its
    spec as the other finders give it, with a loader that runs the hooks once the module is executed."""

    def __init__(self) -> None:
        self.hooks: dict[str, list[Hook]] = {}
        self.lock = threading.Lock()

    def find_spec(self, name, path, target=None):
        with self.lock:
            if name not in self.hooks:
                return None
        for finder in sys.meta_path:
            if finder is self or not hasattr(finder, "find_spec"):
                continue
            spec = finder.find_spec(name, path, target)
            if spec is not None:
                break
        else:
            return None
        if spec.loader is None or not hasattr(spec.loader, "exec_module"):
            return spec  # a namespace package: nothing runs that the hooks could follow
        with self.lock:
            hooks = self.hooks.pop(name, [])
        if hooks:
            spec.loader = _Loader(spec.loader, hooks)
        return spec


_FINDER = _Finder()


def when_imported(name: str, hook: Hook) -> None:
    """Call ``hook(module)`` once the module ``name`` is imported: now if it is, else right after its import."""
    module = sys.modules.get(name)
    if module is not None:
        hook(module)
        return
    with _FINDER.lock:
        _FINDER.hooks.setdefault(name, []).append(hook)
    if _FINDER not in sys.meta_path:
        sys.meta_path.insert(0, _FINDER)


def cancel(name: str, hook: Hook) -> bool:
    """Forget ``hook`` of module ``name`` if it has not run yet; whether it was pending."""
    with _FINDER.lock:
        pending = _FINDER.hooks.get(name, [])
        if hook in pending:
            pending.remove(hook)
            if not pending:
                del _FINDER.hooks[name]
            return True
    return False
