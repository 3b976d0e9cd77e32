"""Scalars read the same way in a scene file and in a ``-D KEY=VALUE`` override.

YAML 1.1 (PyYAML) needs a dot in a float and a sign in its exponent, so "1e3" and "1.0e3" would
be *strings*; YAML 1.2 and every human read them as numbers. Integers still win for "123"
because the int resolver was registered first. The scene reader (reader.py) and the override
parser (overrides.py) both use :func:`install`, so ``-D camera.vfov_deg=4e1`` reads as the file's
``vfov_deg: 4e1`` does (issue #24 item 19).

An integer of more digits than Python converts (``sys.get_int_max_str_digits()``, 4300) is a
located YAML error, not a ValueError out of the constructor (issue #24 item 17).
"""

from __future__ import annotations

import re

import yaml

FLOAT_12 = re.compile(r"^[-+]?(?:\.[0-9]+|[0-9]+(?:\.[0-9]*)?)(?:[eE][-+]?[0-9]+)?$")


def _int(loader, node):
    try:
        return yaml.constructor.SafeConstructor.construct_yaml_int(loader, node)
    except ValueError:  # Python's int digit limit
        raise yaml.constructor.ConstructorError(
            None, None, f"an integer of {len(node.value)} characters is too long to be a number",
            node.start_mark) from None


def install(loader_cls) -> None:
    """YAML 1.2 floats and bounded integers on ``loader_cls`` (a SafeLoader-like class)."""
    loader_cls.add_implicit_resolver("tag:yaml.org,2002:float", FLOAT_12, list("-+.0123456789"))
    loader_cls.add_constructor("tag:yaml.org,2002:int", _int)


class ValueLoader(yaml.SafeLoader):
    """SafeLoader for one override value."""


install(ValueLoader)


def load_value(text: str):
    """``text`` read as a YAML value the way the scene reader reads one."""
    return yaml.load(text, Loader=ValueLoader)  # noqa: S506 - a SafeLoader subclass
