"""``mcpt convert``: a Mitsuba 3 scene written out as the equivalent YAML scene.

The data is the very dict :func:`~.scene.load_xml` validates; it is validated the same way before
anything is written, then written atomically (a temporary file renamed into place), with mesh and
texture paths relative to the YAML's folder. Primitives stay primitives (``shape: sphere``), so no
mesh file is needed.
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

import yaml

from .scene import load_xml, scene_data, split_defines
from .shapes import relative_paths
from .xmltree import XmlError


def convert_file(xml_path, yaml_path, defines=()) -> int:
    """Write the YAML scene equivalent to ``xml_path``; returns the number of meshes."""
    xml_path, yaml_path = Path(xml_path), Path(yaml_path)
    params, keys = split_defines(defines, xml_path)
    if keys:
        raise XmlError(xml_path, None, "", f"-D {keys[0]}: convert takes XML parameters (NAME=VALUE) only")
    load_xml(xml_path, defines)  # validates: refuse before writing anything
    data, _ = scene_data(xml_path, params)
    folder = yaml_path.resolve().parent
    data = relative_paths(data, folder)
    text = (f"# Converted by `mcpt convert` from {xml_path.name}; edit freely.\n"
            + yaml.safe_dump(data, sort_keys=False, default_flow_style=None, width=100))
    try:
        folder.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=f".{yaml_path.name}.", dir=folder)
        with os.fdopen(fd, "w") as fh:
            fh.write(text)
        os.replace(tmp, yaml_path)
    except OSError as exc:
        raise XmlError(yaml_path, None, "", f"cannot write: {exc.strerror or exc}") from None
    return len(data["meshes"])
