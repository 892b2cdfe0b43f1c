"""Filtered HDF5 chunks built off the GIL, written with ``write_direct_chunk``.

h5py holds the GIL while HDF5 selects, shuffles, compresses, checksums and writes a chunk
(``Dataset.__setitem__``), so a commit thread writing series keeps the solver's threads waiting. Here
a series' HDF5 chunk is filtered by the same code HDF5 runs, outside the GIL, and handed to HDF5 whole
(``Dataset.id.write_direct_chunk``, which only places the bytes and indexes them):

* the Blosc (32001) and Zstandard (32015) filters: the filter function of the very plugin HDF5 loaded
  (``hdf5plugin``'s library; its ``H5PLget_plugin_info`` gives the filter class, the stable HDF5 plugin
  interface), called through ctypes, which releases the GIL for the call; the dataset's own filter
  parameters (its pipeline's ``cd_values``, as HDF5 set them locally) are passed;
* deflate (gzip): :func:`zlib.compress` at the dataset's level (it releases the GIL);
* byte shuffle and Fletcher-32: the plain algorithms of HDF5's ``H5Zshuffle.c`` and
  ``H5checksum.c`` (``H5_checksum_fletcher32``, appended little-endian as ``H5Zfletcher32.c`` does),
  compiled ``nogil``.

HDF5 checks what is written this way as it checks its own chunks: Fletcher-32 on every read (a wrong
checksum is a read error), the filters decode it, and the chunk index names it with filter mask 0 (the
integrity checks of :mod:`explorer.store._integrity` refuse a chunk with a skipped filter). A dataset
whose pipeline holds a filter not listed here (lzf, whose code lives inside h5py) has no
:class:`ChunkFilter`: its rows are written through h5py as before.
"""

from __future__ import annotations

import ctypes
import struct
import zlib

import h5py
import numpy as np
from numba import njit

#: HDF5 filter identifiers handled here.
SHUFFLE, DEFLATE, FLETCHER32, BLOSC, ZSTD = 2, 1, 3, 32001, 32015


class _FilterClass(ctypes.Structure):  # H5Z_class2_t
    _fields_ = [("version", ctypes.c_int), ("id", ctypes.c_int), ("encoder_present", ctypes.c_uint),
                ("decoder_present", ctypes.c_uint), ("name", ctypes.c_char_p), ("can_apply", ctypes.c_void_p),
                ("set_local", ctypes.c_void_p), ("filter", ctypes.c_void_p)]


#: size_t filter(unsigned flags, size_t cd_nelmts, const unsigned cd_values[], size_t nbytes, size_t *buf_size,
#: void **buf): HDF5's H5Z_func_t (a ctypes CFUNCTYPE call releases the GIL)
_FILTER_FUNC = ctypes.CFUNCTYPE(ctypes.c_size_t, ctypes.c_uint, ctypes.c_size_t, ctypes.POINTER(ctypes.c_uint),
                                ctypes.c_size_t, ctypes.POINTER(ctypes.c_size_t), ctypes.POINTER(ctypes.c_void_p))
_PLUGINS: dict = {}
_LIBC: list = []


def _libc():
    if not _LIBC:
        import ctypes.util
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6")
        libc.malloc.restype, libc.malloc.argtypes = ctypes.c_void_p, [ctypes.c_size_t]
        libc.free.restype, libc.free.argtypes = None, [ctypes.c_void_p]
        _LIBC.append(libc)
    return _LIBC[0]


def plugin_filter(code: int):
    """The filter function of HDF5 plugin filter ``code`` from ``hdf5plugin``'s library (None if it is not
    there or not an encoder)."""
    if code in _PLUGINS:
        return _PLUGINS[code]
    fn = None
    try:
        import hdf5plugin
        name = {BLOSC: "blosc", ZSTD: "zstd"}[code]
        lib = ctypes.CDLL(hdf5plugin.get_config().registered_filters[name])
        lib.H5PLget_plugin_info.restype = ctypes.POINTER(_FilterClass)
        info = lib.H5PLget_plugin_info().contents
        if info.id == code and info.encoder_present and info.filter:
            fn = _FILTER_FUNC(info.filter)
    except (ImportError, KeyError, OSError, AttributeError, ValueError):
        fn = None
    _PLUGINS[code] = fn
    return fn


def _run_plugin(fn, flags: int, cd_values: tuple, data: np.ndarray) -> bytes | None:
    """``data`` through a plugin's filter function (the GIL released during the call); None if it
    declined (an optional filter that would not shrink the chunk: HDF5 would store it unfiltered)."""
    libc = _libc()
    n = data.nbytes
    ptr = libc.malloc(n)  # HDF5 hands filters a malloc'd buffer; they free it and return their own
    if not ptr:
        raise MemoryError("no memory for a chunk being compressed")
    ctypes.memmove(ptr, data.ctypes.data, n)
    buf = ctypes.c_void_p(ptr)
    size = ctypes.c_size_t(n)
    cd = (ctypes.c_uint * max(1, len(cd_values)))(*cd_values)
    got = fn(flags & ~0x0100, len(cd_values), cd, n, ctypes.byref(size), ctypes.byref(buf))  # not H5Z_FLAG_REVERSE
    try:
        return ctypes.string_at(buf.value, got) if got else None
    finally:
        libc.free(buf.value)


@njit(nogil=True, cache=True)
def _shuffle_jit(src, size, out):
    """HDF5's byte shuffle (H5Zshuffle.c) of the bytes ``src`` with element size ``size`` into ``out``."""
    n = src.shape[0] // size
    for j in range(size):
        base = j * n
        for i in range(n):
            out[base + i] = src[i * size + j]
    for k in range(n * size, src.shape[0]):  # the bytes past the last whole element stay in place
        out[k] = src[k]


@njit(nogil=True, cache=True)
def _sums_jit(pairs, words):
    """(Σ w_i, Σ (words − i) w_i) of the big-endian 16-bit words stored (native order) in ``pairs``."""
    b1 = np.uint64(0)
    b2 = np.uint64(0)
    for i in range(pairs.shape[0]):
        x = np.uint64(pairs[i])
        w = ((x & np.uint64(0xFF)) << np.uint64(8)) | (x >> np.uint64(8))
        b1 += w
        b2 += np.uint64(words - i) * w
    return b1, b2


@njit(nogil=True, cache=True)
def _fletcher32_jit(pairs, tail):
    """HDF5's ``H5_checksum_fletcher32`` of the bytes whose whole 16-bit words are ``pairs`` (read in native order,
    each word big-endian: its bytes swapped here) and whose odd last byte is ``tail`` (-1: none), in closed form: HDF5 folds its two running sums
    (sum1 = Σ w_i, sum2 = Σ (n − i) w_i) with ``(s & 0xffff) + (s >> 16)`` after every 360 words and twice at
    the end, which keeps each sum's value modulo 65,535 and never makes a positive sum zero: each comes out
    as 0 when the true sum is 0 (every byte zero), else as its residue modulo 65,535 written in 1 .. 65,535.
    The sums are accumulated here in 64 bits over blocks of 2^16 words (reduced modulo 65,535 after each),
    which LLVM vectorises (HDF5's loop does not)."""
    words = pairs.shape[0] + (1 if tail >= 0 else 0)
    s1 = np.uint64(0)
    s2 = np.uint64(0)
    nonzero = False
    m = np.uint64(65535)
    block = 1 << 16
    for lo in range(0, pairs.shape[0], block):
        b1, b2 = _sums_jit(pairs[lo:lo + block], words - lo)
        if b1:
            nonzero = True
        s1 = (s1 + b1 % m) % m
        s2 = (s2 + b2 % m) % m
    if tail > 0:
        w = np.uint64(tail) << np.uint64(8)
        nonzero = True
        s1 = (s1 + w) % m
        s2 = (s2 + w) % m
    if not nonzero:
        return np.uint32(0)
    if s1 == 0:
        s1 = m
    if s2 == 0:
        s2 = m
    return np.uint32((s2 << np.uint64(16)) | s1)


def fletcher32(data) -> int:
    """HDF5's Fletcher-32 checksum of ``data`` (bytes or a contiguous uint8 array)."""
    data = np.frombuffer(data, dtype=np.uint8) if isinstance(data, bytes) else data
    n = data.shape[0]
    pairs = np.frombuffer(data[:n - n % 2], dtype=np.uint16) if n > 1 else np.zeros(0, dtype=np.uint16)
    return int(_fletcher32_jit(pairs, int(data[-1]) if n % 2 else -1))


def shuffle(data: np.ndarray, size: int) -> np.ndarray:
    """HDF5's byte shuffle of ``data`` (uint8, contiguous) for elements of ``size`` bytes."""
    out = np.empty_like(data)
    _shuffle_jit(data, int(size), out)
    return out


class ChunkFilter:
    """The filter pipeline of one chunked dataset, applied here: :meth:`encode` gives the bytes HDF5
    would store for a chunk (None where a filter declined). Build with :meth:`of` (None when a filter of
    the pipeline is not one handled here)."""

    def __init__(self, steps: list, chunk_shape: tuple, dtype: np.dtype, fill):
        self.steps, self.chunk_shape, self.dtype, self.fill = steps, chunk_shape, dtype, fill

    @classmethod
    def of(cls, d: h5py.Dataset) -> "ChunkFilter | None":
        if d.chunks is None or d.dtype.kind not in "fiu":
            return None
        dcpl = d.id.get_create_plist()
        steps = []
        for i in range(dcpl.get_nfilters()):
            code, flags, cd, _ = dcpl.get_filter(i)
            if code == SHUFFLE:
                steps.append(("shuffle", int(cd[0]) if cd else d.dtype.itemsize))
            elif code == DEFLATE:
                steps.append(("deflate", int(cd[0]) if cd else 6))
            elif code == FLETCHER32:
                steps.append(("fletcher32", None))
            elif code in (BLOSC, ZSTD):
                fn = plugin_filter(code)
                if fn is None:
                    return None
                steps.append(("plugin", (fn, int(flags), tuple(int(c) for c in cd))))
            else:
                return None
        fill = np.zeros((1,), dtype=d.dtype)
        dcpl.get_fill_value(fill)
        return cls(steps, tuple(d.chunks), d.dtype, fill[0])

    def encode(self, rows: np.ndarray) -> np.ndarray | None:
        """The stored bytes (uint8) of one HDF5 chunk holding ``rows`` (its first rows; a chunk past the end of
        the dataset is padded with the fill value, as HDF5 stores edge chunks whole)."""
        rows = np.asarray(rows, dtype=self.dtype)
        if rows.shape != self.chunk_shape:
            full = np.full(self.chunk_shape, self.fill, dtype=self.dtype)
            full[:rows.shape[0]] = rows
            rows = full
        data = np.ascontiguousarray(rows).reshape(-1).view(np.uint8)
        for kind, arg in self.steps:
            if kind == "shuffle":
                data = shuffle(data, arg)
            elif kind == "deflate":
                data = np.frombuffer(zlib.compress(data, arg), dtype=np.uint8)
            elif kind == "plugin":
                out = _run_plugin(*arg, data)
                if out is None:
                    return None
                data = np.frombuffer(out, dtype=np.uint8)
            else:  # fletcher32: the checksum of the bytes so far, appended little-endian (one copy)
                total = bytearray(data.nbytes + 4)
                view = memoryview(total)
                view[:-4] = data
                view[-4:] = struct.pack("<I", fletcher32(data))
                data = np.frombuffer(total, dtype=np.uint8)
        return data


def write_rows(d: h5py.Dataset, a: int, b: int, values, chunk_filter: ChunkFilter | None) -> None:
    """d[a:b] = values: every HDF5 chunk that [a, b) covers whole (or up to the end of the dataset)
    filtered by ``chunk_filter`` and written with ``write_direct_chunk``; the rest (a range not aligned
    to the chunks, a dataset without a ``chunk_filter``, a chunk a filter declined) through h5py, one
    HDF5 chunk per call (h5py holds the GIL for each; the GIL is free between calls)."""
    h = d.chunks[0] if d.chunks is not None else b - a
    n = d.shape[0]
    zeros = (0,) * (d.ndim - 1)
    lo = a
    while lo < b:
        hi = min((lo // h + 1) * h, b)
        whole = lo % h == 0 and (hi - lo == h or hi == n)
        data = chunk_filter.encode(values[lo - a:hi - a]) if (chunk_filter is not None and whole) else None
        if data is not None:
            d.id.write_direct_chunk((lo,) + zeros, data, 0)
        else:
            d[lo:hi] = values[lo - a:hi - a]
        lo = hi
