"""Mitsuba 3 XML scenes (issue #19): read, mapped onto mcpt's scene schema, validated like YAML.

Modules, in data order: ``xmltree`` (XML with lines, defaults, includes, refs), ``values``
(properties and transforms), ``camera`` (sensor, film, sampler, integrator), ``bsdfs``,
``shapes``, ``scene`` (the walk, and :func:`load_xml`). What is supported, approximated (with the
warning) or refused: README "Mitsuba 3 scenes".
"""

from .scene import load_xml, scene_data, split_defines
from .xmltree import XmlError

__all__ = ["XmlError", "load_xml", "scene_data", "split_defines"]
