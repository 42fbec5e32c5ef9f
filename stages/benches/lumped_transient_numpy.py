"""The lumped transient's scheme as a Python loop with numpy, as a researcher would write it: the
reference that `cargo bench -p squeal-stages --bench lumped_transient` runs back to back with
`transient.matrices`.

    python3 stages/benches/lumped_transient_numpy.py <steps>

The stick-slip oscillator of `pipelines/stick_slip/stick_slip.yaml` (stage `belt`, static
friction 0.5 over kinetic 0.4), read from the same files, integrated by the same scheme:
theta = 1/2, J = M/tau + theta (C + tau theta K) inverted once, W = H J^-1 H^T formed once,
then per step the free velocity, the one contact's laws (Signorini on the equivalent gap,
Coulomb with the static coefficient for a contact that stuck at the step's start) solved
exactly by trying open, stick and slide, and v = v_free + J^-1 H^T r. Prints the seconds the
steps took and the final state, which the benchmark checks against the stage's.
"""

import sys
import time
from pathlib import Path

import numpy as np
import scipy.io

STUDY = Path(__file__).resolve().parents[2] / "pipelines" / "stick_slip"
THETA = 0.5
TAU = 2 * np.pi / 20 / 2000
LOAD = np.array([0.0, -10.0])
MU, MU_STATIC, SPEED = 0.4, 0.5, 0.1


def contact_law(w_free, W, w_n_min, mu):
    """The reaction (r_n, r_t) of the step: open, stick or slide, whichever satisfies the laws."""
    if w_free[0] >= w_n_min:
        return np.zeros(2), "open"
    r = np.linalg.solve(W, np.array([w_n_min, SPEED]) - w_free)
    if r[0] >= 0 and abs(r[1]) <= mu * r[0]:
        return r, "stick"
    for sign in (1.0, -1.0):
        r_n = (w_n_min - w_free[0]) / (W[0, 0] + sign * mu * W[0, 1])
        r = np.array([r_n, sign * mu * r_n])
        slip = w_free[1] + W[1] @ r - SPEED
        if r_n >= 0 and -sign * slip > 0:
            return r, "slide"
    raise RuntimeError("no contact state satisfies the laws")


def main(steps):
    M = scipy.io.mmread(STUDY / "M.mtx").toarray()
    K = scipy.io.mmread(STUDY / "K.mtx").toarray()
    C = np.zeros_like(M)
    H = np.array([[0.0, 1.0], [1.0, 0.0]])  # contacts.yaml: normal DOF 1, tangent DOF 0
    J = M / TAU + THETA * (C + TAU * THETA * K)
    J_inv = np.linalg.inv(J)
    response = J_inv @ H.T
    W = H @ response
    u, v = np.zeros(2), np.zeros(2)
    w, gap, stuck = H @ v, 0.0, False
    start = time.perf_counter()
    for _ in range(steps):
        rhs = M @ v / TAU - (1 - THETA) * (C @ v) - TAU * THETA * (1 - THETA) * (K @ v) - K @ u + LOAD
        v_free = J_inv @ rhs
        w_free = H @ v_free
        w_n_min = -(gap + TAU * (1 - THETA) * w[0]) / TAU
        r, state = contact_law(w_free, W, w_n_min, MU_STATIC if stuck else MU)
        if stuck and state == "slide":
            r, state = contact_law(w_free, W, w_n_min, MU)
        v_new = v_free + response @ r
        w_new = H @ v_new
        u = u + TAU * (THETA * v_new + (1 - THETA) * v)
        gap = gap + TAU * (THETA * w_new[0] + (1 - THETA) * w[0])
        v, w, stuck = v_new, w_new, state == "stick"
    seconds = time.perf_counter() - start
    print(f"{seconds:.6f} {u[0]:.17e} {v[0]:.17e}")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 24000)
