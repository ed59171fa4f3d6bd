"""An HDR panorama held compactly and exactly, decoded by row blocks as it is read.

A 16384 x 8192 float32 panorama is 1.6 GB: more than the whole estimate may use (docs/reliability.md).
Its values usually fit a narrower code exactly: a Radiance file's are RGBE (a shared exponent, 4 bytes a
pixel, 0.54 GB), a half-float EXR's are half floats (6 bytes, 0.8 GB). ``Packer`` builds a ``PackedImage``
from float32 row blocks, checking that every block decodes to the same bits; at the first block that does not,
an image its file can give again by rows (an EXR of real float32 data) stays there (``RowFile``: read again at
each pass, about twice the time), any other becomes a plain float32 array. Every pass over a ``PackedImage``
(SH projection, area averages, the written hdr.exr) decodes one row block at a time, so the estimate gets
exactly the numbers the float32 array would have given it.
"""
from __future__ import annotations

import mmap
import threading
from collections import deque
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from . import threads

KINDS = ("rgbe", "half", "file")  # "file": RowFile, the rows read from the file again at each pass


def rgbe_decode(rgbe: np.ndarray) -> np.ndarray:
    """(..., 4) uint8 RGBE -> (..., 3) float32: (mantissa + 0.5) 2^(exponent - 136), 0 where the exponent
    byte is 0 (Radiance's definition of a stored value: the middle of its step). Exponent bytes below 10
    (values under 2^-126, which ``rgbe_encode`` never makes) decode to 0."""
    e = rgbe[..., 3].astype(np.int32)
    e -= 9  # 2^(e - 136) is the float32 of biased exponent e - 9
    np.maximum(e, 0, out=e)
    e <<= 23
    out = rgbe[..., :3].astype(np.float32)
    out += np.float32(0.5)
    out *= e.view(np.float32)[..., None]
    return out


CHUNK_PIXELS = 1 << 16  # pixels the encoders work on at a time: their temporaries stay a few MB per thread


def rgbe_encode(block: np.ndarray) -> np.ndarray | None:
    """(..., 3) float32 -> (..., 4) uint8 RGBE that ``rgbe_decode`` turns back into the same bits, or None
    when the values are not RGBE values (negative, non-finite, off a step's middle, out of range): the
    pixel's largest channel (m + 0.5) 2^(e - 136), m in 128..255, is a float32 of biased exponent e - 2."""
    flat = np.ascontiguousarray(block, np.float32).reshape(-1, 3)
    out = np.empty((len(flat), 4), np.uint8)
    for k in range(0, len(flat), CHUNK_PIXELS):
        values, code = flat[k:k + CHUNK_PIXELS], out[k:k + CHUNK_PIXELS]
        peak = np.maximum(np.maximum(values[:, 0], values[:, 1]), values[:, 2])
        biased = peak.view(np.int32) >> 23
        inverse = ((261 - biased) << 23).view(np.float32)  # 2^(136 - e)
        with np.errstate(invalid="ignore", over="ignore"):
            mantissa = values * inverse[:, None]
            mantissa -= np.float32(0.5)
            np.clip(mantissa, 0, 255, out=mantissa)
            code[:, :3] = mantissa
        code[:, 3] = np.where(peak > 0, np.clip(biased + 2, 0, 255), 0)
        if not np.array_equal(rgbe_decode(code), values):
            return None
    return out.reshape(block.shape[:-1] + (4,))


def half_encode(block: np.ndarray) -> np.ndarray | None:
    """(..., 3) float32 -> float16 holding the same values (NaN and infinities included), or None."""
    flat = np.ascontiguousarray(block, np.float32).reshape(-1, 3)
    out = np.empty(flat.shape, np.float16)
    for k in range(0, len(flat), CHUNK_PIXELS):
        with np.errstate(over="ignore"):
            out[k:k + CHUNK_PIXELS] = flat[k:k + CHUNK_PIXELS]
        if not np.array_equal(out[k:k + CHUNK_PIXELS].astype(np.float32), flat[k:k + CHUNK_PIXELS], equal_nan=True):
            return None
    return out.reshape(block.shape)


def repair(block: np.ndarray, posinf: float | None, clamp: bool) -> None:
    """The reader's repairs of a float block, in place: NaN and -Inf to 0 and +Inf to ``posinf`` (None: none to
    make), then negatives to 0 with ``clamp``."""
    if posinf is not None:
        np.nan_to_num(block, copy=False, nan=0.0, posinf=posinf, neginf=0.0)
    if clamp:
        np.maximum(block, 0.0, out=block)


class RowFile:
    """The float32 rows of an image file, read again at each access: what an image too large to hold whose values
    no code holds exactly becomes (a 16K float32 EXR). ``read_rows(r0, r1)`` gives the file's rows as they are;
    ``repair`` ((the value +Inf becomes or None, whether negatives are clamped to 0)) and ``top`` (the largest
    value after it) are set by the reader's validation pass, so every later pass sees what an array repaired in
    place would hold. Reads are serialised (one open file)."""

    nbytes = 0

    def __init__(self, read_rows, height: int, width: int):
        self._read, self.shape = read_rows, (height, width, 3)
        self.repair: tuple | None = None
        self.top: float | None = None
        self._lock = threading.Lock()

    def _rows(self, r0: int, r1: int) -> np.ndarray:
        with self._lock:
            block = np.array(self._read(r0, r1), dtype=np.float32)
        if self.repair is not None:
            repair(block, *self.repair)
        return block

    def __getitem__(self, key):
        if isinstance(key, slice):
            r0, r1, _ = key.indices(self.shape[0])
            return self._rows(r0, max(r0, r1))
        rows, cols = key  # gathered 256 rows at a time: only the rows holding them are read
        out = np.empty((len(rows), 3), np.float32)
        for c0 in np.unique(np.asarray(rows) // 256) * 256:
            mine = (rows >= c0) & (rows < c0 + 256)
            out[mine] = self._rows(int(c0), min(self.shape[0], int(c0) + 256))[rows[mine] - c0, cols[mine]]
        return out


class PackedImage:
    """An (H, W, 3) linear image stored as RGBE bytes or half floats (or in its file: ``RowFile``), read as
    ``dtype`` (float32, or float64 for an exact float64 pass) row blocks: ``img[r0:r1]`` (also ``img[..., r0:r1, :, :]``) and
    ``img[rows, cols]`` (integer index arrays) return plain arrays; ``np.asarray(img)`` decodes it whole
    (a full-size array: the passes that matter read by row blocks)."""

    ndim = 3

    def __init__(self, store: np.ndarray, kind: str, dtype=np.float32):
        if kind not in KINDS:
            raise ValueError(f"kind must be one of {KINDS}, got {kind!r}")
        self.store, self.kind, self.dtype = store, kind, np.dtype(dtype)
        self._peak: float | None = None  # the input warnings and hdr.exr's writer both ask

    @property
    def shape(self) -> tuple[int, int, int]:
        return self.store.shape[:2] + (3,)

    @property
    def nbytes(self) -> int:
        return self.store.nbytes

    def __len__(self) -> int:
        return self.store.shape[0]

    def _decode(self, stored: np.ndarray) -> np.ndarray:
        out = rgbe_decode(stored) if self.kind == "rgbe" else stored.astype(np.float32, copy=False)
        return out if self.dtype == np.float32 else out.astype(self.dtype)

    def astype(self, dtype, copy: bool = True) -> PackedImage:
        """The same pixels read as ``dtype`` (a view: nothing is decoded until a block is read)."""
        return PackedImage(self.store, self.kind, dtype)

    def __getitem__(self, key):
        if isinstance(key, tuple) and key and key[0] is Ellipsis:
            key = key[1:]
        if isinstance(key, tuple) and len(key) == 2 and all(isinstance(k, np.ndarray) for k in key):
            return self._decode(self.store[key])
        rest = key[1:] if isinstance(key, tuple) else ()
        first = key[0] if isinstance(key, tuple) else key
        if not isinstance(first, slice) or first.step not in (None, 1) or any(k != slice(None) for k in rest):
            raise TypeError(f"a PackedImage is read by row slices or (rows, cols) index arrays, not {key!r}")
        return self._decode(self.store[first])

    def peak(self) -> float:
        """The largest value (NaN aside), found once from the codes (the reader has validated them): RGBE decodes
        only the pixels of the largest exponent byte; a file's comes from its validation pass."""
        if self._peak is None:
            self._peak = self._find_peak()
        return self._peak

    def _find_peak(self) -> float:
        if self.kind == "file" and self.store.top is not None:
            return self.store.top
        if self.kind in ("half", "file"):
            return max((float(np.nanmax(self.store[r:r + 256], initial=0.0)) for r in range(0, len(self), 256)),
                       default=0.0)
        top = max((int(self.store[r:r + 256, :, 3].max()) for r in range(0, len(self), 256)), default=0)
        if top == 0:
            return 0.0
        return max(float(rgbe_decode(self.store[r:r + 256][self.store[r:r + 256, :, 3] == top]).max(initial=0.0))
                   for r in range(0, len(self), 256))

    def __array__(self, dtype=None, copy=None):
        out = np.empty(self.shape, self.dtype)
        for r0 in range(0, len(self), 256):
            out[r0:r0 + 256] = self[r0:r0 + 256]
        return out if dtype is None else out.astype(dtype, copy=False)

    def __repr__(self) -> str:
        return f"PackedImage({self.shape[0]} x {self.shape[1]}, {self.kind}, read as {self.dtype})"


class Packer:
    """Builds an (height, width, 3) image from float32 row blocks given in order (``put``): a ``PackedImage``
    of ``kind`` while every block encodes exactly, else (from the first block that does not) a float32
    array, or, given ``reread`` (rows r0, r1 of the file again: a format read by any rows), a ``RowFile``
    (``done`` then says the rest need not be given), which ``result`` then returns. Blocks are encoded on
    ``threads.count()`` threads while the caller reads the next ones (at most that many blocks wait); ``close``
    (or leaving a ``with``) ends them."""

    def __init__(self, height: int, width: int, kind: str, reread=None):
        if kind not in ("rgbe", "half"):
            raise ValueError(f"kind must be rgbe or half, got {kind!r}")
        self.kind, self.filled, self.height, self.reread, self.file = kind, 0, height, reread, None
        shape = (height, width, 4 if kind == "rgbe" else 3)
        dtype = np.dtype(np.uint8 if kind == "rgbe" else np.float16)
        # in pages of its own, which a fall back to float32 gives back as it converts them (_release)
        self._pages = mmap.mmap(-1, max(1, int(np.prod(shape)) * dtype.itemsize))
        self.store = np.frombuffer(self._pages, dtype, int(np.prod(shape))).reshape(shape)
        self.plain = None
        self.workers = threads.count()
        self.pool = ThreadPoolExecutor(self.workers, thread_name_prefix="panolight-pack") if self.workers > 1 else None
        self.pending = deque()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def close(self) -> None:
        for _, _, future in self.pending:
            future.cancel()
        self.pending.clear()
        if self.pool is not None:
            self.pool.shutdown(wait=True)
            self.pool = None

    @property
    def done(self) -> bool:
        """Whether no more blocks are needed: the image is read from its file again (``RowFile``)."""
        return self.file is not None

    def put(self, r0: int, block: np.ndarray) -> None:
        if r0 != self.filled:
            raise ValueError(f"blocks must come in order: expected row {self.filled}, got {r0}")
        self.filled += len(block)
        if self.file is not None:
            return
        if self.plain is not None:
            self.plain[r0:r0 + len(block)] = block
            return
        encode = rgbe_encode if self.kind == "rgbe" else half_encode
        if self.pool is None:
            self._keep(r0, block, encode(block))
            return
        self.pending.append((r0, block, self.pool.submit(encode, block)))
        while len(self.pending) > self.workers:
            self._keep(*self._next())

    def _next(self):
        r0, block, future = self.pending.popleft()
        return r0, block, future.result()

    def _keep(self, r0: int, block: np.ndarray, code) -> None:
        """Store one block's code, or (None: it does not fit) turn every row so far into float32, or leave the
        image in its file (``reread``)."""
        if self.file is not None:
            return
        if code is None and self.reread is not None:
            self.file = RowFile(self.reread, self.height, self.store.shape[1])
            self._release(self.height)
            self.store = None
            return
        if self.plain is not None:
            self.plain[r0:r0 + len(block)] = block
        elif code is not None:
            self.store[r0:r0 + len(block)] = code
        else:
            self.plain = np.empty(self.store.shape[:2] + (3,), np.float32)
            done = PackedImage(self.store, self.kind)
            for k in range(0, r0, 256):
                self.plain[k:min(r0, k + 256)] = done[k:min(r0, k + 256)]
                self._release(min(r0, k + 256))  # the codes and the float32 rows are never both held whole
            self.store = done = None
            self.plain[r0:r0 + len(block)] = block

    def _release(self, rows: int) -> None:
        """Give the memory pages of the codes of the first ``rows`` rows back to the system (Linux, macOS)."""
        if not hasattr(mmap, "MADV_DONTNEED"):
            return
        end = rows * self.store.strides[0] // mmap.PAGESIZE * mmap.PAGESIZE
        if end > 0:
            self._pages.madvise(mmap.MADV_DONTNEED, 0, end)

    def result(self):
        """The image: a PackedImage, or a float32 array (some block did not fit). Ends the threads."""
        while self.pending:
            self._keep(*self._next())
        self.close()
        if self.file is not None:
            return PackedImage(self.file, "file")
        if self.filled != self.height:
            raise ValueError(f"{self.filled} of {self.height} rows were given")
        return self.plain if self.plain is not None else PackedImage(self.store, self.kind)
