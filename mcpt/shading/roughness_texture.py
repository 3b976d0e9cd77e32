"""Roughness textures (issue #22; GLSL side: glsl/roughness_texture.glsl): a rough conductor's or a
rough dielectric's microfacet alpha read per hit,

    alpha = clamp(roughness x texture.r, MIN_ALPHA, 1)

``roughness`` the table's alpha (texel 2.x: 1 when the YAML gives only the texture), ``texture.r``
the texture's first channel at the hit's UV (a grey image's grey), read linearly (c / 255) or
sRGB-decoded (``encoding: srgb``: Mitsuba 3's bitmap without ``raw=true``, which decodes every PNG,
grey ones included). MIN_ALPHA is the least alpha either material takes (materials.MIN_ALPHA =
roughdielectric.MIN_ALPHA = 0.001): below it the densities are too peaked for float32.

Where alpha is set: once per hit, where glsl/pathtrace.frag fetches the material (beside the albedo
texture and glTF's metallic-roughness lookup), before light sampling and BSDF sampling, so next-event
estimation, BSDF sampling, evaluation and both MIS densities at that hit see one alpha. Sampling at
a textured alpha is sampling at that alpha: the per-alpha chi-square tests (tests/test_sampling.py)
cover it.

The texture id travels in the material's flags, bits 16-31, as id + 1 (0: none): texel 3 means a
different thing per type (a conductor's eta or lobe scale, glass's absorption, a plastic's
Fdr_int), the flags are read by every type, and scenes without a roughness texture keep every table
bit as before. ``roughplastic`` takes none: its coat's transmittance tables (roughplastic.py) are
computed for one alpha, as Mitsuba 3's roughplastic takes alpha as a number.
"""

from __future__ import annotations

import numpy as np

from .texture import TextureError

TYPES = ("conductor", "roughdielectric")
SHIFT = 16                   # flags bits 16-31: the texture id + 1
MAX_ID = (1 << 16) - 2       # the largest id those bits hold


def uses(table, ids) -> dict[str, bool]:
    """The features.Uses field: whether some used material reads a roughness texture."""
    return {"roughness_textures": any(table.roughness_texture[i] >= 0 for i in table.used(ids))}


def flag_bits(table) -> np.ndarray:
    """The flags bits of each row: (texture id + 1) << 16, 0 without a roughness texture."""
    ids = np.asarray(table.roughness_texture, np.int64)
    if ids.size and ids.max() > MAX_ID:
        raise TextureError(f"a roughness texture has id {int(ids.max())}: at most {MAX_ID + 1} textures fit "
                        "the material flags' 16 bits")
    return np.where(ids >= 0, (ids + 1) << SHIFT, 0).astype(np.int64)
