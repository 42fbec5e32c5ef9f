#!/usr/bin/env python3
"""The elastic frequencies of `tet2.msh` computed by an independent finite-element code.

scikit-fem (12.0) on the same mesh read by meshio: isoparametric quadratic tetrahedra
(`MeshTet2`, `ElementTetP2`), steel (E = 2.02e11 Pa, ν = 0.29, ρ = 7850 kg/m³), free, the
stiffness and consistent mass integrated exactly (order 4), the lowest 16 eigenvalues by
scipy's dense generalised eigensolver (1,917 DOFs). Prints the ten after the six rigid-body
modes, for
`stages/tests/verification/reference_values/scikit_fem_tet10.json`. Run from this folder:
`python3 scikit_fem.py`.
"""

import json

import meshio
import numpy as np
from scipy.linalg import eigh
from skfem import Basis, BilinearForm, ElementTetP2, ElementVector, MeshTet2, asm
from skfem.models.elasticity import lame_parameters, linear_elasticity

E, NU, RHO = 2.02e11, 0.29, 7850.0

mesh_file = meshio.read("tet2.msh")
cells = [block for block in mesh_file.cells if block.type == "tetra10"][0].data
mesh = MeshTet2(mesh_file.points.T, cells.T)
basis = Basis(mesh, ElementVector(ElementTetP2()), intorder=4)
K = asm(linear_elasticity(*lame_parameters(E, NU)), basis)


@BilinearForm
def mass(u, v, _):
    return RHO * (u[0] * v[0] + u[1] * v[1] + u[2] * v[2])


M = asm(mass, basis)
eigenvalues = eigh(K.toarray(), M.toarray(), eigvals_only=True, subset_by_index=[0, 15])
frequencies = np.sqrt(eigenvalues[6:]) / (2.0 * np.pi)
print(json.dumps([float(f"{f:.12g}") for f in frequencies]))
