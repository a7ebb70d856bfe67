"""From Hydra/OmegaConf configuration to the library's plain dataclasses.

The library never needs Hydra: every stage takes frozen dataclasses. :func:`build` turns a config
node (an OmegaConf ``DictConfig`` or a plain ``dict``) into such a dataclass, checking keys and types
against the dataclass fields and calling its ``validate()``; any problem raises :class:`ConfigError`
with one line naming the full key, the value received and what is allowed.
"""

from __future__ import annotations

import dataclasses
import inspect
import math
import types
import typing
from collections.abc import Mapping, Sequence
from typing import Any, TypeVar

from taskcomplexity.errors import ConfigError

T = TypeVar("T")

EXACT_FLOAT_INTEGER = 2**53
"""The largest magnitude up to which a float (``1e6`` typed on the command line) holds every integer exactly: an
integer setting accepts a whole float up to it, and refuses one beyond it (``1e99`` is not the integer typed)."""


def setting(default: Any, *, result: bool = True) -> Any:
    """A settings field that declares whether it changes the stage's result.

    Cache keys hash exactly the fields declared ``result=True`` (the default for undeclared fields),
    so the key follows from this one declaration (:func:`result_identity`).
    """
    if isinstance(default, (list, dict, set)):
        raise TypeError("use an immutable default (tuple) for settings fields")
    return dataclasses.field(default=default, metadata={"result": result})


def result_identity(settings: Any) -> dict:
    """The fields of a settings dataclass that change its stage's result (name → value)."""
    return {f.name: getattr(settings, f.name) for f in dataclasses.fields(settings) if f.metadata.get("result", True)}


def plain(node: Any) -> Any:
    try:
        from omegaconf import DictConfig, ListConfig, OmegaConf
    except ImportError:  # pragma: no cover
        return node
    if isinstance(node, (DictConfig, ListConfig)):
        return OmegaConf.to_container(node, resolve=True)
    return node


def _convert(value: Any, hint: Any, key: str) -> Any:
    origin = typing.get_origin(hint)
    args = typing.get_args(hint)
    if origin in (typing.Union, types.UnionType):
        if value is None and type(None) in args:
            return None
        inner = [a for a in args if a is not type(None)]
        first_error = None
        for option in inner:  # e.g. ``int | str`` for ``metrics.bins``: an integer, or "auto"
            try:
                return _convert(value, option, key)
            except ConfigError as err:
                first_error = first_error or err
        raise first_error
    if dataclasses.is_dataclass(hint):
        return build(hint, value, key)
    if origin is tuple:
        if isinstance(value, (str, bytes)) or not isinstance(value, Sequence):
            raise ConfigError(f"{key} must be a list, got {value!r}")
        item = args[0]
        if len(args) == 2 and args[1] is Ellipsis:
            return tuple(_convert(v, item, f"{key}[{i}]") for i, v in enumerate(value))
        if len(value) != len(args):
            raise ConfigError(f"{key} must be a list of {len(args)} values, got {value!r}")
        return tuple(_convert(v, a, f"{key}[{i}]") for i, (v, a) in enumerate(zip(value, args, strict=True)))
    if origin in (Mapping, dict) or hint is dict:
        if not isinstance(value, Mapping):
            raise ConfigError(f"{key} must be a mapping, got {value!r}")
        return dict(value)
    if hint is float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise ConfigError(f"{key} must be a number, got {value!r}")
        return float(value)
    if hint is int:
        if isinstance(value, float) and value.is_integer() and abs(value) <= EXACT_FLOAT_INTEGER:
            value = int(value)  # 1e6 typed for 1000000
        if isinstance(value, bool) or not isinstance(value, int):
            beyond = isinstance(value, float) and math.isfinite(value) and abs(value) > EXACT_FLOAT_INTEGER
            why = f" ({value:g} is beyond 2**53, where a number with an exponent is no exact integer)" if beyond else ""
            raise ConfigError(f"{key} must be an integer, got {value!r}{why}")
        return value
    if hint is bool:
        if not isinstance(value, bool):
            raise ConfigError(f"{key} must be true or false, got {value!r}")
        return value
    if hint is str:
        if not isinstance(value, str):
            raise ConfigError(f"{key} must be a string, got {value!r}")
        return value
    return value


def build(cls: type[T], node: Any, key: str) -> T:
    """Build dataclass ``cls`` from config ``node``, naming ``key`` in every error.

    Parameters
    ----------
    cls : dataclass type
    node : DictConfig or mapping
    key : str
        Dotted config path of ``node`` (e.g. ``"arm"``), used in messages.
    """
    node = plain(node)
    if isinstance(node, cls):
        return node
    if not isinstance(node, Mapping):
        raise ConfigError(f"{key} must be a mapping of {cls.__name__} fields, got {node!r}")
    hints = typing.get_type_hints(cls)
    fields = {f.name: f for f in dataclasses.fields(cls) if f.init}
    unknown = sorted(set(node) - set(fields))
    if unknown:
        raise ConfigError(f"{key}.{unknown[0]} is not a known key (allowed: {', '.join(sorted(fields))})")
    kwargs = {}
    for name, field in fields.items():
        if name in node:
            kwargs[name] = _convert(node[name], hints[name], f"{key}.{name}")
        elif field.default is dataclasses.MISSING and field.default_factory is dataclasses.MISSING:
            raise ConfigError(f"{key}.{name} is required")
    obj = cls(**kwargs)
    validate = getattr(obj, "validate", None)
    if callable(validate):
        # Nested specs (e.g. LinkSpec) name their own key in messages; top-level ones know theirs.
        takes_key = len(inspect.signature(validate).parameters) == 1
        validate(key) if takes_key else validate()
    return obj


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
