"""Material table (GLSL side: glsl/materials.glsl). Two RGBA32UI texels per material:
(albedo.rgb float bits, type id), (emission.rgb float bits, light_pdf_area float bits)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

TYPES = {"diffuse": 0}


@dataclass(frozen=True)
class MaterialTable:
    names: tuple[str, ...]
    types: tuple[str, ...]
    albedo: np.ndarray          # (M, 3) linear RGB reflectance
    emission: np.ndarray        # (M, 3) emitted radiance, front side only

    def pack(self, light_pdf_area: np.ndarray) -> np.ndarray:
        m = len(self.names)
        out = np.zeros((2 * max(m, 1), 4), np.uint32)
        out[0:2 * m:2, :3] = self.albedo.astype(np.float32).view(np.uint32)
        out[0:2 * m:2, 3] = [TYPES[t] for t in self.types]
        out[1:2 * m:2, :3] = self.emission.astype(np.float32).view(np.uint32)
        out[1:2 * m:2, 3] = np.asarray(light_pdf_area, np.float32).view(np.uint32)
        return out
