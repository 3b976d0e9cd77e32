"""Issue #24: a scene too large for mcpt is refused in one located line before any geometry is
built, not after minutes of tessellation and the OOM killer (3000 instances of a Mitsuba sphere,
98 million triangles, ran 116 s and died at 24 GB).

The count is read per distinct source (mcpt/shapes/counts.py: exact for analytic shapes, headers
or a streaming scan for files) and multiplied by the entries naming it, so a scene of thousands
of entries costs as many dictionary look-ups; nothing is allocated per triangle. The limit is the
smaller of

* what the GL buffers hold: :data:`mcpt.gpu.limits.MAX_TRIANGLES` (2^27 texels, the BVH buffer's
  texels per triangle), whatever the host;
* what the host memory holds: the memory available (host_memory.available_bytes) less the
  image's share, at the measured peak of :data:`~mcpt.gpu.host_memory.BYTES_PER_TRIANGLE`.

The line names the entry whose triangles cross the limit: ``scene.yaml:40: meshes.812`` in YAML,
the top-level ``<shape type="instance">`` an XML shape came through (or the shape's own line).
"""

from __future__ import annotations

from collections import Counter

from ..errors import McptError
from ..shapes.counts import entry_source, source_name, triangles
from . import host_memory, limits


class SceneTooLarge(McptError, ValueError):
    """The scene has more triangles than mcpt can hold here; the line says how many and the limit."""


def triangle_limit(width: int, height: int) -> tuple[int, str]:
    """(most triangles, why) for an image of ``width`` x ``height``: the GL buffers' limit or, where
    lower, the host memory's."""
    gl = limits.MAX_TRIANGLES
    why = f"GL buffer limit: 2^{limits.GL_BUFFER_TEXELS.bit_length() - 1} texels"
    free = host_memory.available_bytes()
    if free is not None:
        room = max(free - host_memory.host_bytes(width, height, 1), 0) // host_memory.BYTES_PER_TRIANGLE
        if room < gl:
            return room, (f"memory available: {free / 2**30:.1f} GiB at "
                          f"{host_memory.BYTES_PER_TRIANGLE} bytes a triangle")
    return gl, why


def _spaced(n: int) -> str:
    return f"{n:,}".replace(",", " ")


def _entry(scene, i: int) -> str:
    """``file:line: key`` of mesh entry ``i``; for an XML shape placed by an instance, the instance."""
    line = scene.line("meshes", i, "instance")
    if line is not None:
        return f"{scene.source_path}:{line}: <shape type=\"instance\">"
    return scene.where("meshes", i)


def check_scene_size(scene, limit: tuple[int, str] | None = None) -> int:
    """The scene's triangle count as its sources announce it (before degenerate and repeated ones
    are dropped); raises :class:`SceneTooLarge` naming the entry that crosses ``limit`` (default:
    :func:`triangle_limit` of the scene's image)."""
    most, why = limit or triangle_limit(scene.camera.width, scene.camera.height)
    each: dict[tuple, int] = {}
    uses: Counter = Counter()
    total, crossing = 0, None
    for i, spec in enumerate(scene.meshes):
        source = entry_source(spec)
        if source not in each:
            each[source] = triangles(source)
        uses[source] += 1
        total += each[source]
        if crossing is None and total > most:
            crossing = i
    if crossing is None:
        return total
    biggest = sorted((s for s in uses if each[s]), key=lambda s: -uses[s] * each[s])
    parts = [f"{uses[s]} x {source_name(s)} of {_spaced(each[s])}" if uses[s] > 1
             else f"{source_name(s)}: {_spaced(each[s])}" for s in biggest[:2]]
    if len(biggest) > 2:
        parts.append(f"{len(biggest) - 2} more sources")
    raise SceneTooLarge(f"{_entry(scene, crossing)}: the scene's triangles pass the limit at this entry: "
                        f"{_spaced(total)} in all ({', '.join(parts)}); mcpt can hold at most "
                        f"{_spaced(most)} ({why})")
