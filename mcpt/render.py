"""Passes on the GPU, averaged on the host (GLSL side: glsl/pathtrace.frag).

Each pass renders one sample per pixel into an RGBA32F target with additive blending; every
``chunk`` passes the float32 target is read back, added into a float64 sum and cleared, so the
average never loses precision, however many passes (the thesis averaged 8-bit images).

Random numbers (mcpt/sampler.py): with ``sobol`` (default) the shader computes them from the
seed, the pixel and the pass index, set as one uniform: no host work and no upload per pass.
With ``independent`` each pass gets fresh numbers in one of two buffer textures used in turn, so
writing the next pass's numbers never waits for the draw that reads the previous ones; large
images are then split into tiles (scissored draws), which bounds that buffer by
GL_MAX_TEXTURE_BUFFER_SIZE.

Where the driver caps loop iterations (llvmpipe), paths still running when a draw has spent its
share are stored and continued by further draws of the same pass (mcpt/path_state.py).
"""

from __future__ import annotations

import os
import time
from dataclasses import dataclass, field

import moderngl
import numpy as np

from . import shader
from .camera import basis
from .context import GLContext
from .features import MAX_SAMPLES_PER_DRAW, SAMPLES_PER_DRAW, Features
from .loader import World
from .path_state import PathState
from .sampler import RandomNumbers
from .sobol import seed32
from .tbo import GL_R32F, create_tbo

# Random numbers per tile at most (uint32): 256 MiB, and far below llvmpipe's 2^27-texel limit.
MAX_RANDOM_PER_TILE = 1 << 26


# Texels per item of each buffer, so a size error can say how many items would fit.
_ITEMS = {"tris": (3, "triangles"), "nodes": (4, "BVH nodes"), "materials": (2, "materials"),
          "lights": (1, "emissive triangles"), "normals": (1, "triangles"), "uvs": (2, "triangles")}


class RenderError(RuntimeError):
    pass


@dataclass
class RenderResult:
    image: np.ndarray            # (H, W, 3) float32 mean radiance, row 0 at the top
    variance: np.ndarray | None  # (H, W, 3) float32 variance OF THE MEAN (sample var / n), or None
    spp: int
    seed: int
    bounces: int
    dropped_samples: int         # non-finite samples detected and left out of the mean
    render_seconds: float        # passes only (set-up excluded)
    random_seconds: float        # generating random numbers on the host (inside render_seconds)
    setup: dict = field(default_factory=dict)  # compile seconds, upload bytes per buffer, tiles

    @property
    def paths_per_second(self) -> float:
        h, w, _ = self.image.shape
        return w * h * self.spp / max(self.render_seconds, 1e-12)


def plan_tiles(width: int, height: int, dims: int, limit_texels: int,
               max_per_tile: int = MAX_RANDOM_PER_TILE) -> list[tuple[int, int, int, int]]:
    """Split the image into full-width bands so each band's random numbers fit the limits."""
    budget = min(limit_texels, max_per_tile)
    rows = max(1, min(height, budget // max(1, width * dims)))
    if width * dims > budget:
        raise RenderError(f"one image row needs {width * dims} random numbers, more than the "
                          f"{budget} one buffer may hold; lower the resolution or the bounces")
    return [(0, y, width, min(rows, height - y)) for y in range(0, height, rows)]


def host_bytes(width: int, height: int, targets: int) -> int:
    """Host memory the accumulation needs: a float64 RGBA sum per target plus one float32 read-back."""
    return width * height * 4 * targets * (8 + 4)


def check_host_memory(width: int, height: int, targets: int) -> None:
    """Refuse, before allocating, an image whose accumulation would not fit in physical memory."""
    need = host_bytes(width, height, targets)
    try:
        total = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (ValueError, OSError, AttributeError):  # pragma: no cover - not POSIX
        return
    if need > 0.5 * total:
        raise RenderError(f"{width}x{height} needs {need / 2**30:.1f} GiB of host memory for "
                          f"accumulation, more than half of the {total / 2**30:.1f} GiB here")


class Renderer:
    """A compiled program and the uploaded scene, ready to render passes."""

    def __init__(self, gl: GLContext, world: World, features: Features, *,
                 max_random_per_tile: int = MAX_RANDOM_PER_TILE):
        self.gl, self.world, self.features = gl, world, features
        self.samples_per_draw = SAMPLES_PER_DRAW
        ctx = gl.ctx
        cam = world.scene.camera
        self.width, self.height = cam.width, cam.height
        # Refuse what cannot work before compiling or allocating anything.
        limits = gl.limits()
        cap = min(limits["max_texture_size"], *limits["max_viewport_dims"])
        if self.width > cap or self.height > cap:
            raise RenderError(f"{self.width}x{self.height} exceeds GL_MAX_TEXTURE_SIZE / "
                              f"GL_MAX_VIEWPORT_DIMS = {cap} on {gl.renderer}; lower --resolution")
        check_host_memory(self.width, self.height, 2 if features.variance else 1)
        t0 = time.perf_counter()
        self.program = shader.program(ctx, "fullscreen.vert", "pathtrace.frag", features.preamble(),
                                      features.key)
        t1 = time.perf_counter()
        self.tbos = {}
        for name, arr in world.buffers(features).items():
            per, item = _ITEMS.get(name, (1, "texels"))
            if name == "materials":
                per = features.material_texels
            self.tbos[name] = create_tbo(gl, name, arr, per_item=per, item=item)
        if features.uploads_random:
            self.tiles = plan_tiles(self.width, self.height, features.random_dims,
                                    limits["max_texture_buffer_size"], max_random_per_tile)
            tile_pixels = max(w * h for _, _, w, h in self.tiles)
            # Host staging array filled in place each pass, and two buffer textures used in turn.
            self._numbers = np.zeros(tile_pixels * features.random_dims, np.float32)
            self.random = [create_tbo(gl, "random", self._numbers, internal_format=GL_R32F)
                           for _ in range(2)]
        else:  # sobol: numbers computed in the shader, nothing to upload or bound
            self.tiles = [(0, 0, self.width, self.height)]
            self._numbers = None
            self.random = []
        self.targets = [ctx.texture((self.width, self.height), 4, dtype="f4")
                        for _ in range(2 if features.variance else 1)]
        self.fbo = ctx.framebuffer(color_attachments=self.targets)
        self.paths = PathState(ctx, self.width, self.height) if features.continues else None
        self.vao = ctx.vertex_array(self.program, [])
        f, r, u = basis(cam.position, cam.look_at, cam.up, cam.vfov_deg, self.width, self.height)
        self._uniform("u_cam_forward", tuple(f))
        self._uniform("u_cam_right", tuple(r))
        self._uniform("u_cam_up", tuple(u))
        self._uniform("u_resolution", (self.width, self.height))
        self._uniform("u_tri_count", world.n_triangles)
        self._uniform("u_light_count", world.lights.count)
        t2 = time.perf_counter()
        self.setup = {
            "compile_seconds": t1 - t0,
            "upload_seconds": t2 - t1,
            "upload_bytes": {k: v.nbytes for k, v in self.tbos.items()},
            "random_bytes_per_pass": (int(self.width * self.height * features.random_dims * 4)
                                      if features.uploads_random else 0),
            "sampler": features.sampler,
            "tiles": len(self.tiles),
        }

    def _uniform(self, name, value):
        if name in self.program:  # the specialised program may have compiled a uniform away
            self.program[name].value = value

    def render(self, spp: int, seed: int, *, progress=None, chunk: int = 64,
               clamp: float | None = None, samples_per_draw: int | None = None) -> RenderResult:
        """Render ``spp`` samples per pixel with random numbers from ``seed``;
        ``progress(done, total)``. ``chunk``: draws between float64 read-backs."""
        if spp < 1:
            raise RenderError(f"spp must be >= 1, got {spp}")
        ctx = self.gl.ctx
        if clamp is not None:
            self._uniform("u_clamp", float(clamp))
        dims = self.features.random_dims
        upload = self.features.uploads_random
        streams = [RandomNumbers(seed, w * h, dims, tile=i) for i, (_, _, w, h) in enumerate(self.tiles)]
        self._uniform("u_sobol_seed", seed32(seed))
        total = np.zeros((len(self.targets), self.height, self.width, 4), np.float64)
        self.fbo.use()
        self.fbo.clear(0.0, 0.0, 0.0, 0.0)
        ctx.enable(moderngl.BLEND)
        ctx.blend_func = moderngl.ONE, moderngl.ONE
        for t in self.tbos.values():
            t.bind()
        if self.paths is not None:
            self.paths.bind()
            self._uniform("u_continue", 0)
            draws_before = self.paths.draws
        rand_seconds = 0.0
        draws = 0
        t0 = time.perf_counter()
        # Sobol: several samples per pixel per draw (path regeneration, glsl/pathtrace.frag);
        # independent numbers are uploaded for one sample per pass.
        spd = 1 if upload else max(1, min(int(samples_per_draw or self.samples_per_draw),
                                          MAX_SAMPLES_PER_DRAW))
        self._uniform("u_samples", 1)

        def stage(pass_index: int, tile: int) -> float:
            """Independent numbers of (pass, tile) into the staging array; host seconds."""
            tr = time.perf_counter()
            streams[tile].fill(pass_index, self._numbers)  # a smaller last tile leaves a tail
            return time.perf_counter() - tr

        if upload:
            rand_seconds += stage(0, 0)
        done, p = 0, 0
        while done < spp:
            n_draw = min(spd, spp - done)
            self._uniform("u_samples", n_draw)
            for ti, (x0, y0, w, h) in enumerate(self.tiles):
                if upload:  # staged during the previous draw (glBufferSubData copies them)
                    buf = self.random[draws % 2]
                    buf.write(self._numbers)
                    buf.bind()
                else:
                    self._uniform("u_sample_index", done)  # sobol: first sample index of the draw
                self._uniform("u_tile", (x0, y0, w, h))
                self._uniform("u_rand_stride", w * h)
                # GL rows count from the bottom; tiles are given from the top.
                ctx.scissor = (x0, self.height - y0 - h, w, h)
                if self.paths is not None:
                    self.paths.reset_count()
                self.vao.render(moderngl.TRIANGLES, vertices=3)
                draws += 1
                if upload:  # the next draw's numbers, made while this one renders
                    nxt = (p, ti + 1) if ti + 1 < len(self.tiles) else (p + 1, 0)
                    if nxt[0] < spp:
                        rand_seconds += stage(*nxt)
                if self.paths is not None:  # long paths: further draws until all have ended
                    self.paths.finish(lambda: self.vao.render(moderngl.TRIANGLES, vertices=3),
                                      lambda v: self._uniform("u_continue", v),
                                      limit=n_draw * (self.features.bounces + 2))
            done += n_draw
            p += 1
            if p % chunk == 0 or done == spp:
                total += self._read_and_clear()
                if progress is not None:
                    progress(done, spp)
        ctx.scissor = None
        ctx.disable(moderngl.BLEND)
        seconds = time.perf_counter() - t0
        # Non-finite samples were written as 0 with alpha 1: the mean is over the valid ones.
        dropped = int(round(total[0, ..., 3].sum()))
        n = np.maximum(spp - total[0, ..., 3], 1.0)[..., None]
        image = total[0, ..., :3] / n
        variance = None
        if self.features.variance:
            var = np.maximum(total[1, ..., :3] / n - image**2, 0.0) * n / np.maximum(n - 1.0, 1.0)
            variance = (var / n).astype(np.float32)
        setup = dict(self.setup)
        if self.paths is not None:
            setup["continuation_draws"] = self.paths.draws - draws_before
        return RenderResult(image.astype(np.float32), variance, spp, seed, self.features.bounces,
                            dropped, seconds, rand_seconds, setup)

    def _read_and_clear(self) -> np.ndarray:
        out = []
        for i in range(len(self.targets)):
            raw = np.frombuffer(self.fbo.read(components=4, dtype="f4", attachment=i), np.float32)
            out.append(np.flipud(raw.reshape(self.height, self.width, 4)))
        self.fbo.clear(0.0, 0.0, 0.0, 0.0)
        return np.stack(out).astype(np.float64)

    def release(self) -> None:
        for t in list(self.tbos.values()) + self.random:
            t.release()
        self.vao.release()
        self.fbo.release()
        if self.paths is not None:
            self.paths.release()
        for t in self.targets:
            t.release()
