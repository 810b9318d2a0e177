"""DAQ files (TDMS, HDF5, MATLAB v5 and v7.3) read by accelcal.io.recordings (issue 17).

The files are written by the libraries labs use (npTDMS's TdmsWriter, h5py,
scipy.io.savemat, h5py in MATLAB's v7.3 layout) and read back: the values
must be exactly the ones written (no tolerance: float64 is copied, never
computed), the rate, unit and start time those the file states, and the
provenance must carry the file's properties and SHA-256. Broken files are
refused in one AccelcalError line naming the parameter to fix.
"""

import hashlib

import numpy as np
import pytest

from accelcal.errors import AccelcalError
from accelcal.io.recordings import InputOptions, describe, iter_blocks, read_recording
from accelcal.units import STANDARD_GRAVITY
from helpers.daq_files import RATE, signals, write_hdf5, write_mat5, write_mat73, write_tdms

XYZ = {"tdms": ("Accel/X", "Accel/Y", "Accel/Z"),
       "hdf5": ("daq/acc[0]", "daq/acc[1]", "daq/acc[2]"),
       "mat5": ("data[0]", "data[1]", "data[2]"), "mat73": ("data[0]", "data[1]", "data[2]")}
WRITERS = {"tdms": (write_tdms, "a.tdms"), "hdf5": (write_hdf5, "a.h5"),
           "mat5": (write_mat5, "a.mat"), "mat73": (write_mat73, "b.mat")}


def _file(tmp_path, fmt, **kw):
    acc, temp = signals()
    writer, name = WRITERS[fmt]
    path = tmp_path / name
    writer(path, acc, temp, **kw)
    return path, acc, temp


@pytest.mark.parametrize("fmt", list(WRITERS))
def test_values_rate_unit_and_provenance(tmp_path, fmt):
    path, acc, _ = _file(tmp_path, fmt)
    given = {"tdms": {}, "hdf5": {"time": "daq/t"}, "mat5": {"rate": RATE, "unit": "g"},
             "mat73": {"rate": RATE, "unit": "g"}}[fmt]
    rec = read_recording(path, InputOptions(columns=XYZ[fmt], **given), channels=3)
    np.testing.assert_array_equal(rec.values, acc)
    assert rec.unit == "g"
    assert rec.rate == pytest.approx(RATE, rel=1e-9)
    np.testing.assert_allclose(rec.in_si(), acc * STANDARD_GRAVITY, rtol=1e-15)
    prov = rec.provenance
    assert prov["sha256"] == hashlib.sha256(path.read_bytes()).hexdigest()
    assert prov["input_format"] == ("mat" if fmt.startswith("mat") else fmt)
    assert prov["samples"] == acc.shape[0]
    if fmt == "tdms":  # the NI waveform properties and the file's, group's, channel's own
        assert prov["start_time"].startswith("2026-11-23T08:00:00")
        assert prov["properties"]["file"] == {"title": "bench 3", "operator": "A. Lab"}
        assert prov["properties"]["groups"]["Accel"] == {"sensor": "triad SN-7"}
        assert prov["channels"]["Accel/Y"]["properties"] == {"NI_ChannelName": "Dev1/ai1"}
        assert prov["channels"]["Accel/Y"]["file_unit"] == "g"
    elif fmt == "hdf5":
        assert prov["properties"]["attributes"] == {"lab": "vibration lab"}
        assert prov["channels"]["daq/acc[0]"]["properties"] == {"sensor": "triad SN-7"}
    else:  # MATLAB scalars and text: the stated rate is listed for the user, not taken
        props = prov["properties"]
        found = props.get("variables", props.get("attributes", {}))
        assert np.ravel(found["Fs"])[0] == RATE
        assert found["sensor"] == "triad SN-7"


@pytest.mark.parametrize("fmt", list(WRITERS))
def test_streamed_blocks_equal_the_whole(tmp_path, fmt):
    path, acc, _ = _file(tmp_path, fmt)
    opts = InputOptions(columns=XYZ[fmt], rate=RATE, unit="g")
    blocks = list(iter_blocks(path, opts, rows=500))
    assert [b.start for b in blocks] == [0, 500, 1000]
    np.testing.assert_array_equal(np.concatenate([b.values for b in blocks]), acc)


def test_temperature_units_and_per_channel_units(tmp_path):
    path, _, temp = _file(tmp_path, "hdf5")
    rec = read_recording(path, InputOptions(columns=("daq/acc[2]", "daq/temp"), time="daq/t"))
    assert rec.unit == "mixed"
    assert rec.units == ("g", "K")
    np.testing.assert_allclose(rec.values[:, 1], temp + 273.15, rtol=0, atol=0)
    with pytest.raises(AccelcalError, match="not an acceleration"):
        rec.in_si()
    tdms, *_ = _file(tmp_path, "tdms")
    rec = read_recording(tdms, InputOptions(columns=("Temp/Case",), rate=RATE))
    assert rec.unit == "degC"  # NI spells it 'Deg C'


def test_counts_times_scale(tmp_path):
    path, acc, temp = _file(tmp_path, "mat5")
    counts = np.round(acc / 6.1e-5)
    write_mat5(path, counts, temp)
    rec = read_recording(path, InputOptions(columns=("data[2]",), rate=RATE, unit="g",
                                            scale=6.1e-5))
    np.testing.assert_allclose(rec.values[:, 0], counts[:, 2] * 6.1e-5, rtol=1e-15)
    assert rec.provenance["scales"] == {"data[2]": 6.1e-5}


def test_v73_vector_orientation(tmp_path):
    """A MATLAB column vector n x 1 is stored (1, n); a row vector 1 x n is stored (n, 1)."""
    import h5py

    path = tmp_path / "v.mat"
    col, row = np.arange(50.0), -np.arange(50.0)
    with h5py.File(path, "w", userblock_size=512) as h5:
        h5.create_dataset("col", data=col[None, :]).attrs["MATLAB_class"] = np.bytes_("double")
        h5.create_dataset("row", data=row[:, None]).attrs["MATLAB_class"] = np.bytes_("double")
    from helpers.daq_files import MAT73_HEADER

    with open(path, "r+b") as fh:
        fh.write(MAT73_HEADER)
    rec = read_recording(path, InputOptions(columns=("col", "row"), rate=10.0, unit="V"))
    np.testing.assert_array_equal(rec.values, np.column_stack([col, row]))


def _refused(path, match, parameter=None, **options):
    with pytest.raises(AccelcalError, match=match) as info:
        read_recording(path, InputOptions(**options))
    assert "\n" not in str(info.value)
    assert info.value.parameter == parameter
    return info.value


@pytest.mark.parametrize("fmt", list(WRITERS))
def test_missing_channel(tmp_path, fmt):
    path, *_ = _file(tmp_path, fmt)
    _refused(path, "has no column", "columns", columns=(XYZ[fmt][0], "Accel/Q"), rate=RATE,
             unit="g")


def test_channels_of_unequal_lengths_are_named(tmp_path):
    acc, temp = signals()
    path = tmp_path / "short.tdms"
    write_tdms(path, acc, temp, lengths={"Y": 7})
    err = _refused(path, "different lengths", "columns", columns=XYZ["tdms"])
    assert "Accel/X 1200" in str(err)
    assert "Accel/Y 1193" in str(err)


@pytest.mark.parametrize(("options", "match", "parameter"), [
    ({"unit": "V"}, "is in g .the file says so., not V", "unit"),
    ({"rate": 500.0}, "sample rate is 1000 Hz", "rate"),
])
def test_a_unit_or_rate_against_the_file_is_refused(tmp_path, options, match, parameter):
    path, *_ = _file(tmp_path, "tdms")
    _refused(path, match, parameter, columns=XYZ["tdms"], **options)


def test_unknown_file_unit_asks_for_one(tmp_path):
    acc, temp = signals()
    path = tmp_path / "odd.tdms"
    write_tdms(path, acc, temp, unit="furlong/fortnight^2")
    _refused(path, "a unit accelcal does not know", "unit", columns=XYZ["tdms"])
    rec = read_recording(path, InputOptions(columns=XYZ["tdms"], unit="g"))
    assert rec.provenance["channels"]["Accel/X"]["file_unit"] == "furlong/fortnight^2"


@pytest.mark.parametrize(("t", "match"), [
    (np.r_[np.arange(600), np.arange(599, 1199)] / RATE,
     r"repeats \S+ s at data row 601 with different values"),
    (np.r_[np.arange(600), np.arange(590, 1190)] / RATE, "goes backwards at data row 601"),
])
def test_time_going_backwards(tmp_path, t, match):
    acc, temp = signals()
    path = tmp_path / "t.h5"
    write_hdf5(path, acc, temp, t=t)
    _refused(path, match, columns=XYZ["hdf5"], time="daq/t")


def test_time_with_a_gap_is_refused_where_a_record_needs_consecutive_samples(tmp_path):
    acc, temp = signals()
    t = np.r_[np.arange(600), np.arange(650, 1250)] / RATE
    path = tmp_path / "gap.h5"
    write_hdf5(path, acc, temp, t=t)
    rec = read_recording(path, InputOptions(columns=XYZ["hdf5"], time="daq/t"))
    assert rec.gaps().tolist() == [599]
    _refused(path, r"jumps from 0.599 s to 0.65 s at data row 601 \(about 50 missing", None,
             columns=XYZ["hdf5"], time="daq/t", refuse_gaps=True)
    opts = InputOptions(columns=XYZ["hdf5"], time="daq/t", refuse_gaps=True)
    with pytest.raises(AccelcalError, match="at data row 601"):  # across block boundaries too
        list(iter_blocks(path, opts, rows=100))


@pytest.mark.parametrize("fmt", list(WRITERS))
@pytest.mark.parametrize("keep", [0.3, 0.7, 0.98])
def test_truncated_files(tmp_path, fmt, keep):
    path, *_ = _file(tmp_path, fmt)
    data = path.read_bytes()
    path.write_bytes(data[:int(len(data) * keep)])
    with pytest.raises(AccelcalError, match=r"truncated|damaged") as info:
        read_recording(path, InputOptions(columns=XYZ[fmt], rate=RATE, unit="g"))
    assert "\n" not in str(info.value)


def test_auto_tells_the_formats_by_their_magic_bytes(tmp_path):
    for fmt in WRITERS:
        path, *_ = _file(tmp_path, fmt)
        prov, _ = describe(path, InputOptions(columns=XYZ[fmt][:1], rate=RATE, unit="g"))
        assert prov["input_format"] == ("mat" if fmt.startswith("mat") else fmt)
    path = tmp_path / "a.tdms"
    _refused(path, "not an HDF5 file", "input_format", input_format="hdf5", columns=("x",),
             unit="g", rate=1.0)
    _refused(path, "not a MATLAB v5 or v7.3", "input_format", input_format="mat",
             columns=("x",), unit="g", rate=1.0)
