#!/usr/bin/python3
# The independent reader of the Gmsh tests (Testing/Algorithms/IO/GmshIOTest.cpp): meshio, from
# Debian's python3-meshio, reads a .msh file and prints what it found, one item per line:
#   points N               then N lines "p x y z" (Python's repr: the shortest exact text)
#   t a b c d tag          one line per 4-node tetrahedron (0-based point indices as meshio
#                          numbers them, and the physical tag, or 0 without one)
#   name dim tag text      one line per physical name
# Run with Debian's /usr/bin/python3 (the one python3-meshio installs into).
import sys

import meshio

m = meshio.read(sys.argv[1])
print("points", len(m.points))
for p in m.points:
    print("p %r %r %r" % (float(p[0]), float(p[1]), float(p[2])))
physical = m.cell_data.get("gmsh:physical")
for i, block in enumerate(m.cells):
    if block.type != "tetra":
        continue
    tags = physical[i] if physical is not None else [0] * len(block.data)
    for cell, tag in zip(block.data, tags):
        print("t %d %d %d %d %d" % (cell[0], cell[1], cell[2], cell[3], tag))
for name, (tag, dim) in m.field_data.items():
    print("name %d %d %s" % (dim, tag, name))
