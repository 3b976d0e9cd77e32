"""Animation (issue #26): keyframes of the camera and of mesh transforms, and the scene at a frame.

In a scene file::

    animation:
      fps: 24                      # frames per second (video encoding, metadata)
      frames: [1, 48]              # the frame range `mcpt render` renders by default (inclusive)
      camera:
        interpolation: smooth      # or linear
        keys:                      # each key sets some of position, look_at, up, vfov_deg
          - {frame: 1, position: [0, 0, 3.9]}
          - {frame: 48, position: [1, 0, 3.5], vfov_deg: 30}
      meshes:
        - mesh: 2                  # index into meshes:
          interpolation: linear
          keys:                    # translate, rotate ([x, y, z, w] quaternion) or rotate_deg, scale
            - {frame: 1, rotate_deg: [0, 0, 0]}
            - {frame: 48, rotate_deg: [0, 90, 0], translate: [0, 0.2, 0]}

Each channel (camera position, look_at, ...; a mesh's translate, rotate, scale) is interpolated
over the keys that set it (mcpt/scene/keyframes.py); a camera channel no key sets keeps the
``camera:`` value, a mesh channel no key sets is the identity. A mesh's animated placement
``T(t) R(t) S(t)`` applies in the mesh's own frame, BEFORE its ``transform``: world =
``transform * T R S`` (a placed object turns about its own origin; a glTF node's animated local
transform under its parent's, mcpt/scene/gltf/animation.py). Keys must be in strictly increasing frame
order. Frames before the first key of a channel hold its first key, after the last its last.

The geometry is rebased (mcpt/shapes/world.py) at the file's ``camera.position`` whatever the
frame, so a moving camera moves a uniform, not the uploaded scene (``Scene.origin``).

mcpt/scene/frame.py ``at_frame`` is the scene at frame N (the tracks here evaluated, its own seed).
"""

from __future__ import annotations

from typing import Annotated, Literal

import numpy as np
from pydantic import BeforeValidator, Field, model_validator

from .diagnostics import FieldError
from .fields import StrictModel, Vec3, list_to_tuple, scalar_to_vec3
from .fields import fixed_list as _fixed
from .keyframes import Track, euler_quat, quat_matrix
from .transform import Transform

Quat = Annotated[tuple[float, float, float, float], _fixed(4)]
Interp = Literal["linear", "smooth"]
CAMERA_CHANNELS = ("position", "look_at", "up", "vfov_deg", "focus_distance")
MESH_CHANNELS = ("translate", "rotate", "scale")


def _increasing(keys) -> None:
    for i in range(1, len(keys)):
        if not keys[i].frame > keys[i - 1].frame:
            raise FieldError(("keys", i, "frame"), f"key frames must increase: {keys[i].frame:g} "
                                                   f"follows {keys[i - 1].frame:g}")


class CameraKey(StrictModel):
    frame: float
    """Frame number of the key (may be fractional)."""
    position: Vec3 | None = None
    look_at: Vec3 | None = None
    up: Vec3 | None = None
    vfov_deg: Annotated[float, Field(gt=0.0, lt=180.0)] | None = None
    """Keyed, it replaces a ``fov_deg`` of the camera (the vertical fov is what is animated)."""
    focus_distance: Annotated[float, Field(gt=0.0)] | None = None
    """A thin lens's plane in focus (world units; needs ``camera.lens``): a rack focus."""


class MeshKey(StrictModel):
    frame: float
    translate: Vec3 | None = None
    """Offset, world units."""
    rotate: Quat | None = None
    """Unit quaternion ``[x, y, z, w]`` (glTF order; normalised)."""
    rotate_deg: Vec3 | None = None
    """Euler angles as ``transform.rotate_deg`` (X, then Y, then Z); made a quaternion."""
    scale: Annotated[Vec3, BeforeValidator(scalar_to_vec3)] | None = None

    @model_validator(mode="after")
    def _one_rotation(self) -> MeshKey:
        if self.rotate is not None and self.rotate_deg is not None:
            raise FieldError(("rotate_deg",), "give rotate or rotate_deg, not both")
        if self.rotate is not None and not any(self.rotate):
            raise FieldError(("rotate",), "rotate is the zero quaternion")
        if self.scale is not None and 0.0 in self.scale:
            raise FieldError(("scale",), f"scale must be nonzero, got {list(self.scale)}")
        return self

    def quaternion(self):
        if self.rotate is not None:
            return np.asarray(self.rotate, np.float64)
        return None if self.rotate_deg is None else euler_quat(self.rotate_deg)


class CameraTrack(StrictModel):
    interpolation: Interp = "smooth"
    keys: Annotated[tuple[CameraKey, ...], BeforeValidator(list_to_tuple), Field(min_length=1)]

    @model_validator(mode="after")
    def _order(self) -> CameraTrack:
        _increasing(self.keys)
        return self


class MeshTrack(StrictModel):
    mesh: Annotated[int, Field(ge=0)]
    """Index of the mesh in ``meshes:``."""
    interpolation: Interp = "smooth"
    keys: Annotated[tuple[MeshKey, ...], BeforeValidator(list_to_tuple), Field(min_length=1)]
    parent: Transform | None = None
    """The frame the animated ``T R S`` live in (default: the mesh's ``transform``, which then
    stays the rest pose only where no key is): the glTF reader sets it to an animated node's
    parent's world matrix, keeping ``transform`` the node's rest placement."""

    @model_validator(mode="after")
    def _order(self) -> MeshTrack:
        _increasing(self.keys)
        return self


class Animation(StrictModel):
    fps: Annotated[float, Field(gt=0.0)] = 24.0
    """Frames per second (a video's rate; recorded in each frame's metadata)."""
    frames: Annotated[tuple[int, int], _fixed(2, "integers")] | None = None
    """``[first, last]`` (inclusive, >= 0): what a sequence renders without ``--frames``;
    absent: the first to the last key."""
    camera: CameraTrack | None = None
    meshes: Annotated[tuple[MeshTrack, ...], BeforeValidator(list_to_tuple)] = ()
    origin: Vec3 | None = None
    """Where the geometry is rebased (world units); absent: the file's ``camera.position``.
    mcpt/scene/frame.py ``at_frame`` fills it in so every frame keeps the rest pose's origin."""
    frame: Annotated[int, Field(ge=0)] | None = None
    """The frame this scene shows: set by ``at_frame`` (the image's metadata, ``mcpt:frame``)."""

    @model_validator(mode="after")
    def _check(self) -> Animation:
        if self.frames is not None:
            first, last = self.frames
            if first < 0 or last < first:
                raise FieldError(("frames",), f"expected [first, last] with 0 <= first <= last, "
                                              f"got {list(self.frames)}")
        seen = set()
        for i, track in enumerate(self.meshes):
            if track.mesh in seen:
                raise FieldError(("meshes", i, "mesh"), f"mesh {track.mesh} is animated twice")
            seen.add(track.mesh)
        return self

    def frame_range(self) -> tuple[int, int]:
        """``frames`` or the span of all keys (rounded outwards)."""
        if self.frames is not None:
            return self.frames
        keys = [k.frame for t in ([self.camera] if self.camera else []) + list(self.meshes) for k in t.keys]
        return max(int(np.floor(min(keys))), 0), max(int(np.ceil(max(keys))), 0)


def check_scene(scene) -> None:
    """Scene-level checks (called by Scene's validator): each track names a mesh that exists;
    focus keys have a lens to focus."""
    cam = scene.animation.camera
    for i, key in enumerate(cam.keys if cam is not None else ()):
        if key.focus_distance is not None and scene.camera.lens is None:
            raise FieldError(("animation", "camera", "keys", i, "focus_distance"),
                             "focus_distance needs a thin lens (camera.lens)")
    for i, track in enumerate(scene.animation.meshes):
        if track.mesh >= len(scene.meshes):
            raise FieldError(("animation", "meshes", i, "mesh"),
                             f"no mesh {track.mesh} (the scene has {len(scene.meshes)})")


def camera_moves(scene) -> bool:
    """The camera has keys: compile the eye offset (glsl/camera.glsl MCPT_CAMERA_MOVES)."""
    anim = getattr(scene, "animation", None)
    return anim is not None and anim.camera is not None


def origin(scene) -> tuple:
    """Where the geometry is rebased: the animation's origin, else the camera position."""
    anim = getattr(scene, "animation", None)
    return anim.origin if anim is not None and anim.origin is not None else scene.camera.position


def _track(keys, name: str, mode: str, rotation: bool = False, value=None) -> Track | None:
    got = [(k.frame, value(k) if value else getattr(k, name)) for k in keys]
    got = [(f, v) for f, v in got if v is not None]
    if not got:
        return None
    return Track.make([f for f, _ in got], [v for _, v in got], mode, rotation)


def camera_at(track: CameraTrack, camera: dict, frame: float) -> dict:
    """The camera's fields (``model_dump`` form) at ``frame``."""
    out = dict(camera)
    if out.get("fov_deg") is not None:
        out["vfov_deg"] = None  # derived from fov_deg again (as Scene.with_overrides does)
    for name in CAMERA_CHANNELS:
        t = _track(track.keys, name, track.interpolation)
        if t is None:
            continue
        v = t.at(frame)
        if name == "vfov_deg":
            out.update(vfov_deg=float(v[0]), fov_deg=None, fov_axis=None)
        elif name == "focus_distance":
            out["lens"] = {**out["lens"], "focus_distance": float(v[0])}
        else:
            out[name] = tuple(float(x) for x in v)
    return out


def mesh_matrix(track: MeshTrack, frame: float) -> np.ndarray:
    """The animated placement ``T R S`` (4x4 float64) of ``track`` at ``frame``."""
    m = np.eye(4)
    t = _track(track.keys, "translate", track.interpolation)
    r = _track(track.keys, "rotate", track.interpolation, True, lambda k: k.quaternion())
    s = _track(track.keys, "scale", track.interpolation)
    if r is not None:
        m[:3, :3] = quat_matrix(r.at(frame))
    if s is not None:
        m[:3, :3] = m[:3, :3] @ np.diag(s.at(frame))
    if t is not None:
        m[:3, 3] = t.at(frame)
    return m


def eye_offset(scene) -> tuple:
    """The camera position relative to the geometry's origin (the ``u_cam_eye`` uniform)."""
    return tuple(float(x) for x in np.subtract(scene.camera.position, origin(scene), dtype=np.float64))


def camera_uniforms(scene) -> dict:
    """The uniforms a moving camera changes between frames: every camera uniform as
    mcpt/gpu/pack.py sets it (mcpt/shading/camera.py), and the eye."""
    from ..shading.camera import camera_uniforms as of_camera

    return {**of_camera(scene.camera), "u_cam_eye": eye_offset(scene)}
