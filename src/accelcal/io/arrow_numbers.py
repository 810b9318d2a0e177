"""Arrow number columns as float64 numpy arrays, without pyarrow's pandas shim.

pyarrow's ``to_numpy`` imports pandas on its first call (about a quarter of a
second of a command's start-up, for nothing a number column needs). A
column of a fixed-width number type without nulls is a plain buffer: numpy
views it directly (``numpy.frombuffer``), and a cast makes it float64. Columns
with nulls or of other types go through ``to_numpy`` as before.

References
----------
.. [1] Apache Arrow Columnar Format, "Fixed-size primitive layout"
   (a validity bitmap and one values buffer per array chunk).
"""

import numpy as np

DTYPES = {"double": "<f8", "float": "<f4", "halffloat": "<f2",
          **{f"int{b}": f"<i{b // 8}" for b in (8, 16, 32, 64)},
          **{f"uint{b}": f"<u{b // 8}" for b in (8, 16, 32, 64)}}
"""Arrow's fixed-width number types (by name) -> numpy dtypes (Arrow buffers are little-endian)."""


def _chunk(array) -> np.ndarray:
    name = str(array.type)
    if array.null_count == 0 and name in DTYPES:
        dtype = np.dtype(DTYPES[name])
        values = array.buffers()[1]
        if values is None:
            return np.empty(0, dtype=float)
        return np.frombuffer(values, dtype=dtype, count=len(array),
                             offset=array.offset * dtype.itemsize).astype(float)
    return array.to_numpy(zero_copy_only=False).astype(float)


def floats(column) -> np.ndarray:
    """A number column (``pyarrow.Array`` or ``ChunkedArray``) as a new float64 array.

    Nulls (only in the fallback) become NaN, as ``to_numpy`` makes them.
    """
    chunks = getattr(column, "chunks", None)
    if chunks is None:
        return _chunk(column)
    if not chunks:
        return np.empty(0, dtype=float)
    return _chunk(chunks[0]) if len(chunks) == 1 else np.concatenate([_chunk(c) for c in chunks])
