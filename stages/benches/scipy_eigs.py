"""scipy's shift-invert `eigs` on the stability problem the `stability` benchmark solves.

    SQUEAL_EXPORT_DIR=stability-export cargo bench -p squeal-stages --bench stability
    python3 stages/benches/scipy_eigs.py stability-export

The benchmark writes the reduced sliding problem (M.mtx, C.mtx, K.mtx: M~, C~, K~ of the
`stability` stage, non-symmetric), the eigenvalues it found (eigenvalues.csv) and its shifts
(shifts.csv: frequency, trusted radius, eigenvalues converged there). This script linearises
the same way (y = [q; lambda q / s], s = sqrt(|K|_1 / |M|_1)), runs ARPACK in shift-invert
mode (complex arithmetic, SuperLU factorisation of A - sigma B) at the same shifts asking for
as many eigenvalues as squeal converged there, and reports the wall time, the peak memory, the
residuals of the quadratic problem (same normwise definition as squeal) and the largest
distance between the two sets of eigenvalues in the band.

    python3 stages/benches/scipy_eigs.py stability-export --shift 6

runs only the listed shifts (0-based rows of shifts.csv; the full 17 kHz band takes scipy
hours) and compares with squeal's eigenvalues inside their disks.
"""

import resource
import sys
import time
from pathlib import Path

import numpy as np
import scipy.io
import scipy.sparse as sp
from scipy.sparse.linalg import eigs


def norm_1(A):
    return abs(A).sum(axis=0).max()


def main(folder, only=None):
    folder = Path(folder)
    M, C, K = (sp.csc_matrix(scipy.io.mmread(folder / f"{name}.mtx")) for name in "MCK")
    m = M.shape[0]
    found = np.loadtxt(folder / "eigenvalues.csv", delimiter=",", skiprows=1, ndmin=2)
    ours = found[:, 0] + 1j * found[:, 1]
    shifts = np.loadtxt(folder / "shifts.csv", delimiter=",", skiprows=1, ndmin=2)
    if only:
        shifts = shifts[only]
        inside_any = np.zeros(len(ours), dtype=bool)
        for frequency, radius, _ in shifts:
            inside_any |= np.abs(ours - 2j * np.pi * frequency) < radius
        ours = ours[inside_any]
    s = np.sqrt(norm_1(K) / norm_1(M))
    I = sp.identity(m, format="csc")
    Z = sp.csc_matrix((m, m))
    A = sp.bmat([[Z, s * I], [-K, -s * C]], format="csc").astype(complex)
    B = sp.bmat([[I, Z], [Z, s * M]], format="csc").astype(complex)
    norms = (norm_1(M), norm_1(C), norm_1(K))

    def residual(lam, q):
        r = lam * lam * (M @ q) + lam * (C @ q) + K @ q
        scale = abs(lam) ** 2 * norms[0] + abs(lam) * norms[1] + norms[2]
        return np.linalg.norm(r) / (scale * np.linalg.norm(q))

    started = time.perf_counter()
    values = []
    worst = 0.0
    for frequency, radius, converged in shifts:
        sigma = 2j * np.pi * frequency
        k = int(min(max(converged, 1), 2 * m - 2))
        lam, Y = eigs(A, k=k, M=B, sigma=sigma, which="LM", tol=1e-10)
        inside = np.abs(lam - sigma) < radius
        for value, y in zip(lam[inside], Y[:, inside].T):
            if value.imag > 0:
                values.append(value)
                worst = max(worst, residual(value, y[:m]))
        print(f"  shift {frequency:9.0f} Hz: {k} eigenvalues, {time.perf_counter() - started:7.1f} s so far", flush=True)
    seconds = time.perf_counter() - started
    peak_mib = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    values = np.array(values)
    distance = max(
        (np.min(np.abs(values - value)) / abs(value) for value in ours), default=0.0
    )
    print(
        f"scipy eigs (shift-invert, SuperLU): {seconds:.1f} s, peak memory {peak_mib:.0f} MiB, "
        f"{len(shifts)} shifts, worst residual {worst:.1e}, "
        f"largest distance from squeal's {len(ours)} eigenvalues {distance:.1e}"
    )


if __name__ == "__main__":
    arguments = sys.argv[1:]
    only = [int(value) for flag, value in zip(arguments, arguments[1:]) if flag == "--shift"]
    folder = arguments[0] if arguments and not arguments[0].startswith("--") else "stability-export"
    main(folder, only or None)
