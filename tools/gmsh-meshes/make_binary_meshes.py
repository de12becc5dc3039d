"""Binary twins of the ASCII test meshes, for crates/mshbm/tests/gmsh_meshes.rs: each file
of crates/mshbm/tests/data/gmsh/ listed below is opened by Gmsh and written again as binary
MSH 4.1 (Mesh.Binary = 1) next to it, `<name>_binary.msh`. The nodes, elements and
physical groups are Gmsh's own, so the twin must give the same model as the ASCII file.

    python3 -m venv venv && venv/bin/pip install gmsh
    venv/bin/python make_binary_meshes.py
"""
import os

import gmsh

HERE = os.path.dirname(os.path.abspath(__file__))
DATA = os.path.join(HERE, "..", "..", "crates", "mshbm", "tests", "data", "gmsh")

gmsh.initialize()
gmsh.option.setNumber("General.Terminal", 0)
for name in ["box_tet10", "plate_tri6", "box_hex20"]:
    gmsh.clear()
    gmsh.open(os.path.join(DATA, name + ".msh"))
    gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
    gmsh.option.setNumber("Mesh.Binary", 1)
    gmsh.option.setNumber("Mesh.SaveAll", 0)
    gmsh.write(os.path.join(DATA, name + "_binary.msh"))
gmsh.finalize()
