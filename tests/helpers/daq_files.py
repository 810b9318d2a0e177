"""Small DAQ files written by the real libraries (npTDMS, h5py, scipy.io), for the import tests.

Each writer puts the same three channels ``x, y, z`` (and a temperature)
where its format's users put them: TDMS group ``Accel`` with the NI
waveform properties, an HDF5 2-D dataset with a ``unit`` attribute and a time
dataset, a MATLAB v5 matrix ``data`` (samples down the rows) with ``Fs``, and
a v7.3 file in MATLAB's layout (the 512-byte header, column-major storage,
``MATLAB_class`` attributes).
"""

import numpy as np

RATE = 1000.0
START = np.datetime64("2026-11-23T08:00:00")
MAT73_HEADER = (b"MATLAB 7.3 MAT-file, Platform: GLNXA64, Created on: Mon Nov 23 08:00:00 2026 "
                b"HDF5 schema 1.00 .").ljust(116, b" ") + b"\x00" * 8 + b"\x00\x02IM"


def signals(n=1200, seed=0):
    """(n, 3) accelerations in g and a temperature in degC."""
    rng = np.random.default_rng(seed)
    acc = rng.normal([0.0, 0.0, 1.0], 1e-3, (n, 3))
    temp = 23.0 + 0.01 * np.arange(n) / n
    return acc, temp


def write_tdms(path, acc, temp, *, unit="g", segments=3, lengths=None):
    """A TDMS file of ``segments`` segments, channels Accel/X,Y,Z and Temp/Case."""
    from nptdms import ChannelObject, GroupObject, RootObject, TdmsWriter

    n = acc.shape[0]
    cuts = np.linspace(0, n, segments + 1).astype(int)
    with TdmsWriter(path) as writer:
        for s in range(segments):
            part = slice(cuts[s], cuts[s + 1])
            first = s == 0
            objs = [RootObject({"title": "bench 3", "operator": "A. Lab"}),
                    GroupObject("Accel", {"sensor": "triad SN-7"})] if first else []
            for k, name in enumerate("XYZ"):
                props = ({"wf_increment": 1 / RATE, "wf_start_time": START, "unit_string": unit,
                          "NI_ChannelName": f"Dev1/ai{k}"} if first else {})
                data = acc[part, k]
                if lengths and name in lengths and s == segments - 1:
                    data = data[:len(data) - lengths[name]]
                objs.append(ChannelObject("Accel", name, data, properties=props))
            objs.append(ChannelObject("Temp", "Case", temp[part],
                                      properties={"unit_string": "Deg C"} if first else {}))
            writer.write_segment(objs)


def write_hdf5(path, acc, temp, *, t=None, unit="g"):
    """HDF5: ``daq/acc`` (n, 3) with a unit attribute, ``daq/t`` (s), ``daq/temp`` (K)."""
    import h5py

    n = acc.shape[0]
    with h5py.File(path, "w") as h5:
        h5.attrs["lab"] = "vibration lab"
        ds = h5.create_dataset("daq/acc", data=acc, chunks=(256, 3))
        ds.attrs["unit"] = unit
        ds.attrs["sensor"] = "triad SN-7"
        h5.create_dataset("daq/t", data=np.arange(n) / RATE if t is None else t)
        h5.create_dataset("daq/temp", data=temp + 273.15).attrs["unit"] = "K"


def write_mat5(path, acc, temp):
    """MATLAB v5: ``data`` (n x 3), ``temp`` (n x 1), ``Fs``, ``sensor``."""
    import scipy.io

    scipy.io.savemat(path, {"data": acc, "temp": temp[:, None], "Fs": RATE,
                            "sensor": "triad SN-7"})


def write_mat73(path, acc, temp):
    """MATLAB v7.3 as MATLAB writes it: HDF5 after a 512-byte header, arrays transposed."""
    import h5py

    with h5py.File(path, "w", userblock_size=512) as h5:
        for name, value in (("data", acc), ("temp", temp[:, None]),
                            ("Fs", np.array([[RATE]]))):
            ds = h5.create_dataset(name, data=np.ascontiguousarray(value.T))
            ds.attrs["MATLAB_class"] = np.bytes_("double")
        text = np.array([ord(c) for c in "triad SN-7"], dtype=np.uint16)[:, None]
        h5.create_dataset("sensor", data=text).attrs["MATLAB_class"] = np.bytes_("char")
    with open(path, "r+b") as fh:
        fh.write(MAT73_HEADER)
