"""A grey frame's JPEG round trip computed as libjpeg computes it, without the entropy coding.

A baseline JPEG's loss is all in its transform and quantisation: the
Huffman coding between encoder and decoder is lossless, and it is the slow
part (a noisy 1080p frame is ~1 MB of coded data: libjpeg-turbo's encode
and decode take ~15 ms). For one component (grey) the round trip is, block
of 8×8 pixels by block:

1. the samples less 128, the right and bottom edges padded by repeating the
   last column and row (libjpeg's ``expand_right_edge`` and
   ``expand_bottom_edge``);
2. libjpeg's "accurate integer" forward DCT (``jpeg_fdct_islow``, Loeffler,
   Ligtenberg and Moschytz's factorisation in 13-bit fixed point, two
   passes, the output 8× a true DCT's);
3. quantisation by the luminance table at the quality (Annex K, IJG
   scaling, baseline: 1 … 255), divided by 8·q with rounding half away
   from zero;
4. dequantisation and libjpeg's accurate integer inverse DCT
   (``jpeg_idct_islow``), descaled, range-limited to 0 … 255 through the
   same wrapped table.

All integer arithmetic, so the result is OpenCV's ``imencode`` and
``imdecode`` (libjpeg-turbo, whose SIMD paths give the C code's bits) to
the bit: the tests compare frames of noise and of smooth scenes at
qualities from 1 to 100, whole and in partial blocks. Colour frames, whose
chroma is subsampled and upsampled with libjpeg's own filters, still go
through OpenCV (:func:`rollsim.isp.jpeg.jpeg_round_trip`).

The compiled kernel runs a row of blocks at a time, every step a loop over
the blocks (which LLVM vectorises); the numpy twin does the same
operations on all blocks at once and gives the same bytes.
"""

from __future__ import annotations

import numpy as np

from rollsim.numerics.jit import kernel

# ITU-T T.81 Table K.1, the luminance quantisation table (row by row).
LUMINANCE_TABLE = np.array([
    16, 11, 10, 16, 24, 40, 51, 61, 12, 12, 14, 19, 26, 58, 60, 55, 14, 13, 16, 24, 40, 57, 69, 56,
    14, 17, 22, 29, 51, 87, 80, 62, 18, 22, 37, 56, 68, 109, 103, 77, 24, 35, 55, 64, 81, 104, 113, 92,
    49, 64, 78, 87, 103, 121, 120, 101, 72, 92, 95, 98, 112, 100, 103, 99], dtype=np.int64).reshape(8, 8)

# libjpeg's jfdctint.c / jidctint.c constants: FIX(c) = round(c · 2^13).
CONST_BITS = 13
PASS1_BITS = 2
FIX_0_298631336 = 2446
FIX_0_390180644 = 3196
FIX_0_541196100 = 4433
FIX_0_765366865 = 6270
FIX_0_899976223 = 7373
FIX_1_175875602 = 9633
FIX_1_501321110 = 12299
FIX_1_847759065 = 15137
FIX_1_961570560 = 16069
FIX_2_053119869 = 16819
FIX_2_562915447 = 20995
FIX_3_072711026 = 25172


def quantisation_table(quality: int) -> np.ndarray:
    """The luminance table at ``quality`` (1 … 100) as libjpeg's ``jpeg_set_quality`` scales it, baseline."""
    if not 1 <= int(quality) <= 100:
        raise ValueError(f"quality must be in 1 … 100, got {quality!r}")
    quality = int(quality)
    scale = 5000 // quality if quality < 50 else 200 - 2 * quality
    return np.clip((LUMINANCE_TABLE * scale + 50) // 100, 1, 255)


def _range_limit_table() -> np.ndarray:
    """libjpeg's post-IDCT range table, indexed by the output & 1023: x + 128 clamped to 0 … 255, wrapped."""
    table = np.zeros(1024, dtype=np.uint8)
    table[0:128] = np.arange(128, 256)
    table[128:512] = 255
    table[896:1024] = np.arange(0, 128)
    return table


RANGE_LIMIT = _range_limit_table()


def round_trip_grey(image: np.ndarray, quality: int) -> np.ndarray:
    """A grey uint8 frame encoded as a baseline JPEG at ``quality`` and decoded, as libjpeg does it.

    Parameters
    ----------
    image : ndarray of uint8, shape (H, W)
    quality : int
        1 … 100.

    Returns
    -------
    ndarray of uint8, shape (H, W)
    """
    table = quantisation_table(quality)
    if image.ndim != 2 or image.dtype != np.uint8:
        raise ValueError(f"the grey JPEG round trip takes an (H, W) uint8 frame, got {image.dtype} {image.shape}")
    if image.size == 0:
        return image.copy()
    compiled = _round_trip_kernel.compiled
    if compiled is None:
        return _round_trip_numpy(image, table)
    out = np.empty_like(image)
    compiled(np.ascontiguousarray(image), np.ascontiguousarray(table.ravel()), RANGE_LIMIT, out)
    return out


# ------------------------------------------------------------------ numpy


def _descale(x, n):
    return (x + (1 << (n - 1))) >> n


def _fdct_1d(d, first_pass):
    """jpeg_fdct_islow on one axis: ``d`` the eight inputs (arrays), returns the eight outputs."""
    tmp0, tmp7 = d[0] + d[7], d[0] - d[7]
    tmp1, tmp6 = d[1] + d[6], d[1] - d[6]
    tmp2, tmp5 = d[2] + d[5], d[2] - d[5]
    tmp3, tmp4 = d[3] + d[4], d[3] - d[4]
    tmp10, tmp13, tmp11, tmp12 = tmp0 + tmp3, tmp0 - tmp3, tmp1 + tmp2, tmp1 - tmp2
    shift = CONST_BITS - PASS1_BITS if first_pass else CONST_BITS + PASS1_BITS
    out = [None] * 8
    if first_pass:
        out[0], out[4] = (tmp10 + tmp11) << PASS1_BITS, (tmp10 - tmp11) << PASS1_BITS
    else:
        out[0], out[4] = _descale(tmp10 + tmp11, PASS1_BITS), _descale(tmp10 - tmp11, PASS1_BITS)
    z1 = (tmp12 + tmp13) * FIX_0_541196100
    out[2] = _descale(z1 + tmp13 * FIX_0_765366865, shift)
    out[6] = _descale(z1 - tmp12 * FIX_1_847759065, shift)
    odd = _odd_part(tmp4, tmp5, tmp6, tmp7)
    out[7], out[5], out[3], out[1] = (_descale(v, shift) for v in odd)
    return out


def _odd_part(a, b, c, d):
    """The rotations of the odd half (LL&M figure 8), the same in both transforms: its four outputs."""
    z1, z2, z3, z4 = a + d, b + c, a + c, b + d
    z5 = (z3 + z4) * FIX_1_175875602
    z1, z2 = z1 * -FIX_0_899976223, z2 * -FIX_2_562915447
    z3, z4 = z3 * -FIX_1_961570560 + z5, z4 * -FIX_0_390180644 + z5
    return (a * FIX_0_298631336 + z1 + z3, b * FIX_2_053119869 + z2 + z4, c * FIX_3_072711026 + z2 + z3,
            d * FIX_1_501321110 + z1 + z4)


def _idct_1d(d, shift):
    """jpeg_idct_islow on one axis (its all-zero-AC shortcuts give the same numbers)."""
    z1 = (d[2] + d[6]) * FIX_0_541196100
    tmp2, tmp3 = z1 - d[6] * FIX_1_847759065, z1 + d[2] * FIX_0_765366865
    tmp0, tmp1 = (d[0] + d[4]) << CONST_BITS, (d[0] - d[4]) << CONST_BITS
    tmp10, tmp13, tmp11, tmp12 = tmp0 + tmp3, tmp0 - tmp3, tmp1 + tmp2, tmp1 - tmp2
    tmp0, tmp1, tmp2, tmp3 = _odd_part(d[7], d[5], d[3], d[1])
    return [_descale(tmp10 + tmp3, shift), _descale(tmp11 + tmp2, shift), _descale(tmp12 + tmp1, shift),
            _descale(tmp13 + tmp0, shift), _descale(tmp13 - tmp0, shift), _descale(tmp12 - tmp1, shift),
            _descale(tmp11 - tmp2, shift), _descale(tmp10 - tmp3, shift)]


def _round_trip_numpy(image: np.ndarray, table: np.ndarray) -> np.ndarray:
    height, width = image.shape
    rows, cols = -(-height // 8) * 8, -(-width // 8) * 8
    padded = np.pad(image, ((0, rows - height), (0, cols - width)), mode="edge").astype(np.int64) - 128
    blocks = padded.reshape(rows // 8, 8, cols // 8, 8).transpose(0, 2, 1, 3)  # (block row, block, row, column)
    work = np.stack(_fdct_1d([blocks[..., k] for k in range(8)], True), axis=-1)
    coefficients = np.stack(_fdct_1d([work[..., k, :] for k in range(8)], False), axis=-2)
    divisor = table << 3
    quantised = (np.abs(coefficients) + (divisor >> 1)) // divisor
    dequantised = np.where(coefficients < 0, -quantised, quantised) * table
    work = np.stack(_idct_1d([dequantised[..., k, :] for k in range(8)], CONST_BITS - PASS1_BITS), axis=-2)
    values = np.stack(_idct_1d([work[..., k] for k in range(8)], CONST_BITS + PASS1_BITS + 3), axis=-1)
    pixels = RANGE_LIMIT[values & 1023]
    return np.ascontiguousarray(pixels.transpose(0, 2, 1, 3).reshape(rows, cols)[:height, :width])


# --------------------------------------------------------------- compiled


@kernel
def _round_trip_kernel(image, table, range_limit, out):
    # A row of blocks at a time, in (line, position, block) order, so that
    # every butterfly is a loop over the blocks (which LLVM vectorises). A
    # pass transforms along the second axis and a transpose turns the
    # result for the next pass; the first forward pass's x·4 for the even
    # outputs is written as the second's descaling, (x·m + h) >> s, so that
    # both passes run one body. One flat kernel: numba passes arrays to a
    # called function with reference counting.
    height, width = image.shape
    n_blocks = (width + 7) // 8
    x = np.empty((8, 8, n_blocks), dtype=np.int64)
    y = np.empty((8, 8, n_blocks), dtype=np.int64)
    for block_row in range(0, height, 8):
        n_whole = width // 8  # blocks with no column past the right edge
        for r in range(8):
            source = image[min(block_row + r, height - 1)]  # the bottom edge repeated
            for c in range(8):
                for b in range(n_whole):
                    x[r, c, b] = np.int64(source[b * 8 + c]) - 128
                for b in range(n_whole, n_blocks):  # the right edge repeated
                    x[r, c, b] = np.int64(source[min(b * 8 + c, width - 1)]) - 128
        # Forward DCT: along the rows, then (transposed) along the columns.
        for second in range(2):
            even_scale = 1 if second else 1 << PASS1_BITS
            even_shift = PASS1_BITS if second else 0
            even_half = (1 << (PASS1_BITS - 1)) if second else 0
            shift = CONST_BITS + PASS1_BITS if second else CONST_BITS - PASS1_BITS
            half = np.int64(1) << (shift - 1)
            for line in range(8):
                for b in range(n_blocks):
                    d0, d1, d2, d3 = x[line, 0, b], x[line, 1, b], x[line, 2, b], x[line, 3, b]
                    d4, d5, d6, d7 = x[line, 4, b], x[line, 5, b], x[line, 6, b], x[line, 7, b]
                    tmp0, tmp7, tmp1, tmp6 = d0 + d7, d0 - d7, d1 + d6, d1 - d6
                    tmp2, tmp5, tmp3, tmp4 = d2 + d5, d2 - d5, d3 + d4, d3 - d4
                    tmp10, tmp13, tmp11, tmp12 = tmp0 + tmp3, tmp0 - tmp3, tmp1 + tmp2, tmp1 - tmp2
                    y[line, 0, b] = ((tmp10 + tmp11) * even_scale + even_half) >> even_shift
                    y[line, 4, b] = ((tmp10 - tmp11) * even_scale + even_half) >> even_shift
                    z1 = (tmp12 + tmp13) * FIX_0_541196100
                    y[line, 2, b] = (z1 + tmp13 * FIX_0_765366865 + half) >> shift
                    y[line, 6, b] = (z1 - tmp12 * FIX_1_847759065 + half) >> shift
                    z1, z2, z3, z4 = tmp4 + tmp7, tmp5 + tmp6, tmp4 + tmp6, tmp5 + tmp7
                    z5 = (z3 + z4) * FIX_1_175875602
                    z1, z2 = z1 * -FIX_0_899976223, z2 * -FIX_2_562915447
                    z3, z4 = z3 * -FIX_1_961570560 + z5, z4 * -FIX_0_390180644 + z5
                    y[line, 7, b] = (tmp4 * FIX_0_298631336 + z1 + z3 + half) >> shift
                    y[line, 5, b] = (tmp5 * FIX_2_053119869 + z2 + z4 + half) >> shift
                    y[line, 3, b] = (tmp6 * FIX_3_072711026 + z2 + z3 + half) >> shift
                    y[line, 1, b] = (tmp7 * FIX_1_501321110 + z1 + z4 + half) >> shift
            for line in range(8):
                for k in range(8):
                    for b in range(n_blocks):
                        x[k, line, b] = y[line, k, b]
        # Quantisation and dequantisation (x: coefficient row, column), rounding half away from zero:
        # (|v| + d/2) // d. In float64 the quotient is exact enough to floor: |v| < 2^14 and d <= 2040,
        # so a quotient that is not an integer lies at least 1/d from one, far beyond its rounding.
        for r in range(8):
            for c in range(8):
                q = table[r * 8 + c]
                divisor = q << 3
                for b in range(n_blocks):
                    v = x[r, c, b]
                    level = np.int64(np.float64(abs(v) + (divisor >> 1)) / np.float64(divisor))
                    x[r, c, b] = (-level if v < 0 else level) * q
        # Inverse DCT: along the columns, then along the rows (each pass transposed first).
        for second in range(2):
            shift = CONST_BITS + PASS1_BITS + 3 if second else CONST_BITS - PASS1_BITS
            half = np.int64(1) << (shift - 1)
            for line in range(8):
                for k in range(8):
                    for b in range(n_blocks):
                        y[k, line, b] = x[line, k, b]
            for line in range(8):
                for b in range(n_blocks):
                    d0, d1, d2, d3 = y[line, 0, b], y[line, 1, b], y[line, 2, b], y[line, 3, b]
                    d4, d5, d6, d7 = y[line, 4, b], y[line, 5, b], y[line, 6, b], y[line, 7, b]
                    z1 = (d2 + d6) * FIX_0_541196100
                    tmp2, tmp3 = z1 - d6 * FIX_1_847759065, z1 + d2 * FIX_0_765366865
                    tmp0, tmp1 = (d0 + d4) << CONST_BITS, (d0 - d4) << CONST_BITS
                    tmp10, tmp13, tmp11, tmp12 = tmp0 + tmp3, tmp0 - tmp3, tmp1 + tmp2, tmp1 - tmp2
                    z1, z2, z3, z4 = d7 + d1, d5 + d3, d7 + d3, d5 + d1
                    z5 = (z3 + z4) * FIX_1_175875602
                    z1, z2 = z1 * -FIX_0_899976223, z2 * -FIX_2_562915447
                    z3, z4 = z3 * -FIX_1_961570560 + z5, z4 * -FIX_0_390180644 + z5
                    tmp0 = d7 * FIX_0_298631336 + z1 + z3
                    tmp1 = d5 * FIX_2_053119869 + z2 + z4
                    tmp2 = d3 * FIX_3_072711026 + z2 + z3
                    tmp3 = d1 * FIX_1_501321110 + z1 + z4
                    x[line, 0, b], x[line, 7, b] = (tmp10 + tmp3 + half) >> shift, (tmp10 - tmp3 + half) >> shift
                    x[line, 1, b], x[line, 6, b] = (tmp11 + tmp2 + half) >> shift, (tmp11 - tmp2 + half) >> shift
                    x[line, 2, b], x[line, 5, b] = (tmp12 + tmp1 + half) >> shift, (tmp12 - tmp1 + half) >> shift
                    x[line, 3, b], x[line, 4, b] = (tmp13 + tmp0 + half) >> shift, (tmp13 - tmp0 + half) >> shift
        for r in range(min(8, height - block_row)):
            for b in range(n_blocks):
                for c in range(min(8, width - b * 8)):
                    out[block_row + r, b * 8 + c] = range_limit[x[r, c, b] & 1023]
    return 0
