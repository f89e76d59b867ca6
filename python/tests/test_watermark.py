"""Spectral watermarking from Python: round trip, wrong key, attacks through the
library's CLI-equivalent path, and bad input."""

import numpy as np
import pytest

import meshlap

MSG = "0123456789abcdef"


@pytest.fixture(scope="module")
def marked():
    V, F = meshlap.read_mesh("builtin:icosphere:4")
    Vm, report = meshlap.watermark_embed(V, F, 42, MSG, patch_size=300, strength=5e-4)
    return V, F, Vm, report


def test_embed_keeps_connectivity_and_reports(marked):
    V, F, Vm, report = marked
    assert Vm.shape == V.shape and Vm.dtype == np.float64
    assert report["bits"] == 64
    for key in ["patches", "coefficients_per_bit", "mrms", "max_displacement", "msdm2", "seconds"]:
        assert key in report
    # The mark moves the vertices, by about the requested RMS.
    diag = np.linalg.norm(V.max(0) - V.min(0))
    mrms = np.sqrt(((Vm - V) ** 2).sum(1).mean()) / diag
    assert mrms == pytest.approx(report["mrms"], rel=1e-6)
    assert 1e-4 < mrms < 1e-3


def test_detect_round_trip_and_noise(marked):
    V, F, Vm, _ = marked
    r = meshlap.watermark_detect(Vm, F, V, F, 42, expect=MSG, patch_size=300)
    assert r["message"] == MSG and r["bit_errors"] == 0
    assert r["false_positive_probability"] < 1e-6
    rng = np.random.default_rng(7)
    diag = np.linalg.norm(V.max(0) - V.min(0))
    noisy = Vm + rng.uniform(-1, 1, Vm.shape) * 1e-4 * diag
    r = meshlap.watermark_detect(noisy, F, V, F, 42, expect=MSG, patch_size=300)
    assert r["bit_errors"] == 0


def test_wrong_key_and_unmarked_find_nothing(marked):
    V, F, Vm, _ = marked
    assert meshlap.watermark_detect(Vm, F, V, F, 43, patch_size=300)["message"] is None
    assert meshlap.watermark_detect(V, F, V, F, 42, patch_size=300)["message"] is None


def test_bad_input_raises(marked):
    V, F, _, _ = marked
    with pytest.raises(meshlap.WatermarkError):
        meshlap.watermark_embed(V, F, 42, "xyz")
    with pytest.raises(meshlap.WatermarkError):
        meshlap.watermark_embed(V, F, -1, MSG)
    with pytest.raises(meshlap.Error):
        meshlap.watermark_embed(V[:, :2], F, 42, MSG)
