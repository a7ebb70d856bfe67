"""Cache keys: a hash of the stage's name, its declared numerics version, its canonical settings subset and
the keys of its inputs.

Each stage module declares, once, beside its ``STAGE`` name, a :class:`Numerics`: the version of its
numbers and the modules that compute them. The key holds the **version**, not the code:

- Hashing code (as the keys did up to this change: the syntax trees of a stage module's whole import
  closure) re-keys results whenever a function moves between modules or a log line changes, which throws
  away hours of SAC curves for a refactor, and makes the code bend around the keys. Hashing only the
  declared modules' source would still re-key on every refactor inside them (e.g. the bit-identical
  rewrites of the RWG kernels), and on none of the changes that reach the numbers from elsewhere.
- The module names are not hashed either: moving a declared module (say into a package of its own) is a
  layout change, and re-keying on it would cost the same hours for the same numbers.
- What guards the version is a **golden run** per stage (``tests/golden``): fixed tiny settings whose
  artefact's values are recorded and committed with the version they were recorded at, and compared within a
  stated tolerance. When the numbers change at the same version the test fails ("bump the version"); when the
  version moved it asks to re-record. So a numbers change comes with a version bump (named in its commit),
  and everything else (layout, logging, glue) changes no key.
- The declared modules say where a change needs that thought: ``tests/stages/test_numerics.py`` checks
  that every module a stage reaches (stopping at the stages it reads through their keys) is either
  declared or listed there as glue that computes no number, and that every declared module exists.

After an upgrade, a stage recomputes only when its version moved or its settings changed, and the stages
downstream with it (their keys hold its key).
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass
from typing import Any

from taskcomplexity.config import canonical

PACKAGE = "taskcomplexity"


@dataclass(frozen=True)
class Numerics:
    """What a stage's numbers are a function of, besides its settings and inputs.

    Attributes
    ----------
    version : int
        Bump it when the stage's numbers change (same settings, same inputs, other artefact); the keys
        change with it, so no artefact of the older numbers is served.
    modules : tuple of str
        The ``taskcomplexity`` modules (dotted, without the package prefix) that compute the stage's
        numbers: a change of a number in one of them needs a bump. Not part of the key.
    """

    version: int
    modules: tuple[str, ...]

    def __post_init__(self) -> None:
        if isinstance(self.version, bool) or not isinstance(self.version, int) or self.version < 1:
            raise ValueError(f"a numerics version is an integer >= 1, got {self.version!r}")
        if len(set(self.modules)) != len(self.modules):
            raise ValueError(f"a module is declared twice in {self.modules}")

    def qualified(self) -> tuple[str, ...]:
        """The declared modules' importable names (``taskcomplexity.<module>``)."""
        return tuple(f"{PACKAGE}.{m}" for m in self.modules)


def stage_key(stage: str, numerics: Numerics, payload: dict[str, Any]) -> str:
    """16 hex digits identifying ``payload`` (settings and input keys) for ``stage`` at ``numerics.version``."""
    text = json.dumps({"stage": stage, "version": numerics.version, "payload": canonical(payload)}, sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()[:16]
