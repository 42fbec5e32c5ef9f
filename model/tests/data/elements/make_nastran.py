#!/usr/bin/env python3
"""Nastran decks of the element-kind test meshes, written by pyNastran (1.4).

Reads each `<kind><order>.msh` with Gmsh's API, puts each element's nodes in Nastran's order
(derived here from Gmsh's reference coordinates of its own node order and the Nastran Quick
Reference Guide's edge lists, independently of squeal's tables), and writes
`<kind><order>.bdf` with pyNastran: the grid points in a cylindrical system CORD2C 2 (whose
axis is the annulus's, its origin moved), one PSOLID 7 named `disc` by a HyperMesh comment,
a SET1 of the points at z = 0, small fields for first-order meshes and large fields for
second-order ones. Run from this folder after `make.py`: `python3 make_nastran.py`.
"""

import math

import gmsh
from pyNastran.bdf.bdf import BDF

# Nastran's mid-edge nodes, by the corners of their edge (0-based), after the corners.
NASTRAN_EDGES = {
    "tet": [(0, 1), (1, 2), (2, 0), (0, 3), (1, 3), (2, 3)],
    "wedge": [(0, 1), (1, 2), (2, 0), (0, 3), (1, 4), (2, 5), (3, 4), (4, 5), (5, 3)],
    "hex": [(0, 1), (1, 2), (2, 3), (3, 0), (0, 4), (1, 5), (2, 6), (3, 7),
            (4, 5), (5, 6), (6, 7), (7, 4)],
}
CARD = {"tet": "CTETRA", "wedge": "CPENTA", "hex": "CHEXA"}
N_CORNERS = {"tet": 4, "wedge": 6, "hex": 8}


def nastran_order(kind, element_type):
    """Positions in Gmsh's node list of Nastran's nodes, from Gmsh's reference coordinates."""
    _, _, _, n_nodes, local, _ = gmsh.model.mesh.getElementProperties(element_type)
    points = [tuple(local[3 * k:3 * k + 3]) for k in range(n_nodes)]
    n = N_CORNERS[kind]
    order = list(range(n))
    if n_nodes > n:
        for a, b in NASTRAN_EDGES[kind]:
            middle = tuple(0.5 * (points[a][i] + points[b][i]) for i in range(3))
            order.append(min(range(n_nodes), key=lambda k: sum((points[k][i] - middle[i]) ** 2 for i in range(3))))
    return order


def write(stem, kind):
    gmsh.initialize()
    gmsh.option.setNumber("General.Terminal", 0)
    gmsh.open(f"{stem}.msh")
    model = BDF(debug=None)
    # CORD2C 2: axis along z through (0, 0, -0.02), θ = 0 along x.
    model.add_cord2c(2, [0.0, 0.0, -0.02], [0.0, 0.0, 1.0], [1.0, 0.0, -0.02])
    tags, coords, _ = gmsh.model.mesh.getNodes()
    bottom = []
    for tag, k in zip(tags, range(len(tags))):
        x, y, z = coords[3 * k:3 * k + 3]
        r, theta = math.hypot(x, y), math.degrees(math.atan2(y, x))
        model.add_grid(int(tag), [r, theta, z + 0.02], cp=2)
        if z == 0.0:
            bottom.append(int(tag))
    model.add_set1(1, bottom)
    model.add_psolid(7, 1, comment=' HMNAME PROP                   7"disc"')
    model.add_mat1(1, 2.0e11, None, 0.3, rho=7850.0)
    types, element_tags, node_tags = gmsh.model.mesh.getElements(3)
    for element_type, tags_of_type, nodes_of_type in zip(types, element_tags, node_tags):
        order = nastran_order(kind, element_type)
        n = len(nodes_of_type) // len(tags_of_type)
        for e, eid in enumerate(tags_of_type):
            nodes = [int(nodes_of_type[e * n + k]) for k in order]
            getattr(model, f"add_{CARD[kind].lower()}")(int(eid), 7, nodes)
    second_order = stem.endswith("2")
    model.write_bdf(f"{stem}.bdf", size=16 if second_order else 8, enddata=True)
    gmsh.finalize()


for kind in ["tet", "wedge", "hex"]:
    for order in [1, 2]:
        write(f"{kind}{order}", kind)
