"""The lowest modes of the benchmark disc with scipy, for comparison with `benches/modes.rs`.

Reads K.mtx and M.mtx (written by `cargo bench -p squeal-stages --bench modes`), runs
shift-invert ARPACK, eigsh(K, k, M=M, sigma=0, which='LM'), and prints the wall time and the
residuals ||K phi - lambda M phi|| / ||K phi|| measured as the Rust benchmark measures them.

    python3 stages/benches/scipy_eigsh.py <directory> [k]
"""

import sys
import time

import numpy as np
import scipy
import scipy.io
import scipy.sparse
import scipy.sparse.linalg


def main() -> None:
    directory = sys.argv[1]
    k = int(sys.argv[2]) if len(sys.argv) > 2 else 100
    K = scipy.sparse.csc_matrix(scipy.io.mmread(f"{directory}/K.mtx"))
    M = scipy.sparse.csc_matrix(scipy.io.mmread(f"{directory}/M.mtx"))
    print(f"scipy {scipy.__version__}, n = {K.shape[0]}, nnz(K) = {K.nnz}, k = {k}")
    started = time.perf_counter()
    eigenvalues, vectors = scipy.sparse.linalg.eigsh(K, k=k, M=M, sigma=0, which="LM")
    wall = time.perf_counter() - started
    order = np.argsort(eigenvalues)
    eigenvalues, vectors = eigenvalues[order], vectors[:, order]
    K_vectors = K @ vectors
    residuals = np.linalg.norm(K_vectors - (M @ vectors) * eigenvalues, axis=0) / np.linalg.norm(
        K_vectors, axis=0
    )
    frequencies = np.sqrt(np.abs(eigenvalues)) / (2 * np.pi)
    print(
        f"eigsh: {k} modes in {wall:.3f} s, f1 = {frequencies[0]:.2f} Hz, "
        f"f{k} = {frequencies[-1]:.2f} Hz, worst residual {residuals.max():.2e}"
    )


if __name__ == "__main__":
    main()
