"""Cache keys: a hash of the canonical (sorted, resolved) config subset, input keys and format version."""

from __future__ import annotations

import dataclasses
import hashlib
import json
from typing import Any


def canonical(value: Any) -> Any:
    """Plain JSON-able form of dataclasses, tuples, numpy scalars and mappings (keys sorted on dump)."""
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return {f.name: canonical(getattr(value, f.name)) for f in dataclasses.fields(value)}
    if isinstance(value, dict):
        return {str(k): canonical(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [canonical(v) for v in value]
    if hasattr(value, "item") and callable(value.item):
        return value.item()
    return value


def stage_key(stage: str, version: int, payload: dict[str, Any]) -> str:
    """16 hex digits identifying ``payload`` for ``stage`` at format ``version``."""
    text = json.dumps({"stage": stage, "version": version, "payload": canonical(payload)}, sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()[:16]
