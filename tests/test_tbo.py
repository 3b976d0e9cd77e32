import numpy as np
import pytest

from mcpt.bench.probe import PROBE_UNIT
from mcpt.gpu.tbo import UNITS, TBOError, check_size

from .probes import run_test_probe


def test_the_probe_buffer_shares_no_unit_with_the_renderer():
    assert PROBE_UNIT not in UNITS.values()
    assert "probe" not in UNITS  # the library binds no test data


def test_every_texel_round_trips_bit_for_bit(gl):
    rng = np.random.default_rng(7)
    data = rng.integers(0, 2**32, (5000, 4), dtype=np.uint32)
    # Float bit patterns that a float path would mangle: NaN payloads, denormals, -0, inf.
    specials = np.array([np.nan, -0.0, 1e-45, 1e-40, np.inf, -np.inf], np.float32).view(np.uint32)
    data[: specials.size, 0] = specials
    data[10, :] = [0, 1, 2, 0xFFFFFFFF]
    out = run_test_probe(gl, "probe_tbo.frag", data, data.shape[0])
    assert out.dtype == np.uint32
    assert np.array_equal(out, data)


def test_float32_arrays_travel_as_their_bits(gl):
    f = np.random.default_rng(1).normal(size=(300, 4)).astype(np.float32)
    out = run_test_probe(gl, "probe_tbo.frag", f, 300)
    assert np.array_equal(out.view(np.float32), f)


def test_size_check_names_the_limit_and_what_fits(gl):
    limit = gl.limits()["max_texture_buffer_size"]
    check_size(gl, "tris", limit, 3, "triangles")  # exactly at the limit is fine
    with pytest.raises(TBOError) as e:
        check_size(gl, "tris", limit + 1, 3, "triangles")
    msg = str(e.value)
    assert "GL_MAX_TEXTURE_BUFFER_SIZE" in msg and f"{limit // 3} triangles" in msg
