"""The stability suite (issue #6): stiff and extreme cases, each with an expected answer.

Every case builds its scene programmatically (:func:`mcpt.scene.parse_scene` on generated YAML and
generated OBJ files), renders or probes it through the real GPU code, and returns an
:class:`Outcome`: what was expected, what was measured, pass or fail. The same cases run twice:

* ``make stability`` (``python -m mcpt.bench.stability``) prints them as a table;
* ``tests/test_stability.py`` runs each as a pytest test (CI, on EGL and on OSMesa).

A case that fails for a known reason outside this module's reach carries ``known``: a function
of the environment returning the reason and the fix (or None where the case is expected to pass,
e.g. on a GPU without llvmpipe's loop limit). pytest marks such a case ``xfail(strict=True)``,
so fixing the cause turns it into a failure that asks for the mark to go.

Statistics: renders are compared with :func:`mcpt.bench.stats.z_test` (per pixel-channel z-test with a
Šidák-corrected threshold, 99.75 % must accept, plus the image mean within 4 standard errors).
Everything is seeded, and llvmpipe is bit-deterministic, so a case gives the same numbers on
every run on one machine.

Budget: the whole suite runs in well under a minute on a 2-core llvmpipe machine; images are
8x8 to 32x32 pixels, sample counts 4 to 64.
"""

from . import deep, furnace, geometry, lights, limits, runtime, scale, watertight  # noqa: F401 (register cases)
from .core import CASES, Case, Env, Outcome, Row, run_case

__all__ = ["CASES", "Case", "Env", "Outcome", "Row", "run_case"]
