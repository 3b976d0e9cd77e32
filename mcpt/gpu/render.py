"""Passes on the GPU, averaged on the host (GLSL side: glsl/pathtrace.frag).

Each pass renders one sample per pixel into an RGBA32F target with additive blending; every
``chunk`` passes the float32 target is read back, added into a float64 sum and cleared, so the
average never loses precision, however many passes (the thesis averaged 8-bit images).

Random numbers (mcpt/shading/sampler.py): with ``sobol`` (default) the shader computes them from
the seed, the pixel and the pass (sample) index, set as one uniform: no host work and no upload
per pass, and a draw takes several samples per pixel (path regeneration, glsl/pathtrace.frag).
With ``independent`` each pass gets fresh numbers in one of two buffer textures used in turn;
large images are then split into tiles (scissored draws), which bounds that buffer by
GL_MAX_TEXTURE_BUFFER_SIZE.

Where the driver caps loop iterations (llvmpipe), paths still running when a draw has spent its
share are stored and continued by further draws of the same pass (mcpt/gpu/path_state.py).

Draws, read-backs and stops fall on one global grid of passes counted from pass 0, whatever
pass a run starts at: a draw never spans a multiple of ``samples_per_draw`` or of ``chunk``.
So one render, a resumed one and the tasks of a farm group samples the same way and add the
same float32 and float64 numbers in the same order (bit-identical images, issue #11).
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass, field

import moderngl
import numpy as np

from ..errors import McptError
from ..shading.sampler import RandomNumbers
from ..shading.sobol import seed32
from . import aov as aov_mod
from . import shader, wavefront
from .bands import BAND_PATHS, BAND_SECONDS, padded, part_geometry, plan_bands, plan_strips
from .context import GLContext
from .features import Features, samples_per_draw
from .host_memory import available_bytes, host_bytes
from .pack import Packed
from .path_state import STATE_IMAGES, PathState
from .tbo import GL_R32F, create_tbo

log = logging.getLogger("mcpt")

#: Random numbers uploaded per pass (MiB) above which the independent sampler is worth a warning.
RANDOM_WARN_MIB = 64

# Random numbers per tile at most (uint32): 256 MiB, and far below llvmpipe's 2^27-texel limit.
MAX_RANDOM_PER_TILE = 1 << 26


class RenderError(McptError, RuntimeError):
    """The render cannot be done as asked (image too large for the driver or memory)."""


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
    aovs: dict = field(default_factory=dict)   # features.aov: albedo, normal, depth (mcpt/gpu/aov.py)
    alpha: np.ndarray | None = None  # (H, W) float32 transparent film: share of camera rays that hit

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


def check_host_memory(width: int, height: int, targets: int) -> None:
    """Refuse, before allocating, a render whose measured peak memory (host_memory.py) would not
    fit in the memory available."""
    need, free = host_bytes(width, height, targets), available_bytes()
    if free is not None and need > free:
        raise RenderError(f"{width}x{height} with {targets} accumulation target(s) needs about "
                          f"{need / 2**30:.1f} GiB of host memory, more than the "
                          f"{free / 2**30:.1f} GiB available here")


def drop_nonfinite(sums: np.ndarray, passes: int) -> np.ndarray:
    """Sums of one read-back whose float32 accumulation overflowed (each sample finite, e.g. a
    light of 1e37 W sr^-1 m^-2 added 64 times) are dropped for that pixel and counted: all
    ``passes`` of the read-back become dropped samples (alpha), so a non-finite value never
    reaches the float64 total or the image (issue #10). Shaders drop non-finite samples
    themselves; this catches what only the sum makes infinite."""
    bad = ~np.isfinite(sums).all(axis=(0, 3))
    if bad.any():
        sums[:, bad, :] = 0.0
        sums[0, bad, 3] = passes
    return sums


class Renderer:
    """A compiled program and the uploaded scene, ready to render passes.

    Takes what mcpt/gpu/pack.py packed (buffers and uniforms) and nothing else of the scene: the
    limits are checked first, then the program for ``features`` is compiled (or taken from the
    cache), then the buffers are uploaded. ``clamp`` (radiance, biased) needs features.clamp.
    """

    def __init__(self, gl: GLContext, features: Features, packed: Packed, *,
                 clamp: float | None = None, max_random_per_tile: int = MAX_RANDOM_PER_TILE):
        if (clamp is not None) != features.clamp:
            raise ValueError("clamp value and features.clamp disagree")
        self.gl, self.features = gl, features
        ctx = gl.ctx
        self.width, self.height = packed.width, packed.height
        # Refuse what cannot work before compiling or allocating anything.
        limits = gl.limits()
        cap = min(limits["max_texture_size"], *limits["max_viewport_dims"])
        if self.width > cap or self.height > cap:
            raise RenderError(f"{self.width}x{self.height} exceeds GL_MAX_TEXTURE_SIZE / "
                              f"GL_MAX_VIEWPORT_DIMS = {cap} on {gl.renderer}; lower --resolution")
        # Targets: beauty, then squares (variance), then the two AOV targets (glsl/aov.glsl).
        n_targets = 1 + int(features.variance) + (aov_mod.AOV_TARGETS if features.aov else 0)
        self.aov_target = 1 + int(features.variance) if features.aov else None
        check_host_memory(self.width, self.height, n_targets)
        t0 = time.perf_counter()
        self.wave = None
        if features.wavefront:  # issue #23: two kernels and queues between them (wavefront.py)
            kernels = wavefront.programs(ctx, features)
            self.program, self.wave = kernels[0], wavefront.Wavefront(ctx, kernels, self.width, self.height)
        elif features.compute:  # issue #23: the same GLSL as a compute shader (glsl/pathtrace.frag)
            self.program = shader.compute_program(ctx, "pathtrace.frag", features.preamble(), features.key)
        else:
            self.program = shader.program(ctx, "fullscreen.vert", "pathtrace.frag", features.preamble(),
                                          features.key)
        t1 = time.perf_counter()
        self.tbos = {}
        for name, arr in packed.buffers.items():
            per, item = packed.per_item.get(name, (1, "texels"))
            self.tbos[name] = create_tbo(gl, name, arr, per_item=per, item=item)
        if features.uploads_random:
            self.tiles = plan_tiles(self.width, self.height, features.random_dims,
                                    limits["max_texture_buffer_size"], max_random_per_tile)
            tile_pixels = max(w * h for _, _, w, h in self.tiles)
            # Host staging array filled in place each pass, and two buffer textures used in turn.
            self._numbers = np.zeros(tile_pixels * features.random_dims, np.float32)
            self.random = [create_tbo(gl, "random", self._numbers, internal_format=GL_R32F)
                           for _ in range(2)]
            mib = self.width * self.height * features.random_dims * 4 / 2**20
            if mib > RANDOM_WARN_MIB:
                log.warning("the independent sampler uploads %.0f MiB of random numbers a pass at "
                            "%d bounces; --sampler sobol computes them in the shader instead",
                            mib, features.bounces)
        else:  # sobol: numbers computed in the shader, nothing to upload or bound
            self.tiles = [(0, 0, self.width, self.height)]
            self._numbers = None
            self.random = []
        # Samples per pixel per draw (path regeneration, features.samples_per_draw: up to 64 by
        # the image's size); 1 where numbers are uploaded per pass.
        self.samples_per_draw = 1 if features.uploads_random else samples_per_draw(self.width, self.height)
        self.band_paths, self.band_seconds = BAND_PATHS, BAND_SECONDS  # mcpt/gpu/bands.py
        self._speed = 0.0  # paths/s of the last draw timed (Renderer._band_paths)
        self.targets = [ctx.texture((self.width, self.height), 4, dtype="f4")
                        for _ in range(n_targets)]
        self.fbo = ctx.framebuffer(color_attachments=self.targets)
        self.paths = PathState(ctx, self.width, self.height) if features.continues else None
        self.vao = None if features.compute else ctx.vertex_array(self.program, [])
        for name, value in packed.uniforms.items():
            self._uniform(name, value)
        if clamp is not None:
            self._uniform("u_clamp", float(clamp))
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
        for program in (self.program,) if self.wave is None else (self.wave.shade, self.wave.trace):
            if name in program:  # the specialised program may have compiled a uniform away
                program[name].value = value

    def passes(self, seed: int, start: int, stop: int, *, chunk: int = 64, carry=None,
               interrupt=None, drop_draw=None, tiles=None):
        """Draw passes ``start .. stop-1`` of ``seed``; a generator of ``(spp, sums)``: passes
        ``0 .. spp-1`` are drawn (those before ``start`` by an earlier call, or in ``carry``).

        ``sums`` is the float32 target read back (and cleared), shape (targets, H, W, 4), yielded at
        every multiple of ``chunk`` (counted from pass 0, not from ``start``), at ``stop``, and
        after a draw where ``interrupt(spp)`` is true (then the generator ends; a draw
        holds up to ``samples_per_draw`` passes). The render loop (mcpt/render.py) adds them
        into an Accumulator and makes the result (:meth:`result`). Because read-backs
        fall on the same passes wherever a render starts, stops or resumes, every way of adding
        them up in pass order (one render, a resumed one, tasks of a farm) adds the same numbers
        (mcpt/farm/accumulate.py). ``carry``: the target of an unfinished chunk to continue from;
        ``tiles``: indices into ``self.tiles`` to draw (default all; other pixels stay 0).

        ``drop_draw(spp, done)``: asked between the bands of a draw (:func:`plan_bands`; ``done``:
        the share of the draw's bands drawn) whether to drop the draw in progress and stop at
        ``spp``, the passes before it, as if ``interrupt`` had stopped after the draw before
        (issue #24 item 8: a stop waited up to a whole draw, seconds on llvmpipe).
        """
        ctx = self.gl.ctx
        upload = self.features.uploads_random
        streams = ([RandomNumbers(seed, w * h, self.features.random_dims, tile=i)
                    for i, (_, _, w, h) in enumerate(self.tiles)] if upload else [])
        todo = [(i, self.tiles[i]) for i in (range(len(self.tiles)) if tiles is None else tiles)]
        self._uniform("u_sobol_seed", seed32(seed))
        self.fbo.use()
        self._clear_targets()
        if carry is not None:
            for i, target in enumerate(self.targets):
                target.write(np.ascontiguousarray(np.flipud(carry[i]), np.float32).tobytes())
            self._clear_targets(clear=False)
        ctx.enable(moderngl.BLEND | moderngl.PROGRAM_POINT_SIZE)  # points: bands.py
        ctx.blend_func = moderngl.ONE, moderngl.ONE
        for t in self.tbos.values():
            t.bind()
        if self.features.compute:  # the targets are images after the path state's
            for i, target in enumerate(self.targets):
                target.bind_to_image(STATE_IMAGES + i, read=True, write=True)
        self._bind_state()
        self.random_seconds = 0.0
        spd = self.samples_per_draw
        self._draws = 0
        # Passes in the target at the next read-back: a carried target holds its chunk's passes.
        last = (start // chunk) * chunk if carry is not None else start
        plan = plan_strips if self.features.compute else plan_bands
        p = start
        try:
            while p < stop:
                n = min(spd - p % spd, chunk - p % chunk, stop - p)  # on the global grid
                self._uniform("u_samples", n)
                bands = [plan(tile, n, self._band_paths() if drop_draw else 0) for _, tile in todo]
                t0 = time.perf_counter()
                # A draw that may be dropped keeps the passes the target holds that the
                # accumulator does not (after a draw that ended inside a chunk), to stop with.
                kept = (self._read_targets() if sum(map(len, bands)) > 1 and p not in (last, start)
                        else None)
                if not self._draw(p, n, todo, bands, streams, drop_draw):
                    if kept is not None:
                        yield p, drop_nonfinite(kept, p - last)
                    return
                kept = None  # not held through the read-back (host memory peak, host_memory.py)
                p += n
                if interrupt is not None:  # issue #24: time the draw's work, not its queueing
                    ctx.finish()
                    self._speed = n * sum(w * h for _, (_, _, w, h) in todo) / max(time.perf_counter() - t0, 1e-9)
                stopping = interrupt is not None and interrupt(p)
                if p % chunk == 0 or p == stop or stopping:
                    ctx.scissor = None
                    yield p, drop_nonfinite(self._read_and_clear(np.float32), p - last)
                    last = p
                if stopping:
                    return
        finally:
            ctx.scissor = None
            ctx.viewport = (0, 0, self.width, self.height)
            self._uniform("u_parts", (0, 1, 0, 1))
            ctx.disable(moderngl.BLEND | moderngl.PROGRAM_POINT_SIZE)

    def _bind_state(self) -> None:
        """The images and buffers of continued paths or of the wavefront's kernels."""
        if self.wave is not None:
            self.wave.bind()
        if self.paths is not None:
            self.paths.bind()
            self._uniform("u_continue", 0)

    def _band_paths(self) -> int:
        """Paths a band holds: ``band_paths``, or as many as BAND_SECONDS takes at the speed of
        the last draw where that is more (a hardware GPU draws 2^22 paths in milliseconds, where
        a wait between bands would cost more than it saves). Bands change no pixel, so their
        size may follow the clock."""
        fit = int(self._speed * self.band_seconds)
        return max(self.band_paths, 1 << (fit.bit_length() - 1) if fit > 0 else 0)

    def _draw(self, p: int, n: int, todo, bands, streams, drop_draw) -> bool:
        """Passes ``p .. p+n-1`` of the tiles ``todo``, each in its ``bands``; False when
        ``drop_draw`` asked to drop the draw (then some bands hold the passes and some not)."""
        try:
            return self._draw_bands(p, n, todo, bands, streams, drop_draw)
        finally:
            self.gl.ctx.viewport = (0, 0, self.width, self.height)  # read-backs read the viewport

    def _draw_bands(self, p: int, n: int, todo, bands, streams, drop_draw) -> bool:
        ctx = self.gl.ctx
        total, done = sum(map(len, bands)), 0
        for (ti, (x0, y0, w, h)), parts in zip(todo, bands):
            if streams:
                tr = time.perf_counter()
                streams[ti].fill(p, self._numbers)  # a smaller last tile leaves an unread tail
                self.random_seconds += time.perf_counter() - tr
                buf = self.random[self._draws % 2]
                buf.write(self._numbers)
                buf.bind()
            else:
                self._uniform("u_sample_index", p)  # sobol: the draw's first sample index
            self._uniform("u_tile", (x0, y0, w, h))  # the tile, whatever band of it is drawn
            self._uniform("u_rand_stride", w * h)
            self._draws += 1
            for band in parts:
                draw = self._band_draw(band)
                if self.paths is not None:
                    self.paths.reset_count()
                draw()
                if self.paths is not None:  # long paths: further draws until all have ended
                    self.paths.finish(draw, lambda v: self._uniform("u_continue", v),
                                      limit=n * (self.features.bounces + 2))
                done += 1
                if drop_draw is not None and done < total:
                    ctx.finish()  # the band's work done: the question is asked in time
                    if drop_draw(p, done / total):
                        return False
        return True

    def _band_draw(self, band):
        """Set up ``band`` (plan_bands / plan_strips) and return the call that draws it (again
        for each continuation draw)."""
        ctx = self.gl.ctx
        bx, by, bw, bh = band[:4]
        y = self.height - by - bh  # GL rows count from the bottom; tiles and bands from the top
        if self.wave is not None:
            return lambda: self.wave.draw(self._uniform, (bx, y, bw, bh))
        if self.features.compute:
            # One invocation a pixel of the rectangle; the barrier makes its image adds visible to
            # the next dispatch's loads and to the read-back.
            self._uniform("u_dispatch", (bx, y, bw, bh))
            groups = (-(-bw // 8), -(-bh // 8))  # glsl/pathtrace.frag's 8x8 work group

            def dispatch():
                self.program.run(*groups)
                ctx.memory_barrier()
            return dispatch
        ctx.scissor = (bx, y, bw, bh)
        geometry, vertices = part_geometry(band, self.width, self.height)
        self._uniform("u_parts", geometry)
        mode = moderngl.TRIANGLES if vertices == 3 else moderngl.POINTS
        ctx.viewport = (0, 0, self.width, self.height) if vertices == 3 else padded(self.width, self.height)
        return lambda: self.vao.render(mode, vertices=vertices)

    def result(self, total: np.ndarray, spp: int, seed: int, seconds: float,
               random_seconds: float) -> RenderResult:
        """The image (and variance) from the float64 sums of ``spp`` passes."""
        # Non-finite samples were written as 0 with alpha 1: the mean is over the valid ones.
        dropped = int(round(total[0, ..., 3].sum()))
        n = np.maximum(spp - total[0, ..., 3], 1.0)[..., None]
        image = total[0, ..., :3] / n
        variance = None
        if self.features.variance:
            var = np.maximum(total[1, ..., :3] / n - image**2, 0.0) * n / np.maximum(n - 1.0, 1.0)
            variance = (var / n).astype(np.float32)
        aovs = {}
        if self.aov_target is not None:
            aovs = aov_mod.means(total[self.aov_target], total[self.aov_target + 1])
        setup = dict(self.setup)
        if self.paths is not None:
            setup["continuation_draws"] = self.paths.draws
        if self.wave is not None:
            setup["wavefront_steps"] = self.wave.steps  # trace + shade pairs run
        # Transparent film (MCPT_ALPHA): the squares target's alpha counts covering samples.
        alpha = (total[1, ..., 3] / n[..., 0]).astype(np.float32) if self.features.options.alpha else None
        return RenderResult(image.astype(np.float32), variance, spp, seed, self.features.bounces,
                            dropped, seconds, random_seconds, setup, aovs, alpha)

    def _read_targets(self, dtype=np.float32) -> np.ndarray:
        """The accumulation targets as (targets, H, W, 4), row 0 at the top."""
        out = []
        for i in range(len(self.targets)):
            raw = np.frombuffer(self.fbo.read(components=4, dtype="f4", attachment=i), np.float32)
            out.append(np.flipud(raw.reshape(self.height, self.width, 4)))
        return np.stack(out).astype(dtype)

    def _read_and_clear(self, dtype=np.float64) -> np.ndarray:
        """The accumulation targets as (targets, H, W, 4), row 0 at the top; then cleared."""
        out = self._read_targets(dtype)
        self._clear_targets()
        return out

    def _clear_targets(self, clear: bool = True) -> None:
        """Clear the accumulation targets (``clear``), then, for the compute dispatch, wait for
        what was written to them: llvmpipe defers a framebuffer clear past a later compute
        dispatch, whose adds then vanished (measured: the second read-back of a render was 0)."""
        if clear:
            self.fbo.clear(0.0, 0.0, 0.0, 0.0)
        if self.features.compute:
            self.gl.ctx.finish()

    def release(self) -> None:
        for t in list(self.tbos.values()) + self.random:
            t.release()
        if self.vao is not None:
            self.vao.release()
        self.fbo.release()
        if self.wave is not None:
            self.wave.release()
        if self.paths is not None:
            self.paths.release()
        for t in self.targets:
            t.release()
