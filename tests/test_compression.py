"""[output] compression: the filter of the (N, steps, 2) series follows the study, the data does not."""

import h5py
import numpy as np
import pytest

import explorer
from explorer.errors import UserError


def _study(tmp_path, compression):
    return {"study": {"name": "c", "mechanism": "jansen", "variants": 40, "steps": 24, "seed": 3},
            "output": {"path": str(tmp_path / f"{compression}.h5"), "compression": compression}}


def test_each_compression_sets_its_filter_and_keeps_the_data(tmp_path):
    paths = {}
    for comp, expect in (("lzf", "lzf"), ("gzip", "gzip"), ("none", None)):
        out = explorer.run_study(_study(tmp_path, comp), progress=False)
        with h5py.File(out, "r") as f:
            d = f["paths/7"]
            assert d.compression == expect
            assert d.shuffle == (expect is not None)
            paths[comp] = d[...]
    assert np.array_equal(paths["lzf"], paths["none"], equal_nan=True)
    assert np.array_equal(paths["gzip"], paths["none"], equal_nan=True)


def test_unknown_compression_is_a_one_line_error(tmp_path):
    with pytest.raises(UserError, match=r"output\.compression.*'zstd'") as e:
        explorer.load_study(_study(tmp_path, "zstd"))
    assert "\n" not in str(e.value) and "lzf" in str(e.value)
