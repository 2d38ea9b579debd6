"""The resolver converter's cyclic error (paper 3 §3: the 19-bit RDC's ±10″): over a turn the
readout's error is a single sinusoid at twice the shaft angle of the stated peak (numpy's
FFT), the converter's quantisation stays on top of it, and zero error draws nothing (the
no-regression and engine-bag tests hold every scenario's bytes to that); the compiled platform
chain with the error on is checked in test_compiled_platform.py."""
import math

import numpy as np
import pytest

from gimbal_sim.world.sensors import EncoderModel, EncoderParams

ARCSEC = math.pi / (180.0 * 3600.0)
N = 4096  # samples over one turn


def _turn(params: EncoderParams, seed: int = 3) -> tuple[np.ndarray, np.ndarray]:
    enc = EncoderModel(params, 2, np.random.default_rng(seed), 1e-3)
    theta = np.linspace(0.0, 2.0 * math.pi, N, endpoint=False)
    read = np.array([enc.step([t, -t])[0] for t in theta])
    return theta, read - np.column_stack([theta, -theta])


def test_the_cyclic_error_is_one_twice_per_turn_sinusoid_of_the_stated_peak():
    theta, err = _turn(EncoderParams(cyclic_error_arcsec=10.0))
    for axis in range(2):
        spectrum = np.abs(np.fft.rfft(err[:, axis])) * 2.0 / N
        assert spectrum[2] == pytest.approx(10.0 * ARCSEC, rel=1e-9)  # twice per turn, the peak
        assert np.max(np.delete(spectrum, 2)) < 1e-9 * ARCSEC
        assert np.max(np.abs(err[:, axis])) == pytest.approx(10.0 * ARCSEC, rel=1e-5)


def test_each_unit_has_its_own_phase_and_the_harmonic_is_a_parameter():
    _, err = _turn(EncoderParams(cyclic_error_arcsec=10.0, cyclic_harmonic=1))
    spectra = [np.fft.rfft(err[:, a]) for a in range(2)]
    assert all(abs(s[1]) * 2.0 / N == pytest.approx(10.0 * ARCSEC, rel=1e-9) for s in spectra)
    assert abs(np.angle(spectra[0][1]) - np.angle(spectra[1][1])) > 1e-3


def test_quantisation_stays_on_top_of_the_cyclic_error():
    q = 2.0 * math.pi / 2 ** 19
    _, err = _turn(EncoderParams(cyclic_error_arcsec=10.0, lines_per_rev=2 ** 19))
    _, cyc = _turn(EncoderParams(cyclic_error_arcsec=10.0))
    assert np.max(np.abs(err - cyc)) <= q / 2.0 + 1e-15  # mid-tread counts of the erring angle


def test_zero_cyclic_error_draws_no_phase_and_bad_values_are_refused_by_name():
    enc = EncoderModel(EncoderParams(lines_per_rev=2 ** 19, noise_deg=1e-3), 2, np.random.default_rng(3), 1e-3)
    assert np.all(enc.cyclic_phases == 0.0) and enc.cyclic_rad == 0.0
    with pytest.raises(ValueError, match="cyclic_harmonic"):
        EncoderParams(cyclic_harmonic=0)
    with pytest.raises(ValueError, match="cyclic_error_arcsec"):
        EncoderParams(cyclic_error_arcsec=-1.0)
