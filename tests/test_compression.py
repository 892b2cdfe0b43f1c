"""[output] compression: the filter of the (N, steps, 2) series follows the study, the data does not."""

import os
import subprocess
import sys

import h5py
import numpy as np
import pytest

import explorer
from explorer.errors import UserError

#: [output] compression -> the HDF5 filter pipeline of the series (ids: 2 shuffle, 3 Fletcher-32, 1 gzip,
#: 32000 lzf, 32001 Blosc (its own byte shuffle inside), 32015 Zstandard)
EXPECTED = {"blosc": [32001, 3], "zstd": [2, 32015, 3], "lzf": [2, 32000, 3], "gzip": [2, 1, 3], "none": [3]}


def _study(tmp_path, compression):
    return {"study": {"name": "c", "mechanism": "jansen", "variants": 40, "steps": 24, "seed": 3},
            "scene": {"velocities": True},
            "output": {"path": str(tmp_path / f"{compression}.h5"), "compression": compression}}


def _pipeline(d):
    plist = d.id.get_create_plist()
    return [plist.get_filter(i)[0] for i in range(plist.get_nfilters())]


def _bits(a):
    return np.ascontiguousarray(a).view(np.uint64)


def test_each_compression_sets_its_filter_and_keeps_every_bit(tmp_path):
    study = explorer.load_study(_study(tmp_path, "none"))
    lengths, crank, _ = explorer.study.study_variants(study)
    # the reference: the kernels' own output for the same designs, never stored
    ref = explorer.simulate_batch(study.mech, lengths, crank, study.steps, vertices=["7"], velocities=True,
                                  tolerance=study.tolerance)
    for comp, expect in EXPECTED.items():
        out = explorer.run_study(_study(tmp_path, comp), progress=False)
        with h5py.File(out, "r") as f:
            d = f["paths/7"]
            assert sorted(_pipeline(d)) == sorted(expect) and _pipeline(d)[-1] == 3, comp
            assert f.attrs["series_filter"].startswith(f"{comp}: "), comp
            assert np.array_equal(_bits(d[...]), _bits(ref.paths["7"])), comp
            assert np.array_equal(_bits(f["velocities/7"][...]), _bits(ref.velocities["7"])), comp
        explorer.open_results(out).close()  # it verifies


def test_default_is_blosc_and_plain_h5py_reads_it_after_importing_hdf5plugin(tmp_path):
    d = _study(tmp_path, "blosc")
    del d["output"]["compression"]
    out = explorer.run_study(d, progress=False)
    with h5py.File(out, "r") as f:
        assert 32001 in _pipeline(f["paths/7"])
        assert "import hdf5plugin" in f.attrs["series_filter"]
        want = _bits(f["paths/7"][...])
    # a fresh interpreter with nothing of explorer: h5py + hdf5plugin read the same bits
    code = ("import sys, h5py, hdf5plugin, numpy as np\n"
            "with h5py.File(sys.argv[1], 'r') as f:\n"
            "    sys.stdout.buffer.write(np.ascontiguousarray(f['paths/7'][...]).tobytes())\n")
    got = subprocess.run([sys.executable, "-c", code, os.fspath(out)], capture_output=True, check=True).stdout
    assert np.array_equal(np.frombuffer(got, dtype=np.uint64).reshape(want.shape), want)


def test_unknown_compression_is_a_one_line_error(tmp_path):
    with pytest.raises(UserError, match=r"output\.compression.*'brotli'") as e:
        explorer.load_study(_study(tmp_path, "brotli"))
    assert "\n" not in str(e.value) and "blosc" in str(e.value) and "lzf" in str(e.value)
