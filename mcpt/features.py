"""What a scene needs, derived once: the single source of every shader define and of the data diet.

``Features`` is immutable and hashable; :meth:`Features.defines` emits EVERY define as 0/1 (or a
number), so ``#if MCPT_X`` never silently reads an undefined macro, and the program cache is keyed by
:attr:`Features.key`. ``Features.everything()`` is the uber-shader (``--features all``) used to
measure what specialisation gains.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, replace

# Russian roulette starts after this many scattering events (Mitsuba's rr_depth is 5 path
# segments = 4 scattering events; we start a little earlier, it is unbiased either way).
RR_START = 3

# Random numbers each path vertex consumes (mcpt/sampler.py documents the layout):
# light choice, light point (2), BSDF direction (2), roulette.
DIMS_CAMERA = 2
DIMS_PER_BOUNCE = 6

# Below this many triangles a linear loop beats BVH traversal (measured: bench/, issue #4).
BVH_MIN_TRIANGLES = 64


@dataclass(frozen=True)
class Features:
    bounces: int                    # maximum scattering events (0: emitters only)
    lights: bool = True             # any emissive triangle (NEE needs one)
    single_light: bool = False      # exactly one emissive triangle: no light CDF search
    mis: bool = True                # MIS between light and BSDF sampling (power heuristic)
    russian_roulette: bool = True   # only matters when bounces > RR_START
    bvh: bool = True                # False: brute-force loop over all triangles
    diffuse: bool = True            # Lambertian material present
    clamp: bool = False             # biased firefly clamp, off unless asked for
    variance: bool = False          # also accumulate squares (per-pixel variance, golden tests)

    @property
    def nee(self) -> bool:
        return self.lights and self.bounces >= 1

    @property
    def rr(self) -> bool:
        return self.russian_roulette and self.bounces > RR_START

    @property
    def random_dims(self) -> int:
        """Random numbers per pixel per pass: the camera jitter plus each bounce's share."""
        return DIMS_CAMERA + DIMS_PER_BOUNCE * self.bounces

    @property
    def key(self) -> tuple:
        return tuple(sorted(asdict(self).items()))

    def defines(self) -> dict[str, int]:
        b = int
        return {
            "MCPT_BOUNCES": self.bounces,
            "MCPT_RAND_DIMS": self.random_dims,
            "MCPT_NEE": b(self.nee),
            "MCPT_MIS": b(self.nee and self.mis),
            "MCPT_LIGHTS": b(self.lights),
            "MCPT_SINGLE_LIGHT": b(self.single_light),
            "MCPT_RR": b(self.rr),
            "MCPT_RR_START": RR_START,
            "MCPT_BVH": b(self.bvh),
            "MCPT_MAT_DIFFUSE": b(self.diffuse),
            "MCPT_CLAMP": b(self.clamp),
            "MCPT_VARIANCE": b(self.variance),
        }

    def preamble(self) -> str:
        return "\n".join(f"#define {k} {v}" for k, v in self.defines().items())

    def everything(self) -> "Features":
        """The uber-shader: every optional code path compiled in (bounces stay as given)."""
        return replace(self, lights=True, single_light=False, mis=True, russian_roulette=True,
                       bvh=True, diffuse=True)


def derive(*, bounces: int, n_triangles: int, n_emissive: int, material_types: set[str],
           mis: bool = True, russian_roulette: bool = True, bvh: bool | None = None,
           clamp: bool = False, variance: bool = False) -> Features:
    """Features of a scene from its counts; the one place these decisions are made."""
    return Features(
        bounces=bounces,
        lights=n_emissive > 0,
        single_light=n_emissive == 1,
        mis=mis,
        russian_roulette=russian_roulette,
        bvh=(n_triangles >= BVH_MIN_TRIANGLES) if bvh is None else bvh,
        diffuse="diffuse" in material_types,
        clamp=clamp,
        variance=variance,
    )
