"""The Abaqus input files of crates/mshbm/tests/data/abaqus/: Gmsh's own `.inp` export
(gmsh.write) of the committed Gmsh meshes in crates/mshbm/tests/data/gmsh/, for
crates/mshbm/tests/abaqus_meshes.rs (the same mesh read from both files must give the same
model). box_tet10.inp and plate_tri6.inp are written with Gmsh's defaults (element sets
per physical group), box_tet4.inp also with node sets (Mesh.SaveGroupsOfNodes = 1).

    python3 -m venv venv && venv/bin/pip install gmsh
    venv/bin/python export_inp.py
"""
import os

import gmsh

HERE = os.path.dirname(os.path.abspath(__file__))
DATA = os.path.join(HERE, "..", "..", "crates", "mshbm", "tests", "data")

os.chdir(os.path.join(DATA, "abaqus"))  # the heading Gmsh writes is the file's name
gmsh.initialize()
gmsh.option.setNumber("General.Terminal", 0)
for name, nodes in [("box_tet10", 0), ("box_tet4", 1), ("plate_tri6", 0)]:
    gmsh.open(os.path.join(DATA, "gmsh", f"{name}.msh"))
    gmsh.option.setNumber("Mesh.SaveGroupsOfNodes", nodes)
    gmsh.write(f"{name}.inp")
    gmsh.clear()
gmsh.finalize()
