"""The numbers of an OBJ file's ``v``/``vt``/``vn``/``f`` lines, parsed with numpy, bit for bit as
Assimp 5.4 parses them (issue #23: Assimp's OBJ import of 10^6 triangles costs seconds).

Assimp reads OBJ coordinates with ``fast_atoreal_move<float>`` (include/assimp/fast_atof.h), which
is not a correctly rounded parse: the integer part becomes a float32, the first 15 fraction digits
a double (their integer value times 10^-digits) rounded to float32, the two are added in float32,
and an exponent multiplies the sum by ``powf(10, e)``. :func:`assimp_floats` does the same, token
by token in columns, so that the fast OBJ reader (obj_fast.py) gives the triangles Assimp gives.
Face indices are ``atoi`` values (:func:`digit_values`).

Everything here works on a token table: the start and end offset of every token in the file's
bytes, the bytes already validated by the caller (digits, ``.``, ``-``, ``+``, ``e``, ``E`` only).
A token this module cannot read exactly as Assimp does raises :class:`Unsupported`; the caller
then hands the file to Assimp.
"""

from __future__ import annotations

import numpy as np

#: Assimp's ``fast_atof_table``: 10^-k as C double literals (Python's float literals are the same).
_FAST_ATOF_TABLE = np.array([0.0] + [float(f"1e-{k}") for k in range(1, 16)])
#: ``AI_FAST_ATOF_RELAVANT_DECIMALS``: fraction digits past the 15th are skipped.
_RELEVANT_DECIMALS = 15
#: Longest integer part read here (int64 holds 18 digits; Assimp's uint64 overflow check beyond).
_MAX_INT_DIGITS = 18
#: Spaces the caller appends to the text so that digit_values can read whole windows at its end.
PAD = 32
#: 10^k for k = 0..18 (a table lookup; numpy's integer ``10 ** array`` is a slow loop).
_POW10 = 10 ** np.arange(19, dtype=np.int64)
_DOT, _E, _LOWER_E, _MINUS, _PLUS = ord("."), ord("E"), ord("e"), ord("-"), ord("+")


#: Kinds of line: the tables numbers go to (v, vt, vn), faces, and lines that hold no numbers.
V, VT, VN, F, SKIP = range(5)


class Unsupported(Exception):
    """The tokens hold something this module does not parse exactly as Assimp: use Assimp."""


def token_bounds(text: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(starts, ends) offsets of the runs of bytes that are not a space (0x20) in ``text``, a
    uint8 array whose separators were all turned into spaces."""
    word = text != 32
    edge = np.flatnonzero(word[1:] != word[:-1]) + 1
    if word[0]:
        edge = np.concatenate([[0], edge])
    if word[-1]:
        edge = np.concatenate([edge, [len(text)]])
    return edge[0::2], edge[1::2]


def digit_values(text: np.ndarray, a: np.ndarray, z: np.ndarray) -> np.ndarray:
    """int64 value of the decimal digits ``text[a:z]`` of every span (empty span: 0). Raises
    Unsupported past 18 digits."""
    n = z - a
    width = int(n.max()) if n.size else 0
    if width > _MAX_INT_DIGITS:
        raise Unsupported("number too long")
    if width == 0:
        return np.zeros(len(a), np.int64)
    # All spans' bytes at once, left-aligned in `width` columns (a strided view of the text, one
    # row gathered per span), digits past a span's end zeroed, then Horner's rule a column at a
    # time: the row read as a `width`-digit number is the span's value times 10^(width - n).
    # The text must run `width` bytes past the last span (the caller pads it, PAD).
    if len(a) and int(a.max()) + width > len(text):
        raise Unsupported("text not padded")
    d = np.lib.stride_tricks.sliding_window_view(text, width)[a] - np.uint8(48)
    d[np.arange(width) >= n[:, None]] = 0
    if (d > 9).any():
        raise Unsupported("a non-digit in an integer")
    return _horner(d) // _POW10[width - n]


def _horner(d: np.ndarray) -> np.ndarray:
    """int64 value of every row of an (n, width) digit matrix (int32 sums up to 9 digits). No
    (n, width) integer copy is made: big temporaries cost page faults, issue #23."""
    small = np.int32 if d.shape[1] <= 9 else np.int64
    value = np.zeros(len(d), small)
    for j in range(d.shape[1]):
        value *= 10
        value += d[:, j]
    return value.astype(np.int64)


def _one_per_token(positions: np.ndarray, starts: np.ndarray, ends: np.ndarray) -> np.ndarray:
    """Token index of each position (sorted); raises Unsupported if a position lies outside the
    tokens (e.g. in a face index) or a token holds two."""
    if len(positions) == len(starts) and (positions >= starts).all() and (positions < ends).all():
        return np.arange(len(starts))  # one in every token (a dot in every number): no search
    tok = np.searchsorted(starts, positions, side="right") - 1
    if (tok < 0).any() or (positions >= ends[tok]).any():
        raise Unsupported("a dot or exponent outside the numbers")
    if tok.size > 1 and not (tok[1:] != tok[:-1]).all():
        raise Unsupported("two dots or exponents in one number")
    return tok


def _specials(text: np.ndarray, starts: np.ndarray, ends: np.ndarray):
    """Offsets of the dots, exponent letters and signs between the first token's start and the
    last one's end (one pass over that stretch only: in a usual OBJ the faces, which follow the
    vertices, are not scanned; digit_values rejects a non-digit in them)."""
    if not len(starts):
        return (np.zeros(0, np.int64),) * 3
    lo, hi = int(starts[0]), int(ends[-1])
    sub = text[lo:hi]
    at = np.flatnonzero((sub - np.uint8(48) > 9) & (sub != 32)) + lo  # neither digit nor space
    c = text[at]
    return at[c == _DOT], at[(c == _E) | (c == _LOWER_E)], at[(c == _MINUS) | (c == _PLUS)]


def _mantissas(text, starts, a, dot, end) -> np.ndarray:
    """float32 ``int part + (float32)(fraction digits * 10^-digits)`` of every token, as
    fast_atoreal_move sums them (``a``: first digit after the sign; ``dot``: the dot's offset or
    -1; ``end``: the mantissa's end; the bytes between are digits, assimp_floats checks). One
    window of the text per token from its first digit: the digits (the dot a zero) read as one
    integer, split at the dot by division; mantissas longer than 18 bytes read their two parts
    separately."""
    has_dot = dot >= 0
    int_end = np.where(has_dot, dot, end)
    frac_a = np.where(has_dot, dot + 1, end)
    frac_n = end - frac_a
    if ((int_end == a) & (frac_n == 0)).any():
        raise Unsupported("number without digits")  # Assimp throws ("does not start with digit")
    kept = np.minimum(frac_n, _RELEVANT_DECIMALS)
    length = end - a  # from the first digit (after the sign)
    width = int(length.max())
    if width > _MAX_INT_DIGITS:
        whole = digit_values(text, a, int_end)
        digits = digit_values(text, frac_a, frac_a + kept)
    else:
        if int(a.max()) + width > len(text):
            raise Unsupported("text not padded")
        d = np.lib.stride_tricks.sliding_window_view(text, width)[a] - np.uint8(48)
        # Inside a mantissa the caller's checks leave digits and one dot: the dot is a byte past
        # 9 here, and counts as a zero digit (the split below skips it). Bytes past the mantissa
        # (an exponent, the next tokens) become digits or zeros too: the divisions by
        # 10^(width - ...) below drop them, so they need no mask by position (issue #23: that
        # mask and a masked assignment were a fifth of this function).
        np.multiply(d, d <= 9, out=d)
        raw = _horner(d)
        split = _POW10[width - (int_end - a)]
        whole = raw // split
        digits = (raw - whole * split) // _POW10[width - length]  # raw % split, one division fewer
        if (frac_n > kept).any():
            digits //= _POW10[frac_n - kept]  # digits past the 15th are skipped
    frac = digits.astype(np.float64) * _FAST_ATOF_TABLE[kept]
    f = whole.astype(np.float32)
    return np.where(frac_n > 0, f + frac.astype(np.float32), f)  # float32 + float32, as Assimp adds


def assimp_floats(text: np.ndarray, starts: np.ndarray, ends: np.ndarray) -> np.ndarray:
    """float32 values of the tokens ``text[starts:ends]`` as Assimp's ``fast_atoreal_move<float>``
    reads them (``[sign] digits [. digits] [e|E [sign] digits]``, at least one digit before the
    exponent). Raises Unsupported for anything else (nan, inf, commas, a bare sign, ...), and
    where a dot, exponent or sign of ``text`` lies outside these tokens."""
    n = len(starts)
    sign = text[starts]
    neg = sign == _MINUS
    a = starts + (neg | (sign == _PLUS))
    end_digits = ends.copy()  # where the mantissa ends: the exponent's letter or the token's end
    dot = np.full(n, -1, np.int64)
    exp = np.zeros(n, np.float32)
    dots, es, signs = _specials(text, starts, ends)
    if es.size:
        tok = _one_per_token(es, starts, ends)
        end_digits[tok] = es
        e_sign = text[np.minimum(es + 1, len(text) - 1)]
        e_neg = e_sign == _MINUS
        e_a = es + 1 + (e_neg | (e_sign == _PLUS))
        if (e_a >= ends[tok]).any():
            raise Unsupported("exponent without digits")  # Assimp throws
        e_val = digit_values(text, e_a, ends[tok]).astype(np.float32)
        exp[tok] = np.where(e_neg, -e_val, e_val)
    if signs.size:  # a sign is allowed first in the token or right after the exponent's letter
        first = np.zeros(len(text), bool)
        first[starts] = True
        ok = first[signs] | np.isin(text[np.maximum(signs - 1, 0)], (_E, _LOWER_E))
        if not ok.all():
            raise Unsupported("misplaced sign")
    if dots.size:
        tok = _one_per_token(dots, starts, ends)
        if (dots >= end_digits[tok]).any():
            raise Unsupported("dot in the exponent")
        dot[tok] = dots
    f = _mantissas(text, starts, a, dot, end_digits)
    if es.size:
        # std::pow(float, float) is powf; for the integer exponents of a text file it is the
        # correctly rounded 10^e (checked against Assimp for every exponent, tests/test_obj_fast.py).
        with np.errstate(over="ignore"):
            scale = np.power(10.0, exp.astype(np.float64)).astype(np.float32)
            f = np.where(exp != 0, f * scale, f)
    return np.where(neg, -f, f)
