"""Frame sequences (issue #26): one image per frame of an animated scene, through the one render loop.

    frames     "1-240", "1,5,10-20" (:func:`parse_frames`), or the scene's ``animation.frames``
    outputs    ``out/shot.####.exr``: the last run of ``#`` is the frame number, zero-padded to
               the run's width (Blender's convention, :func:`frame_path`)
    a frame    mcpt.scene.animation.at_frame: the scene at frame N, seeded with the frame's own
               seed; then mcpt/render.py ``run`` draws and writes it as any still

Set-up: when only the camera moves the scene is prepared (built, packed, compiled, uploaded) once
and each frame sets the camera's uniforms (the geometry is rebased at the rest pose's camera,
glsl/camera.glsl MCPT_CAMERA_MOVES); when meshes move each frame is prepared again (the BVH and
the upload are one piece: nothing finer to rebuild; the compiled program comes from the cache).

A frame whose outputs all exist and that has no ``.state.npz`` beside its first output is done
and skipped: a rerun after a crash renders only what is missing (images are written atomically,
mcpt/output/image.py). ``--time`` is the whole sequence's budget: no frame starts that the last
frame's time says cannot finish, and no frame is cut short (the next run carries on).
``--checkpoint`` / ``--resume`` work per frame (a frame's state is removed once it is done).
"""

from __future__ import annotations

import re
import time
from dataclasses import dataclass, field, replace
from pathlib import Path

from .errors import McptError
from .farm import state as st
from .farm.signals import StopSignals
from .output.image import check_output_path
from .output.layers import computed as computed_aovs
from .prepare import prepare
from .render import Options, run
from .scene import Scene, load_scene
from .scene.animation import camera_uniforms
from .scene.frame import at_frame

_RUN = re.compile(r"#+")


class SequenceError(McptError, ValueError):
    """A frame list or an output pattern that cannot make a sequence."""


def parse_frames(text: str) -> list:
    """``"1-240"``, ``"1,5,10-20"`` -> the frames in order, each once (non-negative integers)."""
    frames: list = []
    for part in str(text).split(","):
        m = re.fullmatch(r"\s*(\d+)\s*(?:-\s*(\d+)\s*)?", part)
        if not m:
            raise SequenceError(f"--frames {text!r}: {part.strip()!r} is not N or FIRST-LAST "
                                "(non-negative integers, e.g. 1-240 or 1,5,10-20)")
        a = int(m.group(1))
        b = int(m.group(2)) if m.group(2) is not None else a
        if b < a:
            raise SequenceError(f"--frames {text!r}: {part.strip()} runs backwards")
        frames.extend(f for f in range(a, b + 1) if f not in frames)
    return frames


def is_pattern(output) -> bool:
    return "#" in Path(output).name


def frame_path(pattern, frame: int) -> Path:
    """``shot.####.exr`` at frame 7 -> ``shot.0007.exr`` (the last run of ``#``; a number wider
    than the run is written whole). A name without ``#`` is returned as is."""
    p = Path(pattern)
    runs = list(_RUN.finditer(p.name))
    if not runs:
        return p
    r = runs[-1]
    return p.with_name(p.name[:r.start()] + str(frame).zfill(r.end() - r.start()) + p.name[r.end():])


def check_outputs(outputs, frames) -> dict:
    """Each frame's output paths, checked before any work (folder writable, format known)."""
    if len(frames) > 1:
        for o in outputs:
            if not is_pattern(o):
                raise SequenceError(f"{o}: {len(frames)} frames need a '#' in the file name for the "
                                    "frame number (e.g. out/shot.####.exr)")
    paths = {f: [frame_path(o, f) for o in outputs] for f in frames}
    for f in frames[:1]:  # one frame's files tell whether the folders can be written
        for path in paths[f]:
            check_output_path(path)
    return paths


def done(paths) -> bool:
    """A frame is done when all its images exist and no checkpoint state says it is partial."""
    return all(Path(p).is_file() for p in paths) and not st.state_path(paths[0]).exists()


@dataclass
class FrameReport:
    frame: int
    outputs: list
    setup_seconds: float          # at_frame + uniforms (camera only) or the whole prepare
    render_seconds: float
    wall_seconds: float
    spp: int
    seed: int


@dataclass
class SequenceOutcome:
    frames: list                                   # asked for, in order
    rendered: list = field(default_factory=list)   # FrameReport per frame rendered now
    skipped: list = field(default_factory=list)    # frames already done
    stopped_by: str | None = None                  # "time", "signal" or None
    interrupted: int | None = None                 # the signal number
    prepare_seconds: float = 0.0                   # the first (shared) prepare
    rebuilt: bool = False                          # meshes move: every frame prepared again


def base_scene(scene, opts: Options) -> Scene:
    """The scene file read with ``-D`` and the command-line render settings applied once."""
    if not isinstance(scene, Scene):
        scene = load_scene(scene, overrides=tuple(opts.overrides))
    return scene.with_overrides(spp=opts.spp, bounces=opts.bounces, seed=opts.seed,
                                resolution=opts.resolution)


def default_frames(scene: Scene) -> list:
    if scene.animation is None:
        raise SequenceError(f"{scene.where('animation')}: the scene has no animation: give --frames")
    first, last = scene.animation.frame_range()
    return list(range(first, last + 1))


def plan(scene, opts: Options, frames=None):
    """The base scene, the frames, each frame's outputs (checked) and the frames still to do."""
    if opts.first_pass:
        raise SequenceError("--first-pass renders a pass range of one still, not a sequence")
    base = base_scene(scene, opts)
    frames = list(frames) if frames is not None else default_frames(base)
    paths = check_outputs(opts.outputs, frames)
    return base, frames, paths, [f for f in frames if not done(paths[f])]


class FrameMaker:
    """Frames of one scene, as one process renders them: prepared once when only the camera moves
    (then each frame sets the camera's uniforms), prepared per frame when meshes move. A farm
    worker (mcpt/farm/frames.py) renders its frames with one of these too."""

    def __init__(self, base: Scene, opts: Options, client=None):
        """``client``: a Dask client to spread each frame's pass ranges over (mcpt/farm/)."""
        self.base, self.opts, self.p, self.client = base, opts, None, client
        anim = base.animation
        self.rebuild = anim is not None and bool(anim.meshes)
        self.camera = anim is not None and anim.camera is not None
        self.prepare_seconds = 0.0

    def render(self, f: int, paths: list, signals: StopSignals):
        """Frame ``f`` to ``paths``: ``(FrameReport, None)``, or ``(None, signum)`` if stopped."""
        t0 = time.perf_counter()
        scene_f = at_frame(self.base, f)
        fresh = self.p is None or self.rebuild
        if fresh:
            self.release()
            # moving meshes make every frame's world its own: keep them out of the set-up cache
            self.p = _prepare(scene_f, self.opts, cache=False if self.rebuild else None)
            self.prepare_seconds = self.prepare_seconds or self.p.setup_seconds
        elif self.camera:
            for name, value in camera_uniforms(scene_f).items():
                self.p.renderer._uniform(name, value)
        p = replace(self.p, scene=scene_f)
        setup = p.setup_seconds if fresh else time.perf_counter() - t0
        state = st.state_path(paths[0])
        frame_opts = replace(self.opts, outputs=[str(x) for x in paths], spp=None, seed=None,
                             time_budget=None, resume=self.opts.resume and state.exists(),
                             workers=None, scheduler=None, client=self.client,
                             started=time.perf_counter())
        res = run(p, frame_opts, signals)
        if res.interrupted is not None:
            return None, res.interrupted
        state.unlink(missing_ok=True)  # the frame is done: no state may call it partial
        return FrameReport(f, [str(x) for x in paths], setup, res.result.render_seconds,
                           time.perf_counter() - t0, res.result.spp, scene_f.render.seed), None

    def release(self) -> None:
        if self.p is not None:
            self.p.renderer.release()
            self.p = None


def render_sequence(scene, opts: Options, frames=None, signals: StopSignals | None = None,
                    on_frame=None) -> SequenceOutcome:
    """Render ``frames`` (default: the scene's ``animation.frames``) of ``scene`` to
    ``opts.outputs`` (patterns) in this process. ``on_frame(FrameReport)`` after each frame."""
    signals = signals if signals is not None else StopSignals()
    base, frames, paths, todo = plan(scene, opts, frames)
    out = SequenceOutcome(frames, skipped=[f for f in frames if f not in todo])
    maker = FrameMaker(base, opts)
    out.rebuilt = maker.rebuild
    last_wall = 0.0
    try:
        for f in todo:
            if opts.time_budget is not None and \
                    time.perf_counter() - opts.started + last_wall > opts.time_budget:
                out.stopped_by = "time"
                break
            rep, signum = maker.render(f, paths[f], signals)
            if rep is None:
                out.stopped_by, out.interrupted = "signal", signum
                break
            last_wall = rep.wall_seconds
            out.rendered.append(rep)
            if on_frame is not None:
                on_frame(rep)
    finally:
        out.prepare_seconds = maker.prepare_seconds
        maker.release()
    return out


def _prepare(scene: Scene, opts: Options, cache: bool | None = None):
    return prepare(scene, gl_backend=opts.gl_backend, features_mode=opts.features_mode,
                   clamp=opts.clamp, sampler=opts.sampler,
                   aovs=computed_aovs(opts.aovs, opts.denoise), cache=cache)
