#!/usr/bin/env python3
"""The element-kind test meshes, written by Gmsh (the `gmsh` Python package, 4.15).

A quarter of an annulus (radii 30 and 50 mm, 10 mm thick) meshed six ways: tetrahedra
(meshed volume), wedges (extruded triangles) and hexahedra (extruded quadrangles), each of
first and second order (`SecondOrderIncomplete`: 20-node hexahedra and 15-node wedges), the
mid-edge nodes of the second-order meshes on the curved faces. Each is written twice by Gmsh:
MSH 4.1 ASCII (`<kind><order>.msh`, with the physical volume `disc` and the physical surface
`bottom`) and Abaqus (`<kind><order>.inp`, volume elements in the element set `disc`). Run
from this folder: `python3 make.py`.
"""

import gmsh


def mesh(kind, order):
    gmsh.initialize()
    gmsh.option.setNumber("General.Terminal", 0)
    gmsh.model.add(f"{kind}{order}")
    occ = gmsh.model.occ
    outer = occ.addDisk(0, 0, 0, 0.05, 0.05)
    inner = occ.addDisk(0, 0, 0, 0.03, 0.03)
    ring, _ = occ.cut([(2, outer)], [(2, inner)])
    box = occ.addRectangle(0, 0, 0, 0.06, 0.06)
    quarter, _ = occ.intersect(ring, [(2, box)])
    occ.synchronize()
    gmsh.option.setNumber("Mesh.MeshSizeMax", 0.01)
    if kind == "tet":
        volume = occ.extrude(quarter, 0, 0, 0.01)
    else:
        if kind == "hex":
            gmsh.option.setNumber("Mesh.RecombineAll", 1)
        volume = occ.extrude(quarter, 0, 0, 0.01, numElements=[2], recombine=True)
    occ.synchronize()
    gmsh.model.addPhysicalGroup(3, [d[1] for d in volume if d[0] == 3], 1, "disc")
    gmsh.model.addPhysicalGroup(2, [d[1] for d in quarter], 2, "bottom")
    gmsh.option.setNumber("Mesh.SecondOrderIncomplete", 1)
    gmsh.model.mesh.generate(3)
    if order == 2:
        gmsh.model.mesh.setOrder(2)
    gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
    gmsh.option.setNumber("Mesh.Binary", 0)
    gmsh.write(f"{kind}{order}.msh")
    # The Abaqus file holds the volume elements only (squeal reads solid elements).
    gmsh.model.removePhysicalGroups([(2, 2)])
    gmsh.write(f"{kind}{order}.inp")
    gmsh.finalize()


for kind in ["tet", "wedge", "hex"]:
    for order in [1, 2]:
        mesh(kind, order)
