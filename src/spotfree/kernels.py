"""Compiled kernels of classification and streaming: CRC_RLS and kernel CRC_RLS on one window, the ``summary``
representation of a window, and the per-sample step of :class:`~spotfree.classify.ring.ModelRing`.

:func:`ring_step` stores one feature sample in the ring buffer (columns ``p`` and ``p + L_max`` hold the newest
sample, so the last ``L`` samples of any model are contiguous) and, for every model whose window is due (the segment
holds ``n >= L`` samples and ``(n - L) % step == 0``), gathers its window channel by channel, divides each channel by
its scale, divides the whole by its l2 norm for ``unit`` models, appends the affine row, represents it
(:func:`summary_features`, for ``summary`` models) and -- for CRC_RLS -- takes the class residuals and their argmin
(:func:`crc_window`); for kernel CRC_RLS it takes the window's kernel row and the class residuals of the folded
operator (:func:`kernel_window`).

They share one module because numba's disk cache only notices changes in the file of the function it caches, so a
compiled call chain stays inside one file. The module imports nothing of spotfree, so the classifiers and the
representations use its kernels without an import circle.
"""

from __future__ import annotations

import numba
import numpy as np

# Reassociation lets the compiler vectorise the sums; no finite-math flags, so NaN checks stay.
_FAST = {"reassoc", "contract", "nsz", "arcp"}

MODEL = np.dtype([
    ("window", "i8"), ("step", "i8"), ("first", "i8"), ("channels", "i8"), ("d", "i8"), ("y", "i8"),
    ("affine", "f8"), ("unit", "?"), ("compiled", "?"), ("classes", "i8"), ("operator", "i8"), ("reject", "f8"),
    ("kernel", "?"), ("fitted", "i8"), ("m", "i8"), ("features", "i8"), ("head", "i8"),
    ("gamma", "f8"), ("code", "i8"), ("summary", "?"), ("bins", "i8"), ("bands", "i8"), ("tables", "i8"), ("z", "i8"),
    ("p", "i8"),
])
"""One row per model of :func:`ring_step`'s table: window ``L`` and ``step`` (samples); ``first``, ``channels``: its
slice of the flat ``picks`` / ``scales``; ``d`` and ``y``: its window length (``channels L`` plus the affine row when
``affine != 0``) and offset in the flat ``windows``; ``unit``: l2-normalised columns; ``compiled``: CRC_RLS in the
kernel, with ``classes``, its operator's offset in the flat ``operators`` and the ``reject`` threshold (inf: off);
``kernel``: kernel CRC_RLS, with ``classes``, ``gamma``, ``head``, its ``m`` landmarks and ``features`` rows per
class, whose fitted arrays (:func:`kernel_window`'s ``fitted``) start at offset ``fitted`` of the flat ``kernels``.
``summary``: the window is represented by :func:`summary_features` (``bins`` spectral bins in ``bands`` bands) into
the ``p`` values at offset ``z`` of ``windows``, with its tables (:func:`spotfree.representation.summary_tables`: taper
``L``, cosines and sines ``bins L``, band of each bin ``bins``) and then its standardisation (offset ``p``, scale
``p``) at offset ``tables`` of ``kernels``; the classifier then reads those ``p`` values.
``code`` is the result of the last sample (:data:`NOT_DUE`, :data:`IN_PYTHON`, :data:`NOT_FINITE`, or the class index,
``classes`` meaning rejected)."""
NOT_DUE, IN_PYTHON, NOT_FINITE = -1, -2, -3


@numba.njit(cache=True, nogil=True, fastmath=_FAST)
def row_squares(operator, first, last, y, r2, bound):  # pragma: no cover - compiled
    """``r2`` plus ``sum (a_i . y)^2`` over the rows ``a_i`` ``first <= i < last`` of ``operator``, four rows at a time
    (they share each load of ``y``); stops early once the sum exceeds ``bound`` (it can only grow)."""
    d = y.shape[0]
    i = first
    while i + 4 <= last and r2 <= bound:
        a0, a1, a2, a3 = operator[i], operator[i + 1], operator[i + 2], operator[i + 3]
        e0, e1, e2, e3 = 0.0, 0.0, 0.0, 0.0
        for j in range(d):
            v = y[j]
            e0 += a0[j] * v
            e1 += a1[j] * v
            e2 += a2[j] * v
            e3 += a3[j] * v
        r2 += e0 * e0 + e1 * e1 + e2 * e2 + e3 * e3
        i += 4
    while i < last and r2 <= bound:
        a0 = operator[i]
        e0 = 0.0
        for j in range(d):
            e0 += a0[j] * y[j]
        r2 += e0 * e0
        i += 1
    return r2


@numba.njit(cache=True, nogil=True, fastmath=_FAST)
def nearest_block(operator, n_classes, head, y):  # pragma: no cover - compiled
    """The class ``c`` of least ``||E_c y||^2`` and that value, ``E_c`` the ``c``-th of the ``n_classes`` equal blocks
    of rows of ``operator`` ``(C p, len(y))`` (the first on a tie). The first ``head`` rows of every block give lower
    bounds; the class of the least bound is completed first, then only the classes whose bound does not exceed the
    best so far, each abandoned once its sum does (exact: a sum of squares only grows)."""
    rows = operator.shape[0] // n_classes
    bounds = np.empty(n_classes)
    for c in range(n_classes):
        bounds[c] = row_squares(operator, c * rows, c * rows + head, y, 0.0, np.inf)
    best = 0
    for c in range(1, n_classes):
        if bounds[c] < bounds[best]:
            best = c
    best_r2 = row_squares(operator, best * rows + head, (best + 1) * rows, y, bounds[best], np.inf)
    for c in range(n_classes):
        if c == best or bounds[c] > best_r2 or (bounds[c] == best_r2 and c > best):
            continue
        r2 = row_squares(operator, c * rows + head, (c + 1) * rows, y, bounds[c], best_r2)
        if r2 < best_r2 or (r2 == best_r2 and c < best):
            best, best_r2 = c, r2
    return best, best_r2


@numba.njit(cache=True, nogil=True, fastmath=_FAST)
def crc_window(operator, n_classes, y):  # pragma: no cover - compiled
    """Best class of ``y`` under the stacked operator ``(C d, d)`` and ``min_i r_i / ||y||``; ``-1`` if not finite."""
    norm2 = 0.0
    for j in range(y.shape[0]):
        norm2 += y[j] * y[j]
    if not np.isfinite(norm2):
        return -1, np.nan
    best, best_r2 = nearest_block(operator, n_classes, operator.shape[1], y)
    ratio = np.sqrt(best_r2 / norm2) if norm2 > 0 else np.inf
    return best, ratio


LOG2E = 1.4426950408889634
LN2_HI, LN2_LO = 6.93147180369123816490e-01, 1.90821492927058770002e-10
"""``ln 2`` split so that ``n LN2_HI`` is exact for ``|n| <= 1022`` (fdlibm's ``e_exp.c`` constants)."""
ROUND = 6755399441055744.0
"""``1.5 2^52``: ``x + ROUND - ROUND`` rounds ``x`` to an integer, which then sits in the low bits of ``x + ROUND``."""
EXP_FLOOR = -708.0
"""Exponents are clamped here, above the subnormal results (``exp(-708)`` is about ``3e-308``)."""


@numba.njit(cache=True, nogil=True, fastmath={"contract"})
def exp_nonpositive(x):  # pragma: no cover - compiled
    """``x`` ``(n,)`` replaced by ``exp(min(max(x, EXP_FLOOR), 0))``, in place, in loops the compiler vectorises
    (numba's ``np.exp`` calls the C library once per value; numpy's has vector code only for AVX-512).

    ``x = n ln 2 + r``, ``n = round(x / ln 2)``, ``|r| <= ln 2 / 2`` (Cody-Waite: ``r`` from the two parts of ``ln 2``);
    ``exp(r)`` by its Taylor polynomial of degree 13 in Horner form (truncation below ``2^-53`` relative on that
    interval); ``2^n`` by writing ``n + 1023`` into the exponent bits. Within one ulp of the C library's ``exp``, not
    always bit-equal to it."""
    n = x.shape[0]
    shifted = np.empty(n)
    for i in range(n):
        v = min(max(x[i], EXP_FLOOR), 0.0)
        s = v * LOG2E + ROUND
        k = s - ROUND
        r = (v - k * LN2_HI) - k * LN2_LO
        p = 1.0 / 6227020800.0
        p = p * r + 1.0 / 479001600.0
        p = p * r + 1.0 / 39916800.0
        p = p * r + 1.0 / 3628800.0
        p = p * r + 1.0 / 362880.0
        p = p * r + 1.0 / 40320.0
        p = p * r + 1.0 / 5040.0
        p = p * r + 1.0 / 720.0
        p = p * r + 1.0 / 120.0
        p = p * r + 1.0 / 24.0
        p = p * r + 1.0 / 6.0
        p = p * r + 0.5
        p = p * r + 1.0
        x[i] = p * r + 1.0
        shifted[i] = s
    bits = shifted.view(np.int64)  # the low bits hold n; 2^n has the bits (n + 1023) << 52
    for i in range(n):
        bits[i] = (bits[i] - (0x4338000000000000 - 1023)) << 52
    for i in range(n):
        x[i] *= shifted[i]


@numba.njit(cache=True, nogil=True, fastmath=_FAST)
def kernel_row(landmarks_t, gamma, y, k):  # pragma: no cover - compiled
    """``k_a = exp(-gamma ||y - l_a||^2)`` (:func:`exp_nonpositive`) for the landmarks ``l_a``, the columns of
    ``landmarks_t`` ``(d, m)``, into ``k`` ``(m,)``: sums over ``d`` with the landmarks side by side, so that the
    compiler vectorises across them."""
    d, m = landmarks_t.shape
    for a in range(m):
        k[a] = 0.0
    for j in range(d):
        v = y[j]
        for a in range(m):
            e = v - landmarks_t[j, a]
            k[a] += e * e
    for a in range(m):
        k[a] *= -gamma
    exp_nonpositive(k)


@numba.njit(cache=True, nogil=True, fastmath=_FAST)
def kernel_window(fitted, d, m, f, n_classes, head, gamma, y, outside):  # pragma: no cover - compiled
    """Kernel CRC_RLS of one window ``y`` ``(d,)`` (:mod:`spotfree.classify.kcrc`). ``fitted`` holds, flat and in this
    order, the ``m`` landmarks as columns ``(d, m)``, the folded, rotated operator ``F`` ``(C f, m)`` and the
    normalisation ``N`` ``(f, m)`` (one array, so that a call unboxes few). The kernel row ``k`` (:func:`kernel_row`),
    then the best class under ``F`` (:func:`nearest_block` with ``head`` bounding rows) and, when ``outside``,
    ``min_i r_i = sqrt(||F_best k||^2 + 1 - ||N k||^2)`` (else NaN). ``(-1, NaN)`` if ``y`` is not finite."""
    for j in range(d):
        if not np.isfinite(y[j]):
            return -1, np.nan
    k = np.empty(m)
    kernel_row(fitted[:d * m].reshape(d, m), gamma, y, k)
    end = d * m + n_classes * f * m
    best, best_r2 = nearest_block(fitted[d * m:end].reshape(n_classes * f, m), n_classes, head, k)
    if not outside:
        return best, np.nan
    normalisation = fitted[end:end + f * m].reshape(f, m)
    norm2 = 0.0
    for r in range(f):
        s = 0.0
        for a in range(m):
            s += normalisation[r, a] * k[a]
        norm2 += s * s
    return best, np.sqrt(max(best_r2 + 1.0 - norm2, 0.0))


@numba.njit(cache=True, nogil=True)  # no reassociation: the same bits in batch and in the ring step
def summary_features(x, channels, taper, cos, sin, band, bands, out):  # pragma: no cover - compiled
    """The ``summary`` representation of one window ``x`` ``(channels L,)`` (channels stacked, each in time order)
    into ``out`` ``(channels (6 + bands),)``: per channel its mean, standard deviation, minimum, maximum, the change
    of mean and of standard deviation from the older to the newer ``L // 2`` samples (0 when ``L < 2``) and
    ``log(1 + sum_{k in band b} |X_k|^2 / L)`` per band, ``X_k`` the spectral bin ``k`` of the tapered, mean-removed
    channel from the rows ``cos``, ``sin`` ``(bins, L)`` of the tables, ``band`` ``(bins,)`` each bin's band
    (:func:`spotfree.representation.summary_tables`)."""
    length = x.shape[0] // channels
    half = length // 2
    n_half = max(half, 1)
    width = 6 + bands
    v = np.empty(length)
    for c in range(channels):
        first = c * length
        total, low, high, older, newer = 0.0, np.inf, -np.inf, 0.0, 0.0
        for t in range(length):
            s = x[first + t]
            total += s
            low = min(low, s)
            high = max(high, s)
            if t < half:
                older += s
            if t >= length - half:
                newer += s
        mean = total / length
        older /= n_half
        newer /= n_half
        var, older_var, newer_var = 0.0, 0.0, 0.0
        for t in range(length):
            s = x[first + t]
            e = s - mean
            var += e * e
            v[t] = e * taper[t]
            if t < half:
                older_var += (s - older) * (s - older)
            if t >= length - half:
                newer_var += (s - newer) * (s - newer)
        o = c * width
        out[o], out[o + 1], out[o + 2], out[o + 3] = mean, np.sqrt(var / length), low, high
        out[o + 4] = newer - older
        out[o + 5] = np.sqrt(newer_var / n_half) - np.sqrt(older_var / n_half)
        for b in range(bands):
            out[o + 6 + b] = 0.0
        for k in range(cos.shape[0]):
            re, im = 0.0, 0.0
            for t in range(length):
                re += cos[k, t] * v[t]
                im += sin[k, t] * v[t]
            out[o + 6 + int(band[k])] += (re * re + im * im) / length
        for b in range(bands):
            out[o + 6 + b] = np.log1p(out[o + 6 + b])


@numba.njit(cache=True, nogil=True)
def summary_matrix(windows, channels, taper, cos, sin, band, bands, out):  # pragma: no cover - compiled
    """:func:`summary_features` of every row of ``windows`` ``(m, channels L)`` into the rows of ``out``."""
    for i in range(windows.shape[0]):
        summary_features(windows[i], channels, taper, cos, sin, band, bands, out[i])


@numba.njit(cache=True, nogil=True)
def ring_step(ring, cursor, models, picks, scales, operators, kernels, windows, values):  # pragma: no cover - compiled
    """Store ``values`` ``(F,)`` in ``ring`` ``(F, 2 L_max)`` and set every model's ``code`` (see :data:`MODEL`);
    ``cursor`` is ``[position, samples in the segment]``, advanced here."""
    length = ring.shape[1] // 2
    p = cursor[0]
    for i in range(values.shape[0]):
        ring[i, p] = values[i]
        ring[i, p + length] = values[i]
    n = cursor[1] + 1
    cursor[0] = (p + 1) % length
    cursor[1] = n
    for m in range(models.shape[0]):
        model = models[m]
        window = model.window
        if n < window or (n - window) % model.step != 0:
            model.code = NOT_DUE
            continue
        y = windows[model.y:model.y + model.d]
        k, norm2 = 0, 0.0
        for i in range(model.channels):
            row, scale = ring[picks[model.first + i]], scales[model.first + i]
            for j in range(p + length - window + 1, p + length + 1):
                y[k] = row[j] / scale
                norm2 += y[k] * y[k]
                k += 1
        if model.unit and norm2 > 0:
            norm = np.sqrt(norm2)
            for k in range(model.channels * window):
                y[k] /= norm
        if model.affine != 0:
            y[model.d - 1] = model.affine
        if not model.compiled:
            model.code = IN_PYTHON
            continue
        d = model.d
        if model.summary:
            t, bins, q = model.tables, model.bins, model.p
            taper = kernels[t:t + window]
            cos = kernels[t + window:t + window + bins * window].reshape(bins, window)
            sin = kernels[t + window + bins * window:t + window + 2 * bins * window].reshape(bins, window)
            t += window + 2 * bins * window
            z = windows[model.z:model.z + q]
            summary_features(y, model.channels, taper, cos, sin, kernels[t:t + bins], model.bands, z)
            t += bins
            for i in range(q):
                z[i] = (z[i] - kernels[t + i]) / kernels[t + q + i]
            y, d = z, q
        if model.kernel:
            best, ratio = kernel_window(kernels[model.fitted:], d, model.m, model.features, model.classes, model.head,
                                        model.gamma, y, model.reject < np.inf)
        else:
            operator = operators[model.operator:model.operator + model.classes * d * d].reshape(model.classes * d, d)
            best, ratio = crc_window(operator, model.classes, y)
        if best < 0:
            model.code = NOT_FINITE
        elif ratio > model.reject:
            model.code = model.classes
        else:
            model.code = best


@numba.njit(cache=True, nogil=True)
def ring_block(ring, cursor, models, picks, scales, operators, kernels, windows, values, codes):  # pragma: no cover
    """:func:`ring_step` for every row of ``values`` ``(n, F)``; ``codes`` ``(n, models)`` receives each model's
    ``code`` after each row."""
    for k in range(values.shape[0]):
        ring_step(ring, cursor, models, picks, scales, operators, kernels, windows, values[k])
        for m in range(models.shape[0]):
            codes[k, m] = models[m].code
