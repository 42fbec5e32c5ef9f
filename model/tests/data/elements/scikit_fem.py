#!/usr/bin/env python3
"""Elastic frequencies of 10-node tetrahedra computed by an independent finite-element code.

scikit-fem (12.0) on the tetrahedra of a Gmsh mesh (`tet1.msh`, or the one named on the command
line: `vented_disc.msh`, the disc of `pipelines/vented_brake/brake.geo` with its pads' and
surfaces' physical groups left out, `gmsh disc.geo -3 -order 1 -clmax 0.02 -nt 1 -format
msh41`) read by meshio, with quadratic elements on
them (`ElementTetP2` on `MeshTet1`: straight edges, the mid-edge nodes at their middles, as
squeal's `with_mid_edge_nodes` makes them), steel (E = 2.02e11 Pa, ν = 0.29, ρ = 7850 kg/m³),
free. On straight-sided elements both codes integrate stiffness and consistent mass exactly
(here order 4), so they solve the same discrete problem. (On curved elements no rule is
exact and two codes differ by their quadrature.) The lowest 16 eigenvalues by
scipy's dense generalised eigensolver. Prints the ten after the six rigid-body
modes, for
`stages/tests/verification/reference_values/scikit_fem_tet10.json`; on a larger mesh the lowest
16 by scipy's sparse shift-invert Lanczos (`eigsh`, shift below zero: the body is free), for
`scikit_fem_vented_disc.json`. Run from this folder: `python3 scikit_fem.py [mesh]`.
"""

import json
import sys

import meshio
import numpy as np
from scipy.linalg import eigh
from scipy.sparse.linalg import eigsh
from skfem import Basis, BilinearForm, ElementTetP2, ElementVector, MeshTet, asm
from skfem.models.elasticity import lame_parameters, linear_elasticity

E, NU, RHO = 2.02e11, 0.29, 7850.0

mesh_file = meshio.read(sys.argv[1] if len(sys.argv) > 1 else "tet1.msh")
cells = [block for block in mesh_file.cells if block.type == "tetra"][0].data
used = np.unique(cells)
renumber = np.zeros(mesh_file.points.shape[0], dtype=int)
renumber[used] = np.arange(used.size)
mesh = MeshTet(mesh_file.points[used].T, renumber[cells].T)
basis = Basis(mesh, ElementVector(ElementTetP2()), intorder=4)
K = asm(linear_elasticity(*lame_parameters(E, NU)), basis)


@BilinearForm
def mass(u, v, _):
    return RHO * (u[0] * v[0] + u[1] * v[1] + u[2] * v[2])


M = asm(mass, basis)
if K.shape[0] <= 5000:
    eigenvalues = eigh(K.toarray(), M.toarray(), eigvals_only=True, subset_by_index=[0, 15])
else:
    shift = -((2.0 * np.pi * 10.0) ** 2)
    eigenvalues = np.sort(eigsh(K, k=16, M=M, sigma=shift, which="LM", return_eigenvectors=False))
frequencies = np.sqrt(eigenvalues[6:]) / (2.0 * np.pi)
print(json.dumps([float(f"{f:.12g}") for f in frequencies]))
