"""PyWavelets reference for `cwt.rs`: the same signal and frequency grid, `method='fft'`.

    pip install pywavelets numpy
    python stages/benches/pywavelets_cwt.py            # 100k samples x 300 frequencies
    python stages/benches/pywavelets_cwt.py --large    # also 1M samples x 256 frequencies

Not run by CI. `cmor2.0-C` with C = k0 / (2 pi) is the Morlet of the design,
psi(t) = exp(i k0 t) exp(-t^2 / 2), up to a constant factor; scale s (in samples) analyses
frequency C / (s dt), i.e. s = k0 / (2 pi f dt), the scale a = k0 / (2 pi f) in samples.
Prints the minimum wall time over several runs, like the Rust benchmark.
"""

import sys
import time

import numpy as np
import pywt

DT = 1e-5
K0 = 6.0
F_MIN, F_MAX = 100.0, 25_000.0


def signal(n):
    t = np.arange(n) * DT
    duration = n * DT
    return (
        np.sin(2 * np.pi * 3537.0 * t)
        + 0.3 * np.sin(2 * np.pi * 11_100.0 * t)
        + 0.5 * np.sin(2 * np.pi * (500.0 * t + 0.5 * (8000.0 / duration) * t * t))
    )


def bench(n_samples, n_freqs, runs):
    data = signal(n_samples)
    center = K0 / (2 * np.pi)
    wavelet = f"cmor2.0-{center}"
    freqs = np.geomspace(F_MIN, F_MAX, n_freqs)
    scales = center / (freqs * DT)
    best = float("inf")
    for _ in range(runs):
        start = time.perf_counter()
        coefficients, _ = pywt.cwt(data, scales, wavelet, sampling_period=DT, method="fft")
        best = min(best, time.perf_counter() - start)
        del coefficients
    print(
        f"pywt.cwt {wavelet} fft, pywavelets {pywt.__version__}: "
        f"{n_samples:>9} samples x {n_freqs} freqs: {best:8.3f} s (min of {runs})"
    )


if __name__ == "__main__":
    bench(100_000, 300, 3)
    if "--large" in sys.argv:
        bench(1_000_000, 256, 1)
