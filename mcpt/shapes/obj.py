"""OBJ specifics Assimp does not give: line numbers of bad vertices and faces, float64 coordinates
far from the origin, and what the MTL files really declare (Assimp fills defaults).

:class:`ObjFile` reads an OBJ's bytes once and every check here shares them; its MTL files are
parsed once, on first use (:class:`MtlLibrary`). Assimp still opens the file itself: assimp-py 1.1
reads from a path only, so an OBJ is read by mcpt once and by Assimp once (its MTL files likewise).
"""

from __future__ import annotations

import logging
import math
import re
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path

import numpy as np

from .geometry import column_bounds
from .raw_mesh import TextureMap

log = logging.getLogger("mcpt")


_OBJ_VERTEX = re.compile(rb"^[ \t]*v[ \t]+(\S+)[ \t]+(\S+)[ \t]+(\S+)", re.MULTILINE)
_OBJ_FACE = re.compile(rb"^[ \t]*f[ \t]+([^\r\n#]*)", re.MULTILINE)
_MTLLIB = re.compile(rb"^[ \t]*mtllib[ \t]+(.+?)[ \t]*\r?$", re.MULTILINE)
FLOAT32_MAX = float(np.finfo(np.float32).max)

#: Assimp parses OBJ coordinates as float32. When a mesh's coordinates are more than this many
#: times its own size, the rounding is visible (relative to the mesh), so the file's own float64
#: values are read back (see ObjFile.restore_precision).
OBJ_FLOAT64_RATIO = 64.0


def _line_of(data: bytes, offset: int) -> int:
    return data.count(b"\n", 0, offset) + 1


def mtllib_specs(data: bytes) -> list[str]:
    """The text after ``mtllib`` of every mtllib line, in order. The word is found by its last
    byte, ``b``, which numbers never hold: a one-byte ``find`` is a memchr (6 ms for 40 MB against
    25 ms for the six-byte word, issue #23); the line regex runs only where the word stands (a
    MULTILINE regex over all of it costs 0.2 s)."""
    specs, seen, q = [], set(), data.find(b"b", 5)
    while q >= 0:
        pos = q - 5
        if data[pos:q + 1] == b"mtllib":
            start = data.rfind(b"\n", 0, pos) + 1
            if start not in seen:
                seen.add(start)
                m = _MTLLIB.match(data, start)
                if m is not None:
                    specs.append(m.group(1).decode("utf-8", "replace"))
        q = data.find(b"b", q + 1)
    return specs


#: Bytes of plain vertex and face lines. ``data.translate(None, _PLAIN_OBJ_BYTES)`` deletes them in
#: one C pass (0.02 s for 40 MB) and leaves the rest, a few hundred bytes for a clean file, in
#: which a letter is counted in no time (six substring searches and the exponent regex over the
#: whole file took 0.4 s, issue #23).
_PLAIN_OBJ_BYTES = b"0123456789 \t\r\n.-+/vf"
_BIG_EXPONENT = re.compile(rb"[eE]\+?(3[89]|[4-9]\d|\d{3})")


def _outside_comments(data: bytes, rest: bytes, letters: bytes) -> bool:
    """Whether any of ``letters`` occurs in ``data`` outside ``#`` comments (``rest``: data less
    _PLAIN_OBJ_BYTES). A vertex token that parses as NaN or inf holds an n or N, and no '#'
    precedes it on its line (a token holding '#' is not a number)."""
    total = sum(rest.count(c) for c in letters)
    if total == 0 or rest.count(b"#") > 10_000:
        return total > 0
    in_comments, pos = 0, data.find(b"#")
    while pos >= 0:
        end = data.find(b"\n", pos)
        end = len(data) if end < 0 else end
        in_comments += sum(data.count(c, pos, end) for c in letters)
        pos = data.find(b"#", end)
    return total > in_comments


def _big_exponent(data: bytes, rest: bytes) -> bool:
    """Whether ``_BIG_EXPONENT`` matches somewhere in ``data``: the regex is tried only where an e
    or E is (bytes.find jumps there), unless there are so many that one regex pass is cheaper."""
    n = rest.count(b"e") + rest.count(b"E")
    if n > 100_000:
        return _BIG_EXPONENT.search(data) is not None
    for letter in (b"e", b"E") if n else ():
        pos = data.find(letter)
        while pos >= 0:
            if _BIG_EXPONENT.match(data, pos):
                return True
            pos = data.find(letter, pos + 1)
    return False


class ObjFile:
    """An OBJ file's bytes, read once, and the checks Assimp does not make (all on those bytes).

    ``data`` is None when the file cannot be read: every check then finds nothing and Assimp
    reports the unreadable file."""

    def __init__(self, path: Path, data: bytes | None) -> None:
        self.path, self.data = Path(path), data

    @classmethod
    def read(cls, path: Path) -> ObjFile:
        try:
            return cls(path, Path(path).read_bytes())
        except OSError:
            return cls(path, None)

    def bad_vertex(self) -> str | None:
        """A message naming ``file:line`` for the first vertex that is NaN, infinite or beyond
        float32 (Assimp would read the latter as inf). A quick byte search skips clean files."""
        data = self.data
        if data is None:
            return None
        rest = data.translate(None, _PLAIN_OBJ_BYTES)
        if not _outside_comments(data, rest, b"nN") and not _big_exponent(data, rest):
            return None  # no NaN, no inf and no exponent past float32's: the common, clean case
        low = (b"nan", b"NaN", b"NAN", b"inf", b"Inf", b"INF")
        if not any(t in data for t in low) and _BIG_EXPONENT.search(data) is None:
            return None
        for k, m in enumerate(_OBJ_VERTEX.finditer(data)):
            try:
                xyz = [float(t) for t in m.groups()]
            except ValueError:
                continue  # Assimp decides what to do with a malformed number
            if not all(math.isfinite(x) and abs(x) <= FLOAT32_MAX for x in xyz):
                text = data[m.start():data.find(b"\n", m.start())].decode("utf-8", "replace").strip()
                return (f"{self.path}:{_line_of(data, m.start())}: vertex {k + 1} is not finite "
                        f"(NaN, inf or beyond float32): {text!r}")
        return None

    def bad_face(self) -> str | None:
        """'file:line: ...' for the first face whose vertex index is out of range, or None."""
        data, path = self.data, self.path
        if data is None:
            return None
        ends = [m.start() for m in _OBJ_VERTEX.finditer(data)]
        total = len(ends)
        for m in _OBJ_FACE.finditer(data):
            before = int(np.searchsorted(ends, m.start()))  # vertices defined above this face
            for tok in m.group(1).split():
                try:
                    i = int(tok.split(b"/")[0])
                except ValueError:
                    return (f"{path}:{_line_of(data, m.start())}: face index "
                            f"{tok.decode(errors='replace')!r} is not an integer")
                ok = 1 <= i <= total if i > 0 else (i < 0 and -i <= before)
                if not ok:
                    return (f"{path}:{_line_of(data, m.start())}: face vertex index {i} out of range "
                            f"(the file has {total} vertices, indices are 1-based)")
        return None

    def restore_precision(self, parts: list) -> None:
        """Replace Assimp's float32 coordinates (``part.vertices`` of each part) by the file's
        float64 ones where it matters.

        A Cornell box written at x = 1e5 loses everything below 1/128 in float32, before mcpt's
        camera-relative float64 rebasing could keep it (issue #6). Every Assimp vertex is the
        float32 rounding of some file vertex; where that file vertex is unique the float64 value is
        restored. If two different file vertices round to the same float32 vertex, Assimp has
        already merged them: precision is lost and a warning says so (a YAML ``transform`` keeps
        far-away meshes exact)."""
        allv = parts[0].vertices if len(parts) == 1 else np.concatenate([p.vertices for p in parts])
        if allv.size == 0 or not np.isfinite(allv).all() or self.data is None:
            return
        lo, hi = column_bounds(allv)
        extent = float(np.max(hi - lo))
        if max(-lo.min(), hi.max()) <= OBJ_FLOAT64_RATIO * max(extent, 1e-300):
            return
        try:
            exact = np.array([[float(t) for t in m.groups()] for m in _OBJ_VERTEX.finditer(self.data)])
        except ValueError:
            return
        if exact.size == 0:
            return
        keys = np.ascontiguousarray(exact.astype(np.float32)).view(np.dtype((np.void, 12))).ravel()
        order = np.argsort(keys, kind="stable")
        sk, se = keys[order], exact[order]
        clash = (sk[1:] == sk[:-1]) & np.any(se[1:] != se[:-1], axis=1)
        if clash.any():
            log.warning("%s: %d vertices differ only below float32 precision at coordinates up to %.3g:"
                        " they were merged; place the mesh with a YAML transform instead of far-away"
                        " coordinates", self.path, int(clash.sum()), float(np.abs(exact).max()))
            return
        for p in parts:
            q = np.ascontiguousarray(p.vertices.astype(np.float32)).view(np.dtype((np.void, 12))).ravel()
            pos = np.searchsorted(sk, q)
            pos = np.minimum(pos, len(sk) - 1)
            found = sk[pos] == q
            p.vertices = np.where(found[:, None], se[pos], p.vertices)

    def mtl_files(self) -> list[Path]:
        """The MTL files the OBJ names in its ``mtllib`` lines (existing or not), in order.

        A regex over the raw bytes finds `mtllib` lines without splitting a 40 MB OBJ into lines."""
        if self.data is None:
            return []
        files = []
        for spec in mtllib_specs(self.data):
            # The spec allows several files per line; a single name with spaces is also common.
            candidates = [spec] if (self.path.parent / spec).is_file() else spec.split()
            files += [self.path.parent / name for name in candidates]
        return files

    @cached_property
    def mtl(self) -> MtlLibrary:
        """The OBJ's MTL files, each read and parsed once."""
        return MtlLibrary.parse(self.mtl_files())


#: MTL texture statements mcpt reads: the diffuse colour, the emitted radiance, the opacity
#: ("dissolve": a grey cut-out image, mcpt/shading/opacity.py).
MTL_MAPS = ("map_kd", "map_ke", "map_d")
#: MTL statements for what mcpt does not read from an MTL (bump and normal maps, PBR and specular
#: maps): said once per MTL file (issue #22), so a scene that needs them gives them in the YAML
#: (``bump_map``, ``normal_map``, ``roughness_texture``) instead of rendering flat without a word.
MTL_IGNORED = ("bump", "map_bump", "norm", "map_pr", "map_pm", "map_ks", "map_ns", "disp", "refl")


@dataclass
class MtlLibrary:
    """What an OBJ's MTL files say, per material name.

    Attributes:
        declared: lower-cased keywords each material really states (Assimp fills the rest with
            its defaults, so ``Kd`` is the file's only where ``"kd"`` is here).
        maps: ``map_Kd`` / ``map_Ke`` images, keyed ``"map_kd"`` / ``"map_ke"``; paths relative to
            the MTL file's folder (as the format says), backslashes read as slashes.
    """

    declared: dict[str, set[str]]
    maps: dict[str, dict[str, TextureMap]]

    @classmethod
    def parse(cls, files: list[Path]) -> MtlLibrary:
        declared: dict[str, set[str]] = {}
        maps: dict[str, dict[str, TextureMap]] = {}
        texts: dict[Path, str | None] = {}
        for mtl in files:
            if mtl not in texts:  # a file named twice is read once
                texts[mtl] = _read_text(mtl)
            ignored: dict[str, list[str]] = {}
            for name, key, rest in _statements(texts[mtl]):
                declared.setdefault(name, set()).add(key)
                if key in MTL_IGNORED:
                    ignored.setdefault(key, [])
                    if name not in ignored[key]:
                        ignored[key].append(name)
                if key in MTL_MAPS:
                    file = map_file(rest).replace("\\", "/")
                    if file:
                        spelled = key[:4] + (key[4:].capitalize() if key != "map_d" else "d")
                        maps.setdefault(name, {})[key] = TextureMap(mtl, spelled, mtl.parent / file)
            if ignored:
                what = "; ".join(f"{k} (material{'s' if len(v) > 1 else ''} {', '.join(v[:3])}"
                                 f"{', ...' if len(v) > 3 else ''})" for k, v in ignored.items())
                log.warning("%s: ignored by mcpt: %s; give bump_map / normal_map / roughness_texture in "
                            "the scene's material instead", mtl, what)
        return cls(declared, maps)


def _read_text(mtl: Path) -> str | None:
    """An MTL file's text; None when missing or unreadable (Assimp then uses its default material)."""
    try:
        return mtl.read_text(encoding="utf-8", errors="replace")
    except OSError:
        return None


def _statements(text: str | None):
    """(material name, lower-cased keyword, rest of the line) for every statement inside a
    ``newmtl`` block of an MTL file's text."""
    if text is None:
        return
    current: str | None = None
    for line in text.splitlines():
        fields = line.split(None, 1)
        if not fields or fields[0].startswith("#"):
            continue
        key = fields[0].lower()
        rest = fields[1].strip() if len(fields) > 1 else ""
        if key == "newmtl":
            current = rest
        elif current is not None:
            yield current, key, rest


#: Options of MTL texture statements (``map_Kd -s 1 1 1 file.png``) and how many values each takes
#: (Wavefront MTL specification); ``-o``, ``-s``, ``-t`` take 1 to 3 numbers.
_MAP_OPTIONS = {"-blendu": 1, "-blendv": 1, "-bm": 1, "-boost": 1, "-cc": 1, "-clamp": 1,
                "-imfchan": 1, "-mm": 2, "-o": 3, "-s": 3, "-t": 3, "-texres": 1, "-type": 1}


def map_file(rest: str) -> str:
    """The file name of a texture statement, its options skipped (a name may contain spaces)."""
    tokens = rest.split()
    i = 0
    while i < len(tokens) and tokens[i].lower() in _MAP_OPTIONS:
        n = _MAP_OPTIONS[tokens[i].lower()]
        i += 1
        if n == 3:  # up to three numbers
            while n and i < len(tokens) - 1 and _is_number(tokens[i]):
                i, n = i + 1, n - 1
        else:
            i += n
    return " ".join(tokens[i:])


def _is_number(token: str) -> bool:
    try:
        float(token)
    except ValueError:
        return False
    return True
