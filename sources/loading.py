"""Reading untrusted YAML input: bounded reads, safe loading, limits, and errors that name the place.

Every configuration and scenario file enters the product through :func:`read_document`
(or :func:`parse_document` for text): the file must be a regular file of at most
:data:`MAX_FILE_BYTES` bytes (at most that many plus one are read, so ``/dev/zero`` or a
FIFO costs nothing); the YAML is parsed with a safe loader (libyaml's ``CSafeLoader``
where installed, else PyYAML's ``SafeLoader``: no object-constructing tags, duplicate
keys refused, standard merge keys ``<<`` supported, plain scalars read as YAML 1.2's core
schema has them: ``1e8`` a number, ``045`` forty-five, ``0o17`` octal, ``yes``, ``8_0``,
``0b10``, ``1:20`` and dates strings), and the composed document is measured before
anything is constructed: at most :data:`MAX_DEPTH` levels of nesting
and :data:`MAX_NODES` nodes once aliases are expanded (an alias bomb is refused in
milliseconds), no alias inside the node it names. A :class:`Document` then validates
its data against a pydantic model. Any problem raises :class:`InputError`, whose message
names the file, the key path (``world.walls[3].points``), what is wrong and the line
(``FILE: PATH: PROBLEM (line N)``; a syntax error: ``FILE: line N, column M: PROBLEM``):

>>> doc = parse_document("a: &x [1, 2]\\nb: {<<: {c: 1}, d: *x}", "t.yaml")
>>> doc.data
{'a': [1, 2], 'b': {'c': 1, 'd': [1, 2]}}
>>> parse_document("[1e8, 1e-9, 1.5e+3, 12, e5, 1e]", "n.yaml").data
[100000000.0, 1e-09, 1500.0, 12, 'e5', '1e']
>>> parse_document("[045, -07, 0o17, 0x1F, .5, -.inf, 8_0, 0b10, 1:20, yes, True, 2024-01-01, ~]", "c.yaml").data
[45, -7, 15, 31, 0.5, -inf, '8_0', '0b10', '1:20', 'yes', True, '2024-01-01', None]
>>> doc.line(("b", "d"))
2
>>> try:
...     parse_document("a: " + "[" * 40 + "]" * 40, "deep.yaml")
... except InputError as exc:
...     print(exc)
deep.yaml: line 1, column 11: nesting depth of at least 33, more than the limit of 32
"""

from __future__ import annotations

import os
import re
import reprlib
import stat
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TypeVar

import pydantic
import yaml

__all__ = [
    "MAX_DEPTH",
    "MAX_FILE_BYTES",
    "MAX_NODES",
    "MAX_REPORTED_PROBLEMS",
    "Document",
    "InputError",
    "key_path",
    "load_model",
    "parse_document",
    "read_document",
    "shown",
    "validate",
]

MAX_FILE_BYTES = 1_000_000
"""Largest YAML file accepted, in bytes. Scenarios at every count limit take about 0.3 MB; reading a
2 MB file of walls (refused for its count of wall segments) took up to 21 s on a loaded machine."""
MAX_DEPTH = 32
"""Deepest nesting of collections (a scalar at the top level has depth 1)."""
MAX_NODES = 1_000_000
"""Most YAML nodes (scalars and collections) in one file, every alias expanded."""
MAX_REPORTED_PROBLEMS = 10
"""Most problems one error message lists (the rest are counted)."""

Model = TypeVar("Model", bound=pydantic.BaseModel)

_SHOWN = reprlib.Repr()
_SHOWN.maxlevel, _SHOWN.maxstring, _SHOWN.maxother = 3, 40, 40
_SHOWN.maxlist = _SHOWN.maxtuple = _SHOWN.maxdict = _SHOWN.maxset = 4


class InputError(ValueError):
    """A configuration or scenario file is wrong; the message says where and why."""


def shown(value: Any, width: int = 60) -> str:
    """A short repr of a value of any size, for error messages (never the repr of a huge value).

    >>> shown(list(range(10**6)))
    '[0, 1, 2, 3, ...]'
    >>> len(shown("x" * 10**6)) <= 60
    True
    """
    text = _SHOWN.repr(value)
    return text if len(text) <= width else text[: width - 3] + "..."


_BaseLoader: type[yaml.SafeLoader] = getattr(yaml, "CSafeLoader", yaml.SafeLoader)


class _StrictLoader(_BaseLoader):  # type: ignore[misc, valid-type]
    """The safe loader (libyaml's where installed) that refuses duplicate keys and resolves merge keys."""

    def construct_mapping(self, node: yaml.MappingNode, deep: bool = False) -> dict[Any, Any]:
        """Construct a mapping; a key written twice is refused (a key merged by ``<<`` may be overridden)."""
        seen: set[Any] = set()
        for key_node, _ in node.value:
            if key_node.tag == "tag:yaml.org,2002:merge":
                continue
            key = self.construct_object(key_node, deep=True)
            try:
                duplicate = key in seen
            except TypeError:  # an unhashable key: the base class refuses it, with its line
                break
            if duplicate:
                raise yaml.constructor.ConstructorError(None, None, f"duplicate key {shown(key)}", key_node.start_mark)
            seen.add(key)
        return super().construct_mapping(node, deep=deep)


def _construct_int(loader: yaml.SafeLoader, node: yaml.ScalarNode) -> int:
    """An integer of YAML 1.2's core schema: decimal (``010`` is ten), ``0o`` octal or ``0x`` hexadecimal."""
    text = loader.construct_scalar(node)
    base = {"0o": 8, "0x": 16}.get(text[:2], 10)
    return int(text[2:] if base != 10 else text, base)


_YAML_1_1_ONLY = {f"tag:yaml.org,2002:{t}" for t in ("bool", "int", "float", "timestamp", "value")}
_StrictLoader.yaml_implicit_resolvers = {  # YAML 1.1's plain scalars that YAML 1.2 reads otherwise: replaced below
    first: [(tag, regexp) for tag, regexp in resolvers if tag not in _YAML_1_1_ONLY]
    for first, resolvers in _BaseLoader.yaml_implicit_resolvers.items()
}
for _tag, _pattern, _first in (  # YAML 1.2's core schema; an integer before a float, which would match it too
    ("bool", r"true|True|TRUE|false|False|FALSE", "tTfF"),
    ("int", r"[-+]?[0-9]+|0o[0-7]+|0x[0-9a-fA-F]+", "-+0123456789"),
    (
        "float",
        r"[-+]?(?:\.[0-9]+|[0-9]+(?:\.[0-9]*)?)(?:[eE][-+]?[0-9]+)?|[-+]?\.(?:inf|Inf|INF)|\.(?:nan|NaN|NAN)",
        "-+.0123456789",
    ),
):
    _StrictLoader.add_implicit_resolver(f"tag:yaml.org,2002:{_tag}", re.compile(f"^(?:{_pattern})$"), list(_first))
_StrictLoader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, _StrictLoader.construct_mapping)
_StrictLoader.add_constructor("tag:yaml.org,2002:int", _construct_int)


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


def _children(node: yaml.Node) -> list[yaml.Node]:
    if isinstance(node, yaml.SequenceNode):
        return list(node.value)
    if isinstance(node, yaml.MappingNode):
        return [item for pair in node.value for item in pair]
    return []


def _mark(node: yaml.Node) -> str:
    return f"line {node.start_mark.line + 1}, column {node.start_mark.column + 1}"


def _measure(root: yaml.Node, name: str) -> None:
    """Refuse a composed document nested deeper than MAX_DEPTH, over MAX_NODES expanded, or with a cyclic alias.

    One iterative walk over the distinct nodes (an alias shares its anchor's node), so it
    costs the size of the file, not of the expanded document.
    """
    size: dict[int, int] = {}
    height: dict[int, int] = {}
    entered: set[int] = set()
    stack: list[tuple[yaml.Node, bool]] = [(root, False)]
    scalar = yaml.ScalarNode
    while stack:
        node, done = stack.pop()
        key = id(node)
        if done:  # every collection below is measured; a scalar counts 1 node, 1 level
            total, deepest = 1, 0
            for kid in _children(node):
                if kid.__class__ is scalar:
                    total, deepest = total + 1, max(deepest, 1)
                else:
                    total, deepest = total + size[id(kid)], max(deepest, height[id(kid)])
            size[key], height[key] = total, deepest + 1
            if deepest + 1 > MAX_DEPTH:
                raise InputError(
                    f"{name}: {_mark(node)}: nesting depth of at least {deepest + 1}, more than the limit of {MAX_DEPTH}"
                )
            if total > MAX_NODES:
                raise InputError(
                    f"{name}: {_mark(node)}: {total} nodes once aliases are expanded, more than the limit of {MAX_NODES}"
                )
            continue
        if key in size:
            continue
        if key in entered:  # entered, not finished: an ancestor of the node being walked
            raise InputError(
                f"{name}: {_mark(node)}: an alias refers to a node that contains it (a recursive structure)"
            )
        entered.add(key)
        stack.append((node, True))
        stack.extend((kid, False) for kid in _children(node) if kid.__class__ is not scalar)


@dataclass(frozen=True)
class Document:
    """A parsed YAML file: its data and its composed nodes (for the line of a key path).

    Attributes
    ----------
    name : the file name used in messages.
    data : the constructed data (dicts, lists, scalars).
    root : the composed root node (merge keys already flattened), or ``None`` for an empty file.
    """

    name: str
    data: Any
    root: yaml.Node | None

    def line(self, loc: tuple[str | int, ...]) -> int | None:
        """The 1-based line of the deepest node of ``loc`` found in the file (``None`` for an empty file)."""
        node = self.root
        if node is None:
            return None
        mark = node.start_mark
        for part in loc:
            if isinstance(node, yaml.SequenceNode) and isinstance(part, int) and 0 <= part < len(node.value):
                node = node.value[part]
                mark = node.start_mark
            elif isinstance(node, yaml.MappingNode):
                # the last one wins: an explicit key overrides a merged one
                matches = [(k, v) for k, v in node.value if isinstance(k, yaml.ScalarNode) and k.value == str(part)]
                if not matches:
                    break
                key, node = matches[-1]
                mark = key.start_mark  # the key's line: an aliased value's own mark is its anchor's
            else:
                break
        return mark.line + 1

    def error(self, loc: tuple[str | int, ...], problem: str) -> InputError:
        """An InputError naming the file, the line and the key path of ``loc``, and the problem."""
        line = self.line(loc)
        return InputError(f"{self.name}: {key_path(loc)}: {problem}{f' (line {line})' if line is not None else ''}")

    def validate(self, model: type[Model], at: tuple[str | int, ...] = ()) -> Model:
        """Validate the data (or the part at key path ``at``) against a model; errors name every bad key path."""
        data = self.data
        for part in at:
            data = data[part]
        return validate(model, data, self.name, at, self)


def validate(
    model: type[Model], data: Any, name: str, at: tuple[str | int, ...] = (), document: Document | None = None
) -> Model:
    """Validate parsed data against a pydantic model; errors name every bad key path (and line, given ``document``).

    ``at`` is the key path of ``data`` inside its file, prefixed to the paths in errors.
    At most :data:`MAX_REPORTED_PROBLEMS` problems are listed.
    """
    if data is None and not at:
        raise InputError(f"{name}: the file is empty (or holds only comments): nothing to read")
    try:
        return model.model_validate(data)
    except pydantic.ValidationError as exc:
        errors = exc.errors()
        problems = []
        for err in errors[:MAX_REPORTED_PROBLEMS]:
            loc = (*at, *err["loc"])
            line = document.line(loc) if document is not None else None
            problems.append(f"{key_path(loc)}: {_describe(err)}{f' (line {line})' if line is not None else ''}")
        if len(errors) > MAX_REPORTED_PROBLEMS:
            problems.append(f"and {len(errors) - MAX_REPORTED_PROBLEMS} more problems")
        raise InputError(f"{name}: " + "; ".join(problems)) from None


def parse_document(text: str, name: str) -> Document:
    """Parse YAML text safely, within the limits; ``name`` (a file name) is used in error messages.

    Raises
    ------
    InputError
        For text over :data:`MAX_FILE_BYTES`, a syntax error (with line and column), an
        unknown or unsafe tag, a duplicate key, nesting over :data:`MAX_DEPTH`, more than
        :data:`MAX_NODES` nodes with aliases expanded, or a recursive alias.
    """
    if len(text) > MAX_FILE_BYTES or len(text.encode()) > MAX_FILE_BYTES:
        raise InputError(f"{name}: file is larger than the limit of {MAX_FILE_BYTES} bytes")
    loader = _StrictLoader(text)
    try:
        root = loader.get_single_node()
        if root is None:
            return Document(name, None, None)
        _measure(root, name)
        return Document(name, loader.construct_document(root), root)
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        where = f"line {mark.line + 1}, column {mark.column + 1}" if mark else "unknown position"
        problem = exc.problem or exc.context
        if problem and "maximum nesting depth" in problem:  # libyaml's own limit (1000), met before ours is measured
            problem = f"nesting deeper than the limit of {MAX_DEPTH}"
        lines = text.splitlines()
        if mark and mark.line < len(lines) and "\t" in lines[mark.line]:
            problem = f"{problem} (a tab: YAML indents with spaces only)"
        raise InputError(f"{name}: {where}: {problem}") from None
    except yaml.YAMLError as exc:
        raise InputError(f"{name}: {exc}") from None
    except RecursionError:  # PyYAML's pure-Python composer, before the depth is measured
        raise InputError(f"{name}: nesting is deeper than the limit of {MAX_DEPTH}") from None
    finally:
        loader.dispose()


def read_document(source: str | Path) -> Document:
    """Read and parse a YAML file: a regular file of at most :data:`MAX_FILE_BYTES` bytes.

    The file is opened without blocking and refused unless it is a regular file, so a
    FIFO, a device (``/dev/zero``) or a directory is refused at once; at most
    ``MAX_FILE_BYTES + 1`` bytes are read.

    Raises
    ------
    InputError
        If the file cannot be read, is not a regular file, is too large, is not UTF-8,
        or is not valid YAML within the limits (see :func:`parse_document`).
    """
    path = Path(source)
    try:
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0))
    except OSError as exc:
        raise InputError(f"{path}: cannot read file: {exc.strerror or exc}") from None
    if not stat.S_ISREG(os.fstat(fd).st_mode):
        os.close(fd)
        raise InputError(f"{path}: not a regular file (a directory, FIFO, socket or device cannot be read)")
    with os.fdopen(fd, "rb") as file:
        try:
            raw = file.read(MAX_FILE_BYTES + 1)
        except OSError as exc:
            raise InputError(f"{path}: cannot read file: {exc.strerror or exc}") from None
    if len(raw) > MAX_FILE_BYTES:
        raise InputError(f"{path}: file is larger than the limit of {MAX_FILE_BYTES} bytes")
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise InputError(f"{path}: not UTF-8 text: byte {exc.start} cannot be decoded") from None
    return parse_document(text, str(path))


def load_model(model: type[Model], source: str | Path) -> Model:
    """Read a YAML file and validate it against ``model``."""
    return read_document(source).validate(model)


def _describe(err: Any) -> str:
    """The pydantic message, without its 'Value error, ' prefix, with the offending value (shortened)."""
    msg = str(err["msg"]).removeprefix("Value error, ").removeprefix("Assertion failed, ")
    if err["type"] == "extra_forbidden":
        return "unknown key"
    if err["type"] == "missing":  # a mapping's key, or an item of a fixed-length list (a pose's heading)
        return "required item is missing" if isinstance(err["loc"][-1], int) else "required key is missing"
    if isinstance(err.get("input"), dict):  # a section's own check: its line says where, its text is long
        return msg
    if err["type"] == "bool_type" and str(err.get("input")).lower() in {"yes", "no", "on", "off", "y", "n"}:
        return f"{msg} (got {err['input']!r}: YAML 1.2 writes true or false)"
    return f"{msg} (got {shown(err.get('input'))})"
