"""Mitsuba 3 XML as a tree of located elements: defaults, ``$name`` substitution, includes, refs.

``read_tree(path, defines)`` parses the file with expat (which reports the line of every start
tag), expands ``<include filename>`` (cycle-checked), substitutes ``$name`` in every attribute
from ``<default name value>`` and the ``-D name=value`` defines (a define wins over a default, as
in Mitsuba's ``load_file(path, **params)``), and indexes every element with an ``id`` so
``<ref id>`` can be followed. ``<path value>`` adds a search folder as in Mitsuba's file resolver
(:func:`resolve_file`), so published scenes that keep their meshes in a shared folder
(``<path value="../../common"/>`` in Mitsuba's documentation scenes) load. Every error is one :class:`XmlError` line
``file.xml:LINE: <tag type="...">: what is wrong``.
"""

from __future__ import annotations

import re
import xml.parsers.expat
from dataclasses import dataclass, field
from pathlib import Path

from ..diagnostics import SceneError

#: Largest XML file read (bytes); meshes live in their own files.
MAX_XML_BYTES = 16 * 2**20
#: Most elements a scene (all includes together) may hold: bounds memory and time.
MAX_ELEMENTS = 200_000
#: Deepest include chain (a cycle is reported by name long before this).
MAX_INCLUDE_DEPTH = 32

_PARAM = re.compile(r"\$([A-Za-z_][A-Za-z0-9_]*)")


class XmlError(SceneError):
    """A Mitsuba XML scene mistake or a refused feature: ``file:line: <tag type=..>: reason``."""


@dataclass
class Node:
    """One XML element: tag, attributes (after substitution), children, and where it was written."""

    tag: str
    attrs: dict[str, str]
    file: Path
    line: int
    children: list[Node] = field(default_factory=list)
    #: The scene's search folders (``<path>`` folders, newest first, then the scene file's folder):
    #: one list shared by every node of a tree, so a later ``<path>`` counts everywhere, as in
    #: Mitsuba, which resolves file names when it instantiates plugins, after parsing.
    search: list[Path] = field(default_factory=list, repr=False)

    @property
    def label(self) -> str:
        """``<tag type="..." name="...">`` (type, name or id: whichever it has), for messages."""
        keys = [k for k in ("type", "name", "id") if k in self.attrs][:2]
        inner = "".join(f' {k}="{self.attrs[k]}"' for k in keys)
        return f"<{self.tag}{inner}>"

    def error(self, reason: str) -> XmlError:
        """An :class:`XmlError` located at this element."""
        return XmlError(self.file, self.line, self.label, reason)

    def get(self, key: str, default: str | None = None) -> str | None:
        return self.attrs.get(key, default)

    def need(self, key: str) -> str:
        """Attribute ``key``; a located error if it is missing."""
        if key not in self.attrs:
            raise self.error(f"missing attribute {key!r}")
        return self.attrs[key]


def _parse_file(path: Path) -> Node:
    """The root element of ``path`` with every element's line (no substitution yet)."""
    try:
        size = path.stat().st_size
        if size > MAX_XML_BYTES:
            raise XmlError(path, None, "", f"{size} bytes is not a scene file (at most "
                           f"{MAX_XML_BYTES // 2**20} MiB)")
        data = path.read_bytes()
    except OSError as exc:
        raise XmlError(path, None, "", f"cannot read scene file: {exc.strerror or exc}") from None
    parser = xml.parsers.expat.ParserCreate()
    stack: list[Node] = []
    root: list[Node] = []
    count = [0]

    def start(tag, attrs):
        count[0] += 1
        if count[0] > MAX_ELEMENTS:
            raise XmlError(path, parser.CurrentLineNumber, f"<{tag}>",
                           f"more than {MAX_ELEMENTS} elements; not a scene file mcpt reads")
        node = Node(tag, dict(attrs), path, parser.CurrentLineNumber)
        (stack[-1].children if stack else root).append(node)
        stack.append(node)

    def end(tag):
        stack.pop()

    parser.StartElementHandler, parser.EndElementHandler = start, end
    # Entities could expand without bound ("billion laughs"): a scene file has no use for a DTD.
    parser.StartDoctypeDeclHandler = lambda *a: (_ for _ in ()).throw(
        XmlError(path, parser.CurrentLineNumber, "<!DOCTYPE>", "DTDs and entities are not accepted"))
    try:
        parser.Parse(data, True)
    except xml.parsers.expat.ExpatError as exc:
        raise XmlError(path, exc.lineno, "", f"malformed XML: "
                       f"{xml.parsers.expat.ErrorString(exc.code)}") from None
    if not root:
        raise XmlError(path, 1, "", "no root element (expected <scene version=...>)")
    return root[0]


def _substitute(node: Node, params: dict[str, str]) -> None:
    """Replace ``$name`` in every attribute of ``node`` (not its children) from ``params``."""
    for key, value in node.attrs.items():
        if "$" not in value:
            continue

        def repl(m: re.Match, key=key, value=value) -> str:
            if m.group(1) not in params:
                known = ", ".join(sorted(params)) or "none"
                raise node.error(f"undefined parameter ${m.group(1)} in {key}={value!r} (give it a "
                                 f"<default name=\"{m.group(1)}\" value=...> or -D "
                                 f"{m.group(1)}=VALUE; defined: {known})")
            return params[m.group(1)]

        node.attrs[key] = _PARAM.sub(repl, value)


@dataclass
class Tree:
    """The expanded scene: the root's children in order and the objects by ``id``."""

    root: Node
    ids: dict[str, Node]
    params: dict[str, str]
    used_defines: set[str]


def read_tree(path: str | Path, defines: dict[str, str] | None = None) -> Tree:
    """Parse ``path`` with its includes, substitute parameters, index ids (see module doc)."""
    path = Path(path)
    defines = dict(defines or {})
    params = dict(defines)
    root = _parse_file(path)
    if root.tag != "scene":
        raise root.error("the root element must be <scene version=\"3...\">")
    version = root.get("version", "")
    if not version:
        raise root.error("missing attribute 'version' (Mitsuba 3 scenes say version=\"3.0.0\")")
    if version.split(".")[0] not in ("2", "3"):
        raise root.error(f"version {version!r}: mcpt reads Mitsuba 3 (and 2) scene files; "
                         "upgrade a Mitsuba 0.6 scene with Mitsuba 2's converter")
    ids: dict[str, Node] = {}
    root.search = [path.resolve().parent]
    root.children = _expand(root, params, ids, [path.resolve()])
    return Tree(root, ids, params, set(defines))


def _expand(parent: Node, params: dict[str, str], ids: dict[str, Node], chain: list[Path]) -> list[Node]:
    """``parent``'s children with defaults applied, includes inlined and ids indexed (recursive)."""
    out: list[Node] = []
    for child in parent.children:
        if child.tag == "default":
            name, value = child.need("name"), child.need("value")
            params.setdefault(name, value)  # a define (or an earlier default) wins
            continue
        _substitute(child, params)
        child.search = parent.search
        if child.tag == "path":
            _add_path(child, parent)
            continue
        if child.tag == "include":
            out.extend(_include(child, params, ids, chain))
            continue
        ident = child.get("id")
        if ident is not None and child.tag != "ref":
            if ident in ids:
                first = ids[ident]
                raise child.error(f"id {ident!r} already used at {first.file}:{first.line}")
            ids[ident] = child
        child.children = _expand(child, params, ids, chain)
        out.append(child)
    return out


def resolve_file(node: Node, name: str) -> Path:
    """The file ``name`` that ``node`` refers to, found as Mitsuba 3's FileResolver finds it
    (mitsuba3 src/core/parser.cpp, ``<path>`` and ``<include>``): in the ``<path>`` folders,
    newest first, then beside the file that names it, then beside the scene file. Not found
    anywhere: the path beside the naming file (so the caller's error names where it looked first).
    Mitsuba also tries the working directory last; mcpt does not (a render would depend on it)."""
    here = node.file.parent / name
    for folder in [*node.search[:-1], node.file.parent, *node.search[-1:]]:
        candidate = folder / name
        if candidate.exists():
            return candidate.resolve()
    return here.resolve()


def _add_path(node: Node, parent: Node) -> None:
    """``<path value>``: a search folder, relative to its file's folder or else found by the
    resolver, prepended as Mitsuba prepends it; only a child of the root, as Mitsuba requires."""
    if parent.tag != "scene":
        raise node.error("<path> can only be a child of <scene>")
    folder = resolve_file(node, node.need("value"))
    if not folder.is_dir():
        raise node.error(f"folder not found: {folder}")
    node.search.insert(0, folder)


def _include(node: Node, params: dict[str, str], ids: dict[str, Node], chain: list[Path]) -> list[Node]:
    target = resolve_file(node, node.need("filename"))
    if target in chain:
        cycle = " -> ".join(p.name for p in chain[chain.index(target):] + [target])
        raise node.error(f"include cycle: {cycle}")
    if len(chain) >= MAX_INCLUDE_DEPTH:
        raise node.error(f"includes nested deeper than {MAX_INCLUDE_DEPTH}")
    if not target.is_file():
        raise node.error(f"included file not found: {target}")
    sub = _parse_file(target)
    if sub.tag != "scene":
        raise sub.error("an included file's root element must be <scene>")
    sub.search = node.search
    return _expand(sub, params, ids, chain + [target])


def deref(node: Node, ids: dict[str, Node]) -> Node:
    """The object a ``<ref id=...>`` names (``node`` itself if it is no ref)."""
    if node.tag != "ref":
        return node
    ident = node.need("id")
    if ident not in ids:
        known = ", ".join(sorted(ids)) or "none"
        raise node.error(f"unknown reference id {ident!r} (ids defined: {known})")
    return ids[ident]
