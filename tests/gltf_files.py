"""Small glTF 2.0 files built in the tests with numpy + json (no binary blobs committed)."""

from __future__ import annotations

import base64
import json
import struct
from pathlib import Path

import numpy as np

TYPES = {1: "SCALAR", 2: "VEC2", 3: "VEC3", 4: "VEC4"}
COMPONENT_OF = {"int8": 5120, "uint8": 5121, "int16": 5122, "uint16": 5123, "uint32": 5125, "float32": 5126}


class GltfBuilder:
    """A glTF document and its one binary buffer, built element by element."""

    def __init__(self) -> None:
        self.blob = bytearray()
        self.doc: dict = {"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": []}], "nodes": [],
                          "meshes": [], "materials": [], "accessors": [], "bufferViews": [], "buffers": []}

    def view(self, data: bytes, stride: int | None = None) -> int:
        self.blob += b"\0" * (-len(self.blob) % 4)
        view = {"buffer": 0, "byteOffset": len(self.blob), "byteLength": len(data)}
        if stride:
            view["byteStride"] = stride
        self.blob += data
        self.doc["bufferViews"].append(view)
        return len(self.doc["bufferViews"]) - 1

    def accessor(self, array, *, normalized: bool = False, view: int | None = None, offset: int = 0,
                 count: int | None = None) -> int:
        """An accessor over ``array`` ((N,) or (N, k)), in a view of its own unless ``view``."""
        a = np.asarray(array)
        width = 1 if a.ndim == 1 else a.shape[1]
        if view is None:
            view = self.view(np.ascontiguousarray(a).astype(a.dtype.newbyteorder("<")).tobytes())
        acc = {"bufferView": view, "byteOffset": offset, "componentType": COMPONENT_OF[a.dtype.name],
               "count": count if count is not None else len(a), "type": TYPES[width]}
        if normalized:
            acc["normalized"] = True
        self.doc["accessors"].append(acc)
        return len(self.doc["accessors"]) - 1

    def mesh(self, positions, indices, material: int | None = None, uvs=None, mode: int | None = None,
             normals=None) -> int:
        attrs = {"POSITION": self.accessor(np.asarray(positions, np.float32))}
        if normals is not None:
            attrs["NORMAL"] = self.accessor(np.asarray(normals, np.float32))
        if uvs is not None:
            attrs["TEXCOORD_0"] = self.accessor(np.asarray(uvs, np.float32))
        prim = {"attributes": attrs, "indices": self.accessor(np.asarray(indices, np.uint16).reshape(-1))}
        if material is not None:
            prim["material"] = material
        if mode is not None:
            prim["mode"] = mode
        self.doc["meshes"].append({"primitives": [prim]})
        return len(self.doc["meshes"]) - 1

    def material(self, **fields) -> int:
        self.doc["materials"].append(fields)
        return len(self.doc["materials"]) - 1

    def node(self, root: bool = True, **fields) -> int:
        self.doc["nodes"].append(fields)
        index = len(self.doc["nodes"]) - 1
        if root:
            self.doc["scenes"][0]["nodes"].append(index)
        return index

    def camera(self, yfov: float, aspect: float | None = None, name: str | None = None) -> int:
        persp = {"yfov": yfov, "znear": 0.01} | ({"aspectRatio": aspect} if aspect else {})
        self.doc.setdefault("cameras", []).append({"type": "perspective", "perspective": persp}
                                                  | ({"name": name} if name else {}))
        return len(self.doc["cameras"]) - 1

    def write_gltf(self, path: Path, external: bool = False) -> Path:
        """A .gltf with the buffer as a data: URI (or a .bin beside it)."""
        doc = json.loads(json.dumps(self.doc))
        blob = bytes(self.blob)
        if external:
            (path.parent / (path.stem + ".bin")).write_bytes(blob)
            doc["buffers"] = [{"uri": path.stem + ".bin", "byteLength": len(blob)}]
        else:
            uri = "data:application/octet-stream;base64," + base64.b64encode(blob).decode()
            doc["buffers"] = [{"uri": uri, "byteLength": len(blob)}]
        path.write_text(json.dumps(doc))
        return path

    def write_glb(self, path: Path) -> Path:
        doc = json.loads(json.dumps(self.doc))
        blob = bytes(self.blob) + b"\0" * (-len(self.blob) % 4)
        doc["buffers"] = [{"byteLength": len(self.blob)}]
        text = json.dumps(doc).encode()
        text += b" " * (-len(text) % 4)
        body = struct.pack("<II", len(text), 0x4E4F534A) + text + struct.pack("<II", len(blob), 0x004E4942) + blob
        path.write_bytes(struct.pack("<III", 0x46546C67, 2, 12 + len(body)) + body)
        return path


#: A unit quad in the z = 0 plane facing +z: corners (+-1, +-1, 0), two counter-clockwise triangles.
QUAD = np.array([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], np.float32)
QUAD_FACES = np.array([[0, 1, 2], [0, 2, 3]])


def write_obj(path: Path, positions, faces) -> Path:
    """The same triangles as an OBJ (for a YAML scene equivalent to a glTF one)."""
    lines = [f"v {x!r} {y!r} {z!r}" for x, y, z in np.asarray(positions, np.float64).tolist()]
    lines += [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in np.asarray(faces).tolist()]
    path.write_text("\n".join(lines) + "\n")
    return path
