"""The transient's scheme written with scipy, as a researcher would: the reference that
`cargo bench -p squeal-stages --bench transient` is compared with.

    SQUEAL_EXPORT_DIR=transient-data cargo bench -p squeal-stages --bench transient
    python3 stages/benches/transient_scipy.py transient-data [steps]

Same data (M, C, K, the rows of H, the pairs, the kick), same scheme (θ = 1/2, τ = 1e-6 s):
J = M/τ + θ(C + τθK) factorised once with SuperLU (`splu`), Z = J⁻¹ Hᵀ and W = H Z formed
once, then per step a solve for the free velocity, the contact problem by projected
Gauss-Seidel over the pairs (a Python loop, warm-started) and V = V_free + Z r.
"""

import sys
import time

import numpy as np
import scipy.io
import scipy.sparse as sp
import scipy.sparse.linalg as spla


def load(directory):
    M, C, K = (scipy.io.mmread(f"{directory}/{name}.mtx").tocsc() for name in "MCK")
    h = np.loadtxt(f"{directory}/H.csv", delimiter=",", skiprows=1, ndmin=2)
    pairs = np.loadtxt(f"{directory}/pairs.csv", delimiter=",", skiprows=1, ndmin=2)
    v0 = np.loadtxt(f"{directory}/v0.csv")
    n = M.shape[0]
    H = sp.csr_matrix((h[:, 2], (h[:, 0].astype(int), h[:, 1].astype(int))), shape=(3 * len(pairs), n))
    return M, C, K, H, pairs, v0


def project(r, w, w_n_min, speed, mu, rho_n, rho_t):
    r_n = max(0.0, r[0] - rho_n * (w[0] - w_n_min))
    trial = np.array([r[1] - rho_t * (w[1] - speed), r[2] - rho_t * w[2]])
    length = np.hypot(trial[0], trial[1])
    if length > mu * r_n:
        trial *= mu * r_n / length
    return np.array([r_n, trial[0], trial[1]])


def main():
    directory = sys.argv[1]
    steps = int(sys.argv[2]) if len(sys.argv) > 2 else 300
    tau, theta = 1e-6, 0.5
    M, C, K, H, pairs, v = load(directory)
    n, n_pairs = M.shape[0], len(pairs)
    gap0, speed, mu = pairs[:, 0], pairs[:, 1], pairs[0, 5]
    r_e = pairs[:, 2:5].reshape(-1)

    clock = time.perf_counter()
    J = (M / tau + theta * C + tau * theta * theta * K).tocsc()
    solve = spla.factorized(J)
    factor_s = time.perf_counter() - clock
    clock = time.perf_counter()
    Ht = H.T.toarray()
    Z = np.column_stack([solve(Ht[:, k]) for k in range(3 * n_pairs)])
    W = H @ Z
    delassus_s = time.perf_counter() - clock
    A = (M / tau - (1 - theta) * C - tau * theta * (1 - theta) * K).tocsr()
    Ksr = K.tocsr()
    equilibrium_force = H.T @ r_e
    rho_n = 1.0 / W.diagonal()[0::3]
    rho_t = 1.0 / np.maximum(W.diagonal()[1::3], W.diagonal()[2::3])
    force_scale = max(np.abs(r_e).max(), 1e-300)

    u = np.zeros(n)
    r = r_e.copy()
    w = H @ v
    delta = H @ u
    solve_s = contact_s = 0.0
    most_sweeps = 0
    clock_steps = time.perf_counter()
    for step in range(steps):
        rhs = A @ v - Ksr @ u - equilibrium_force
        clock = time.perf_counter()
        v_free = solve(rhs)
        solve_s += time.perf_counter() - clock
        w_free = H @ v_free
        w_n_min = -(gap0 + delta[0::3] + tau * (1 - theta) * w[0::3]) / tau
        clock = time.perf_counter()
        w_new = w_free + W @ r
        for sweep in range(1, 2001):
            for p in range(n_pairs):
                k = slice(3 * p, 3 * p + 3)
                new = project(r[k], w_new[k], w_n_min[p], speed[p], mu, rho_n[p], rho_t[p])
                change = new - r[k]
                if change.any():
                    w_new += W[:, k] @ change
                    r[k] = new
            residual = max(
                np.abs(project(r[3 * p:3 * p + 3], w_new[3 * p:3 * p + 3], w_n_min[p], speed[p], mu, rho_n[p], rho_t[p]) - r[3 * p:3 * p + 3]).max()
                for p in range(n_pairs)
            ) / max(force_scale, np.abs(r).max())
            if residual <= 1e-10:
                break
        most_sweeps = max(most_sweeps, sweep)
        contact_s += time.perf_counter() - clock
        v_new = v_free + Z @ r
        u = u + tau * (theta * v_new + (1 - theta) * v)
        delta = delta + tau * (theta * w_new + (1 - theta) * w)
        v, w = v_new, w_new
    steps_s = time.perf_counter() - clock_steps
    per_step = lambda seconds: 1e3 * seconds / steps
    print(f"scipy: {n} DOFs, {n_pairs} pairs, {steps} steps")
    print(f"factorisation of J {factor_s:.2f} s, Delassus operator {delassus_s:.2f} s")
    print(
        f"per step {per_step(steps_s):.3f} ms: solve {per_step(solve_s):.3f} ms, "
        f"contact {per_step(contact_s):.3f} ms (most sweeps {most_sweeps}), "
        f"the rest {per_step(steps_s - solve_s - contact_s):.3f} ms"
    )
    print(f"kinetic energy at the end {0.5 * v @ (M @ v):.6e} J")


if __name__ == "__main__":
    main()
