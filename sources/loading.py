"""Reading untrusted YAML input: safe loading, size limits, and errors that name the place.

Every configuration and scenario file enters the product through :func:`load_model`:
the YAML is parsed with a safe loader (no object-constructing tags, duplicate keys
refused), then validated by a pydantic model. Any problem raises :class:`InputError`,
whose message names the file, the key path (``world.walls[3].points``) or the line
and column, and what is wrong.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, TypeVar

import pydantic
import yaml

__all__ = ["MAX_FILE_BYTES", "InputError", "key_path", "load_model", "read_yaml", "validate"]

MAX_FILE_BYTES = 5_000_000
"""Largest YAML file accepted, in bytes."""

Model = TypeVar("Model", bound=pydantic.BaseModel)


class InputError(ValueError):
    """A configuration or scenario file is wrong; the message says where and why."""


class _StrictSafeLoader(yaml.SafeLoader):
    """PyYAML's safe loader that also refuses duplicate mapping keys."""

    def construct_mapping(self, node: yaml.MappingNode, deep: bool = False) -> dict[Any, Any]:
        seen: set[Any] = set()
        for key_node, _ in node.value:
            key = self.construct_object(key_node, deep=True)
            if key in seen:
                mark = key_node.start_mark
                raise yaml.constructor.ConstructorError(None, None, f"duplicate key {key!r}", mark)
            seen.add(key)
        return super().construct_mapping(node, deep=deep)


_StrictSafeLoader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, _StrictSafeLoader.construct_mapping)


def key_path(loc: tuple[str | int, ...]) -> str:
    """Write a pydantic error location as a key path.

    >>> key_path(("world", "walls", 3, "points"))
    'world.walls[3].points'
    >>> key_path(())
    '(top level)'
    """
    text = ""
    for part in loc:
        text += f"[{part}]" if isinstance(part, int) else (f".{part}" if text else str(part))
    return text or "(top level)"


def read_yaml(text: str, name: str) -> Any:
    """Parse YAML text safely; ``name`` (a file name) is used in error messages."""
    if len(text.encode()) > MAX_FILE_BYTES:
        raise InputError(f"{name}: file is larger than the limit of {MAX_FILE_BYTES} bytes")
    try:
        return yaml.load(text, Loader=_StrictSafeLoader)
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        where = f"line {mark.line + 1}, column {mark.column + 1}" if mark else "unknown position"
        raise InputError(f"{name}: {where}: {exc.problem or exc.context}") from None
    except yaml.YAMLError as exc:
        raise InputError(f"{name}: {exc}") from None


def validate(model: type[Model], data: Any, name: str, at: tuple[str | int, ...] = ()) -> Model:
    """Validate parsed data against a pydantic model; errors name every bad key path.

    ``at`` is the key path of ``data`` inside its file, prefixed to the paths in errors.
    """
    try:
        return model.model_validate(data)
    except pydantic.ValidationError as exc:
        problems = [f"{key_path((*at, *err['loc']))}: {_describe(err)}" for err in exc.errors()]
        raise InputError(f"{name}: " + "; ".join(problems)) from None


def load_model(model: type[Model], source: str | Path) -> Model:
    """Read a YAML file and validate it against ``model``."""
    path = Path(source)
    try:
        if path.stat().st_size > MAX_FILE_BYTES:
            raise InputError(f"{path}: file is larger than the limit of {MAX_FILE_BYTES} bytes")
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"{path}: cannot read file: {exc}") from None
    return validate(model, read_yaml(text, str(path)), str(path))


def _describe(err: Any) -> str:
    """The pydantic message, without its 'Value error, ' prefix, with the offending value."""
    msg = str(err["msg"]).removeprefix("Value error, ").removeprefix("Assertion failed, ")
    if err["type"] == "extra_forbidden":
        return "unknown key"
    if err["type"] == "missing":
        return "required key is missing"
    value = err.get("input")
    shown = repr(value)
    if len(shown) > 60:
        shown = shown[:57] + "..."
    return f"{msg} (got {shown})"
