"""The bracket of examples/bracket_gmsh: an L-shaped steel angle bracket bolted down
through a hole in its base, whose upright arm strikes a rigid stop. Writes bracket.msh
(MSH 4.1 ASCII, quadratic tetrahedra) beside this script.

    python3 -m venv venv && venv/bin/pip install gmsh && venv/bin/python make_mesh.py

Geometry [mm]: base 40 x 30 x 4 (x, y, z) with a bolt hole of radius 4 at (26, 15), upright
arm 4 x 30 x 36 on the base at x in [0, 4], so the bracket stands 40 high; a fillet of
radius 3 where the arm meets the base. Physical groups: "bracket" (the volume), "bolt" (the
hole's surface, clamped), "top" (the arm's top face z = 40, loaded), "stop" (the arm's outer
face x = 0 above z = 30, which meets the stop).
"""
import os

import gmsh

HERE = os.path.dirname(os.path.abspath(__file__))

gmsh.initialize()
gmsh.option.setNumber("General.Terminal", 0)
gmsh.model.add("bracket")
occ = gmsh.model.occ
base = occ.addBox(0, 0, 0, 40, 30, 4)
arm = occ.addBox(0, 0, 0, 4, 30, 40)
# the stop's patch: the outer face above z = 30 is a face of its own
band = occ.addBox(-1, -1, 30, 1, 32, 11)
fillet = occ.addBox(4, 0, 4, 3, 30, 3)
round_off = occ.addCylinder(7, 0, 7, 0, 30, 0, 3)
bracket, _ = occ.fuse([(3, base)], [(3, arm)])
corner, _ = occ.cut([(3, fillet)], [(3, round_off)])
bracket, _ = occ.fuse(bracket, corner)
hole = occ.addCylinder(26, 15, -1, 0, 0, 6, 4)
bracket, _ = occ.cut(bracket, [(3, hole)])
# split the outer face at z = 30 (fragment with a thin slab outside the body, then drop it)
out, _ = occ.fragment(bracket, [(3, band)])
occ.synchronize()
volumes = [t for d, t in gmsh.model.getEntities(3)]
keep = [v for v in volumes if occ.getCenterOfMass(3, v)[0] > 0]
occ.remove([(3, v) for v in volumes if v not in keep], recursive=True)
occ.synchronize()
gmsh.model.addPhysicalGroup(3, keep, name="bracket")
groups = {"bolt": [], "top": [], "stop": []}
boundary = gmsh.model.getBoundary([(3, v) for v in keep], combined=True, oriented=False)
for _, s in boundary:
    x, y, z = occ.getCenterOfMass(2, s)
    box = gmsh.model.getBoundingBox(2, s)
    if abs(x - 26) < 1e-6 and abs(y - 15) < 1e-6 and abs(z - 2) < 1e-6:
        groups["bolt"].append(s)
    elif abs(box[2] - 40) < 1e-6 and abs(box[5] - 40) < 1e-6:
        groups["top"].append(s)
    elif abs(box[0]) < 1e-6 and abs(box[3]) < 1e-6 and box[2] > 30 - 1e-6:
        groups["stop"].append(s)
for name, surfaces in groups.items():
    assert surfaces, name
    gmsh.model.addPhysicalGroup(2, surfaces, name=name)
gmsh.option.setNumber("Mesh.MeshSizeMax", 2.5)
gmsh.option.setNumber("Mesh.MeshSizeMin", 1.0)
gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
gmsh.option.setNumber("Mesh.Binary", 0)
gmsh.model.mesh.generate(3)
gmsh.model.mesh.setOrder(2)
gmsh.write(os.path.join(HERE, "bracket.msh"))
tags, _, _ = gmsh.model.mesh.getNodes()
print(f"{len(tags)} nodes")
for name in groups:
    t = [g for d, g in gmsh.model.getPhysicalGroups() if gmsh.model.getPhysicalName(d, g) == name][0]
    print(name, len(gmsh.model.mesh.getNodesForPhysicalGroup(2, t)[0]), "nodes")
gmsh.finalize()
