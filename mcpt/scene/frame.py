"""The scene at a frame (issue #26): an animated scene's camera and meshes evaluated at frame N
(mcpt/scene/animation.py), with the frame's own seed. A still render of ``at_frame(scene, N)`` is
frame N of a sequence (mcpt/sequence.py), bit for bit."""

from __future__ import annotations

import numpy as np
from pydantic import ValidationError

from .animation import camera_at, mesh_matrix, origin
from .diagnostics import SceneError, line_of, to_scene_error
from .model import Scene
from .reader import load_scene
from .transform import Transform


def frame_seed(seed: int, frame: int) -> int:
    """Frame N's seed: ``SeedSequence([seed, N, 0xA11A])`` hashed to 63 bits, so frames are
    decorrelated and frame N's image does not depend on which frames were rendered before it."""
    state = np.random.SeedSequence([int(seed), int(frame), 0xA11A]).generate_state(1, np.uint64)[0]
    return int(state) >> 1


def at_frame(scene, frame: int, seed: int | None = None):
    """The scene at ``frame``: camera and animated meshes evaluated, ``render.seed`` the frame's
    (:func:`frame_seed`; ``seed``: that seed, already derived), the geometry's origin the rest
    pose's. A scene without animation is returned with only the seed changed."""
    anim = scene.animation
    seed = frame_seed(scene.render.seed, frame) if seed is None else seed
    data = {"name": scene.name, "camera": scene.camera.model_dump(),
            "render": {**scene.render.model_dump(), "seed": seed},
            "materials": dict(scene.materials), "meshes": list(scene.meshes),
            "lights": scene.lights, "environment": scene.environment, "animation": anim}
    if anim is not None:
        data["animation"] = anim.model_copy(update={"origin": tuple(origin(scene)), "frame": frame})
        if anim.camera is not None:
            data["camera"] = camera_at(anim.camera, data["camera"], frame)
        for track in anim.meshes:
            mesh = scene.meshes[track.mesh]
            space = track.parent if track.parent is not None else mesh.transform
            m = space.matrix() @ mesh_matrix(track, frame)  # in the mesh's own frame
            rows = tuple(tuple(float(x) for x in row) for row in m)
            data["meshes"][track.mesh] = mesh.model_copy(update={"transform": Transform(matrix=rows)})
    try:
        out = Scene.model_validate(data)
    except ValidationError as exc:
        err = to_scene_error(exc, "<frame>", {}, Scene)
        line = line_of(scene._lines, ("animation",)) if scene._lines else None
        raise SceneError(scene.source_path or "<scene>", line, "animation",
                         f"at frame {frame}: {err.key}: {err.reason}") from None
    return out.located(scene.source_path, scene._lines) if scene.source_path else out


def frame_metadata(scene) -> dict:
    """``frame`` and ``fps`` of a scene made by :func:`at_frame` (nothing for a still)."""
    anim = getattr(scene, "animation", None)
    if anim is None or anim.frame is None:
        return {}
    return {"frame": anim.frame, "fps": anim.fps}


def frame_job(scene) -> dict:
    """What a farm job (mcpt/farm/cluster.py job_for) adds for a frame: its number."""
    anim = getattr(scene, "animation", None)
    return {} if anim is None or anim.frame is None else {"frame": anim.frame}


def job_scene(job: dict):
    """The scene a farm worker prepares for ``job``: the file, or the file at the job's frame
    with the job's (frame) seed."""
    if "frame" not in job:
        return job["scene"]
    base = load_scene(job["scene"], overrides=tuple(job["overrides"]))
    return at_frame(base, job["frame"], seed=job["seed"])
