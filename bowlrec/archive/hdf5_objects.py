"""Creating many small HDF5 datasets and attributes quickly, with h5py's low-level API.

A segment file holds ~40 datasets, each with a ``units`` attribute, and a dozen file
attributes. Through h5py's high-level API each costs ~100-150 us of Python (type guessing, a
new dataset-creation property list, an existence check before an attribute is written),
which is most of the time to write a segment of a few runs (a server's group commit, one
``bowlrec simulate``). The functions here make the same HDF5 calls with the datatypes and the
property list made once: the file is the same, byte for byte
(``tests/test_hdf5_objects.py`` compares files written both ways). Anything they do not cover
(chunked or filtered datasets, other attribute types) goes through the high-level API.
"""

from __future__ import annotations

import functools
from typing import Any

import h5py
import numpy as np
from h5py import h5a, h5d, h5p, h5s, h5t
from numpy.typing import NDArray

__all__ = ["new_dataset", "read_whole", "set_attr"]

#: dataset dtype kinds written through the low-level path: numbers and fixed-length bytes
_PLAIN_KINDS = frozenset("biufS")


@functools.cache
def _plain_dcpl() -> h5p.PropDCID:
    """The creation property list h5py gives a contiguous dataset without filters or a fill
    value: HDF5's defaults with object times not tracked."""
    dcpl = h5p.create(h5p.DATASET_CREATE)
    dcpl.set_obj_track_times(False)
    return dcpl


@functools.cache
def _file_type(dtype: np.dtype[Any]) -> h5t.TypeID:
    """The HDF5 datatype h5py stores ``dtype`` as (its ``logical`` type)."""
    return h5t.py_create(dtype, logical=True)


def new_dataset(
    group: h5py.Group, name: str, data: NDArray[Any], options: dict[str, Any]
) -> h5py.Dataset:
    """``group.create_dataset(name, data=data, **options)``, quicker for the common case: a
    contiguous dataset (no ``options``) of numbers or fixed-length bytes."""
    if options or data.dtype.kind not in _PLAIN_KINDS or data.dtype.hasobject:
        return group.create_dataset(name, data=data, **options)
    data = np.ascontiguousarray(data)
    space = h5s.create_simple(data.shape)
    dataset = h5d.create(group.id, name.encode(), _file_type(data.dtype), space, dcpl=_plain_dcpl())
    dataset.write(h5s.ALL, h5s.ALL, data)
    return h5py.Dataset(dataset)


def read_whole(group: h5py.Group, name: str) -> NDArray[Any]:
    """``group[name][()]``, quicker for a dataset of numbers or fixed-length bytes: read into
    an array of its own dtype and shape, without h5py's Dataset object (its selection and
    reader set-up cost more than reading a small dataset). Anything else (variable-length or
    compound types, an empty dataspace) is read by the high-level API."""
    dataset = h5d.open(group.id, name.encode())
    dtype = dataset.dtype
    shape = dataset.get_space().shape
    if shape is None or dtype.kind not in _PLAIN_KINDS or dtype.hasobject:
        return group[name][()]  # type: ignore[no-any-return]
    out = np.empty(shape, dtype=dtype)
    if out.size:
        dataset.read(h5s.ALL, h5s.ALL, out)
    return out if out.ndim else out[()]  # a scalar dataspace reads as a NumPy scalar


@functools.cache
def _string_attr_types() -> tuple[h5t.TypeID, h5t.TypeID, h5s.SpaceID]:
    """(file type, memory type, space) of a scalar text attribute as h5py writes one: a
    variable-length UTF-8 string."""
    dtype = h5t.string_dtype()
    return h5t.py_create(dtype, logical=True), h5t.py_create(dtype), h5s.create(h5s.SCALAR)


@functools.cache
def _number_attr_types(dtype: np.dtype[Any]) -> tuple[h5t.TypeID, h5t.TypeID, h5s.SpaceID]:
    return h5t.py_create(dtype, logical=True), h5t.py_create(dtype), h5s.create(h5s.SCALAR)


def set_attr(obj: h5py.HLObject, name: str, value: Any) -> None:
    """``obj.attrs[name] = value``, quicker for a ``str``, ``int`` or ``float`` value (stored as
    h5py stores them: variable-length UTF-8, int64, float64 scalars; an attribute of that name
    is replaced); other values go through ``obj.attrs``."""
    kind = type(value)
    if kind is str:
        file_type, memory_type, space = _string_attr_types()
        data = np.array(value, dtype=h5t.string_dtype())
    elif kind is int and -(2**63) <= value < 2**63:
        data = np.array(value, dtype=np.int64)
        file_type, memory_type, space = _number_attr_types(data.dtype)
    elif kind is float:
        data = np.array(value, dtype=np.float64)
        file_type, memory_type, space = _number_attr_types(data.dtype)
    else:
        obj.attrs[name] = value
        return
    key = name.encode()
    if h5a.exists(obj.id, key):
        h5a.delete(obj.id, key)
    attr = h5a.create(obj.id, key, file_type, space)
    try:
        attr.write(data, mtype=memory_type)
    finally:
        attr.close()
