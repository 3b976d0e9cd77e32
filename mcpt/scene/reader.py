"""Reading a scene file: YAML with line numbers, then validation into :class:`Scene`."""

from __future__ import annotations

import gc
from pathlib import Path

import yaml
from pydantic import ValidationError

from .diagnostics import KeyPath, SceneError, dotted, to_scene_error, type_name
from .model import Scene
from .overrides import apply as apply_overrides
from .overrides import blame
from .yaml12 import install as install_yaml12

#: Largest scene file read (bytes): scenes are small, meshes live in their own files.
MAX_FILE_BYTES = 16 * 2**20
#: Most values a document's aliases may add once followed. YAML aliases share one node, so
#: "billion laughs" documents are tiny to read but explode for anything that walks the data
#: (validation, error messages): refuse them before that. Values written out in the file count
#: once each (issue #24: 12 500 materials without an alias were refused); their number is bounded
#: by MAX_FILE_BYTES.
MAX_VALUES = 100_000


def _expanded_size(node: yaml.Node, memo: dict[int, int], active: set[int]) -> int:
    """Values ``node`` stands for with every alias expanded (memoised: linear in the node graph;
    ``memo`` ends with one entry per distinct node); a node that contains itself counts as
    unbounded."""
    key = id(node)
    if key in memo:
        return memo[key]
    if key in active:
        return 2**64
    active.add(key)
    if isinstance(node, yaml.SequenceNode):
        size = 1 + sum(_expanded_size(n, memo, active) for n in node.value)
    elif isinstance(node, yaml.MappingNode):
        size = 1 + sum(_expanded_size(k, memo, active) + _expanded_size(v, memo, active)
                       for k, v in node.value)
    else:
        size = 1
    active.discard(key)
    memo[key] = size
    return size


def _alias_values(node: yaml.Node) -> int:
    """Values the aliases of the document under ``node`` add: its expanded size less its nodes."""
    memo: dict[int, int] = {}
    return _expanded_size(node, memo, set()) - len(memo)


# libyaml's parser where PyYAML was built with it (issue #24: 15x faster on large documents); the
# pure-Python one otherwise. Both give nodes with marks, and SafeLoader's constructor and resolver.
if yaml.__with_libyaml__:
    import yaml.cyaml

    class _Base(yaml.cyaml.CParser, yaml.constructor.SafeConstructor, yaml.resolver.Resolver):
        def __init__(self, stream: str) -> None:
            yaml.cyaml.CParser.__init__(self, stream)
            yaml.constructor.SafeConstructor.__init__(self)
            yaml.resolver.Resolver.__init__(self)
else:  # pragma: no cover - PyYAML without libyaml
    _Base = yaml.SafeLoader


class _SceneLoader(_Base):
    """SafeLoader that knows where things are, refuses duplicate keys and reads ``1e3`` as a float.

    Usage: :meth:`compose_indexed` composes the node tree and fills :attr:`lines`; the normal
    ``construct_document`` then builds plain Python data from it.
    """

    def __init__(self, stream: str, file: str) -> None:
        super().__init__(stream)
        self.file = file
        #: key path -> 1-based line of the mapping key / sequence item; () -> the document start.
        self.lines: dict[KeyPath, int] = {}

    def compose_indexed(self) -> yaml.Node | None:
        """The document's root node (None for an empty document), with :attr:`lines` filled."""
        node = self.get_single_node()
        if node is not None:
            self.lines[()] = node.start_mark.line + 1
            if _alias_values(node) > MAX_VALUES:
                raise SceneError(self.file, self.lines[()], "",
                                 f"YAML aliases (&anchor / *alias) add more than {MAX_VALUES} "
                                 "values to the document; a scene needs far fewer")
            self._index(node, (), set())
        return node

    def _index(self, node: yaml.Node, path: KeyPath, seen: set[int]) -> None:
        # An alias is the *same* node object as its anchor: walk it once, which keeps the walk
        # linear (no "billion laughs") and finite for recursive aliases. Keys under an alias then
        # fall back to the line where the alias is used, which is where the user should look.
        if id(node) in seen:
            return
        seen.add(id(node))
        if isinstance(node, yaml.SequenceNode):
            for i, item in enumerate(node.value):
                self.lines[path + (str(i),)] = item.start_mark.line + 1
                self._index(item, path + (str(i),), seen)
        elif isinstance(node, yaml.MappingNode):
            first: dict[tuple[str, str], int] = {}
            merges = []
            for key_node, value_node in node.value:
                if key_node.tag == "tag:yaml.org,2002:merge":  # "<<: *base" — own keys win
                    merges.append(value_node)
                    continue
                if key_node.tag == "tag:yaml.org,2002:bool" and not key_node.style:  # plain: None or ""
                    # YAML 1.1 reads a plain `on:`/`yes:` key as True; every key here is a name.
                    key_node.tag = "tag:yaml.org,2002:str"
                key = self._key_text(key_node)
                line = key_node.start_mark.line + 1
                ident = (key_node.tag, key)  # "spp" and spp are the same key; 1 and "1" are not
                if ident in first:
                    raise SceneError(
                        self.file, line, dotted(path + (key,)),
                        f"duplicate key {key!r} (first defined on line {first[ident]})",
                    )
                first[ident] = line
                self.lines[path + (key,)] = line
                self._index(value_node, path + (key,), seen)
            for merged in merges:
                for source in merged.value if isinstance(merged, yaml.SequenceNode) else [merged]:
                    if isinstance(source, yaml.MappingNode):
                        for key_node, _ in source.value:
                            self.lines.setdefault(path + (self._key_text(key_node),), key_node.start_mark.line + 1)

    @staticmethod
    def _key_text(key_node: yaml.Node) -> str:
        # Keys are compared with pydantic's loc via str(); complex keys just get a readable tag.
        return key_node.value if isinstance(key_node, yaml.ScalarNode) else f"<{key_node.id} key>"


install_yaml12(_SceneLoader)  # 1e3 is a float; a 5000-digit integer a located error (yaml12.py)


def parse_scene(text: str, path: str | Path, overrides=()) -> Scene:
    """Parse and validate scene YAML ``text``; ``path`` names the file (for messages) and its
    folder anchors relative mesh paths; ``overrides``: ``KEY=VALUE`` texts (overrides.py).
    Raises :class:`SceneError`."""
    path = Path(path)
    file = str(path)
    loader = _SceneLoader(text, file)
    collecting = gc.isenabled()
    gc.disable()  # issue #24: the collector's passes over a growing node tree made parsing quadratic
    try:
        try:
            node = loader.compose_indexed()
            data = None if node is None else loader.construct_document(node)
        except yaml.MarkedYAMLError as exc:
            mark = exc.problem_mark or exc.context_mark
            line = mark.line + 1 if mark else None
            what = exc.problem or "syntax error"
            if exc.context:  # e.g. "while parsing a flow sequence", which may have begun earlier
                started = exc.context_mark.line + 1 if exc.context_mark else line
                where = f" (started on line {started})" if started != line else ""
                what = f"{exc.context}{where}: {what}"
            kind = "unsupported YAML" if isinstance(exc, yaml.constructor.ConstructorError) else "malformed YAML"
            raise SceneError(file, line, "", f"{kind}: {what}") from None
        except yaml.YAMLError as exc:  # e.g. a reader error on a control character
            raise SceneError(file, None, "", f"malformed YAML: {exc}") from None
    finally:
        loader.dispose()
        if collecting:
            gc.enable()
    if node is None:
        raise SceneError(file, 1, "", "the file is empty (expected a mapping with camera and meshes)")
    if not isinstance(data, dict):
        raise SceneError(
            file, loader.lines.get(()), "",
            f"the top level must be a mapping (camera:, meshes:, ...), got {type_name(data)}",
        )
    named, original = [], data
    if overrides:
        data, named = apply_overrides(data, overrides, file)
    context = {"base_dir": path.parent.resolve()}
    try:
        scene = Scene.model_validate(data, context=context)
    except ValidationError as exc:
        raise blame(to_scene_error(exc, file, loader.lines, Scene), named, file, original,
                    lambda d: Scene.model_validate(d, context=context)) from None
    return scene.located(path, loader.lines)


def load_scene(path: str | Path, overrides=()) -> Scene:
    """Read and validate the scene file at ``path`` (``overrides``: ``-D KEY=VALUE`` texts).
    Raises :class:`SceneError`."""
    path = Path(path)
    if path.suffix.lower() == ".xml":  # issue #19: a Mitsuba 3 scene, mapped onto the same schema
        from .mitsuba import load_xml

        return load_xml(path, overrides)
    if path.suffix.lower() in (".gltf", ".glb"):  # issue #19: a glTF 2.0 scene, mapped likewise
        from .gltf import load_gltf

        return load_gltf(path, overrides)
    try:
        if path.is_file() and path.stat().st_size > MAX_FILE_BYTES:
            raise SceneError(path, None, "", f"{path.stat().st_size} bytes is not a scene file "
                             f"(at most {MAX_FILE_BYTES // 2**20} MiB; meshes go in their own files)")
        text = path.read_bytes().decode("utf-8-sig")  # tolerate a BOM
    except OSError as exc:
        raise SceneError(path, None, "", f"cannot read scene file: {exc.strerror or exc}") from None
    except UnicodeDecodeError as exc:
        raise SceneError(path, None, "", f"not UTF-8 text (byte {exc.start})") from None
    return parse_scene(text, path, overrides)
