"""Plugin parameters, checked against the factory's signature before anything runs.

A factory's keyword parameters and their annotations are the contract: an unknown name is
refused, and a value is converted to the annotated type or refused with one line naming the
plugin and the parameter.  ``int`` takes integers (and integral numbers such as ``1e6``, never
``true``), ``float`` takes numbers, ``bool`` takes true/false, ``str`` and ``Path`` take text
(a number is taken as its text), ``Literal[...]`` takes one of its values, ``X | None`` also
takes null; other annotations (lists, tuples, your own types) are passed through unchanged.
A class may describe parameters it takes through ``**kwargs`` with a ``__signature__``.
"""

from __future__ import annotations

import inspect
import math
import types
import typing
from pathlib import Path
from typing import Any, Callable, Literal, Mapping, Sequence, Union

from .errors import ConfigError

_EMPTY = inspect.Parameter.empty


class _Refused(Exception):
    """A value does not fit an annotation; the message says what was expected."""


def signature_parameters(factory: Callable[..., Any]) -> dict[str, inspect.Parameter] | None:
    """Keyword parameters of ``factory`` (following ``**kwargs`` up a class's MRO); None if unknowable."""
    targets: list[Any] = [factory]
    if inspect.isclass(factory) and "__signature__" not in vars(factory):
        targets = [vars(c)["__init__"] for c in inspect.getmro(factory) if "__init__" in vars(c)]
    found: dict[str, inspect.Parameter] = {}
    for fn in targets:
        try:
            sig = inspect.signature(fn, eval_str=True)
        except NameError:
            sig = inspect.signature(fn)
        except (TypeError, ValueError):
            return None
        var_keyword = False
        for p in sig.parameters.values():
            if p.kind is inspect.Parameter.VAR_KEYWORD:
                var_keyword = True
            elif (
                p.kind in (inspect.Parameter.KEYWORD_ONLY, inspect.Parameter.POSITIONAL_OR_KEYWORD) and p.name != "self"
            ):
                found.setdefault(p.name, p)
        if not var_keyword:
            return found
    return None


def config_signature(config: type, *, more: bool = False) -> inspect.Signature:
    """The signature to give an ``__init__(self, **params)`` that passes ``params`` to the dataclass
    ``config``: its fields as keyword parameters, and ``**kwargs`` with ``more`` (the class's base
    takes the rest, e.g. a designer's harness parameters)."""
    own = [
        p.replace(kind=inspect.Parameter.KEYWORD_ONLY)
        for p in inspect.signature(config, eval_str=True).parameters.values()
    ]
    rest = [inspect.Parameter("kwargs", inspect.Parameter.VAR_KEYWORD)] if more else []
    return inspect.Signature([inspect.Parameter("self", inspect.Parameter.POSITIONAL_OR_KEYWORD), *own, *rest])


def convert(value: Any, annotation: Any) -> Any:
    """``value`` as ``annotation`` asks, or :class:`_Refused`."""
    if annotation is _EMPTY or annotation is Any or isinstance(annotation, str):
        return value
    origin = typing.get_origin(annotation)
    if origin in (Union, types.UnionType):
        arms = typing.get_args(annotation)
        if value is None and type(None) in arms:
            return None
        expected = []
        for arm in (a for a in arms if a is not type(None)):
            try:
                return convert(value, arm)
            except _Refused as refused:
                expected.append(str(refused))
        raise _Refused(" or ".join(expected + (["null"] if type(None) in arms else [])))
    if origin is Literal:
        choices = typing.get_args(annotation)
        if any(value == c and type(value) is type(c) for c in choices):
            return value
        raise _Refused("one of " + ", ".join(map(str, choices)))
    if annotation is bool:
        if isinstance(value, bool):
            return value
        raise _Refused("true or false")
    if annotation is int:
        if isinstance(value, int) and not isinstance(value, bool):
            return value
        if isinstance(value, float) and math.isfinite(value) and value.is_integer():
            return int(value)
        raise _Refused("an integer")
    if annotation is float:
        if isinstance(value, (int, float)) and not isinstance(value, bool):
            return float(value)
        raise _Refused("a number")
    if annotation in (str, Path):
        if isinstance(value, str):
            return value
        if isinstance(value, (int, float)) and not isinstance(value, bool):
            return str(value)
        raise _Refused("text" if annotation is str else "a path")
    return value


def check_params(
    kind: str, name: str, factory: Callable[..., Any], params: Mapping[str, Any], reserved: Sequence[str] = ()
) -> dict[str, Any]:
    """``params`` converted to the types ``factory`` declares; one-line errors for the rest."""
    for key in params:
        if key in reserved:
            raise ConfigError(f"{kind} {name!r}: {key!r} is set by the harness (use the --{key} option)")
    accepted = signature_parameters(factory)
    if accepted is None:
        return dict(params)
    unknown = sorted(set(params) - set(accepted))
    if unknown:
        choices = ", ".join(sorted(set(accepted) - set(reserved))) or "(none)"
        raise ConfigError(f"{kind} {name!r} has no parameter {unknown[0]!r}; its parameters: {choices}")
    converted = {}
    for key, value in params.items():
        try:
            converted[key] = convert(value, accepted[key].annotation)
        except _Refused as refused:
            raise ConfigError(f"{kind} {name!r}: parameter {key!r} must be {refused}, got {value!r}") from None
    return converted


def _type_name(annotation: Any) -> str:
    if annotation is _EMPTY:
        return "any"
    if isinstance(annotation, str):
        return annotation
    origin = typing.get_origin(annotation)
    if origin in (Union, types.UnionType):
        return " | ".join("null" if a is type(None) else _type_name(a) for a in typing.get_args(annotation))
    if origin is Literal:
        return " | ".join(map(repr, typing.get_args(annotation)))
    if origin is not None:
        return str(annotation).replace("typing.", "")
    return getattr(annotation, "__name__", str(annotation))


def docstring_params(factory: Callable[..., Any]) -> dict[str, str]:
    """One line per parameter from a ``Parameters:`` (or ``Args:``) section of the factory's
    docstring (a class's own and its ``__init__``'s), each entry ``name: what it does``."""
    texts = [inspect.getdoc(factory) or ""]
    if inspect.isclass(factory):
        texts.append(inspect.getdoc(factory.__init__) or "")
    found: dict[str, str] = {}
    for text in texts:
        section, indent = False, 0
        for line in text.splitlines():
            stripped = line.strip()
            if stripped in ("Parameters:", "Args:"):
                section, indent = True, len(line) - len(line.lstrip())
                continue
            if not section:
                continue
            if stripped and len(line) - len(line.lstrip()) <= indent:
                section = False
                continue
            name, sep, what = stripped.partition(":")
            name = name.strip("`* ").split(" ")[0]
            if sep and name.isidentifier():
                found.setdefault(name, what.strip())
            elif stripped and found:
                last = next(reversed(found))
                found[last] = f"{found[last]} {stripped}"
    return found


def describe(spec: Any) -> list[tuple[str, str, str, str]]:
    """(name, type, default, description) of every parameter a plugin spec takes from users."""
    factory = spec.load()
    accepted = signature_parameters(factory) or {}
    notes = docstring_params(factory)
    rows = []
    for name, p in accepted.items():
        if name in ("shape", "population", "budget", "seed"):  # the harness passes these
            continue
        default = spec.defaults.get(name, p.default)
        rows.append(
            (name, _type_name(p.annotation), "required" if default is _EMPTY else repr(default), notes.get(name, ""))
        )
    return rows
