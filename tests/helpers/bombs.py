"""Memory bombs: small files that declare huge arrays (the fault tier's inputs).

Each is made on the fly, small on disk, by compressing zeros in a stream
(never holding the declared array):

- :func:`hdf5_chunk_bomb`: an HDF5 file of one 1-D gzip-chunked dataset whose
  single chunk holds ``n`` doubles (400 M: 3.2 GB decompressed, ~3 MB on disk);
- :func:`mat5_bomb`: a MATLAB v5 file of one compressed ``rows x cols`` double
  variable (2e8 x 1: 1.6 GB, ~1.5 MB on disk; 2 x 3,000,000: 48 MB of values but
  three million columns, ~70 kB on disk).
"""

import struct
import zlib

_BLOCK = 8_000_000
"""Bytes of zeros compressed once and repeated (a full flush resets the compressor, so
every block of zeros compresses to the same bytes)."""

_ADLER = 65521


def deflated_zeros(nbytes: int, *, prefix: bytes = b"") -> bytes:
    """The zlib stream of ``prefix`` then ``nbytes`` zero bytes, in milliseconds.

    One block of zeros is compressed after a full flush and its bytes
    repeated; the Adler-32 checksum of the whole is computed (zeros leave
    its first sum alone and add it to the second once per byte) and put in
    place of the one the compressor saw.
    """
    comp = zlib.compressobj(9)
    head = comp.compress(prefix) + comp.flush(zlib.Z_FULL_FLUSH)
    blocks, rest = divmod(nbytes, _BLOCK)
    block = comp.compress(bytes(_BLOCK)) + comp.flush(zlib.Z_FULL_FLUSH) if blocks else b""
    tail = comp.compress(bytes(rest)) + comp.flush()
    adler = zlib.adler32(prefix)
    low, high = adler & 0xFFFF, adler >> 16
    high = (high + low * nbytes) % _ADLER
    return head + block * blocks + tail[:-4] + struct.pack(">I", (high << 16) | low)


def hdf5_chunk_bomb(path, n: int = 400_000_000) -> None:
    """An HDF5 file whose dataset ``x`` is one gzip chunk of ``n`` float64 zeros."""
    import h5py

    with h5py.File(path, "w") as h5:
        ds = h5.create_dataset("x", shape=(n,), dtype="f8", chunks=(n,), compression="gzip")
        ds.attrs["unit"] = "g"
        ds.id.write_direct_chunk((0,), deflated_zeros(8 * n))


def mat5_bomb(path, rows: int, cols: int, name: bytes = b"data") -> None:
    """A v5 MAT-file of one zlib-compressed ``rows x cols`` double variable of zeros."""
    nbytes = 8 * rows * cols
    padded_name = name + bytes(-len(name) % 8)
    body = (struct.pack("<II", 6, 8) + struct.pack("<II", 6, 0)  # array flags: mxDOUBLE_CLASS
            + struct.pack("<II", 5, 8) + struct.pack("<ii", rows, cols)  # dimensions
            + struct.pack("<II", 1, len(name)) + padded_name  # the name (miINT8)
            + struct.pack("<II", 9, nbytes))  # the real part (miDOUBLE), zeros follow
    matrix_tag = struct.pack("<II", 14, len(body) + nbytes)
    compressed = deflated_zeros(nbytes, prefix=matrix_tag + body)
    header = b"MATLAB 5.0 MAT-file, Platform: GLNXA64, Created on: fault tier".ljust(116)
    header += bytes(8) + struct.pack("<H", 0x0100) + b"IM"
    with open(path, "wb") as fh:
        fh.write(header)
        fh.write(struct.pack("<II", 15, len(compressed)))
        fh.write(compressed)


def check_small(path, limit: int = 20 * 2**20) -> None:
    """The file is small on disk (the point of a bomb)."""
    assert path.stat().st_size < limit, path.stat().st_size
