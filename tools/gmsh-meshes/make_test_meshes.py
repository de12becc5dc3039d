"""Small Gmsh meshes for crates/mshbm/tests/gmsh_meshes.rs, with reference facts from the
Gmsh API itself and eigenfrequencies from scikit-fem. Writes, in
crates/mshbm/tests/data/gmsh/:

* box_tet10.msh: the box [0, 3] x [0, 1] x [0, 1] in quadratic tetrahedra (mesh size 0.5),
  physical groups "body" (the volume), "root" (x = 0), "tip" (x = 3), "top" (z = 1);
* box_tet4.msh: the same box in linear tetrahedra;
* plate_tri6.msh: the plate [0, 4] x [0, 1] with a hole of radius 0.25 at (2, 0.5), in
  6-node triangles, groups "plate", "left" (x = 0), "right" (x = 4), "hole";
* reference.json: for each file the node and cell counts, per group the number of nodes and
  the sum of their coordinates (all from the Gmsh API), and for the boxes the ten lowest
  eigenfrequencies with "root" clamped from scikit-fem on the same nodes and tetrahedra
  (E = 2.1e5, nu = 0.3, rho = 7.85e-9; the box's faces are flat, so its Tet10 cells are
  straight-sided, as scikit-fem's P2 element on the Tet4 cells).

    python3 -m venv venv && venv/bin/pip install gmsh -r ../fe-reference/requirements.txt
    venv/bin/python make_test_meshes.py
"""
import json
import os

import gmsh
import numpy as np
import scipy.linalg

HERE = os.path.dirname(os.path.abspath(__file__))
OUT = os.path.join(HERE, "..", "..", "crates", "mshbm", "tests", "data", "gmsh")
E, NU, RHO = 2.1e5, 0.3, 7.85e-9


def facts():
    """Counts and group facts of the current model, from the Gmsh API."""
    tags, x, _ = gmsh.model.mesh.getNodes()
    x = x.reshape(-1, 3)
    where = {t: i for i, t in enumerate(tags)}
    dim = max(d for d, _ in gmsh.model.getEntities())
    cells = 0
    solid_nodes = set()
    for _, tag in gmsh.model.getEntities(dim):
        types, _, nodes = gmsh.model.mesh.getElements(dim, tag)
        for t, n in zip(types, nodes):
            per = gmsh.model.mesh.getElementProperties(t)[3]
            cells += len(n) // per
            solid_nodes.update(int(v) for v in n)
    groups = {}
    for d, t in gmsh.model.getPhysicalGroups():
        name = gmsh.model.getPhysicalName(d, t)
        nodes = set()
        for e in gmsh.model.getEntitiesForPhysicalGroup(d, t):
            for n in gmsh.model.mesh.getElements(d, e)[2]:
                nodes.update(int(v) for v in n)
        coords = x[[where[n] for n in nodes]]
        groups[name] = {"nodes": len(nodes), "sum": coords.sum(axis=0)[:dim].tolist()}
    return {"dimension": dim, "nodes": len(solid_nodes), "cells": cells, "groups": groups}


def box(order):
    gmsh.model.add(f"box{order}")
    v = gmsh.model.occ.addBox(0, 0, 0, 3, 1, 1)
    gmsh.model.occ.synchronize()
    gmsh.model.addPhysicalGroup(3, [v], name="body")
    faces = {}
    for _, s in gmsh.model.getEntities(2):
        c = gmsh.model.occ.getCenterOfMass(2, s)
        for name, axis, value in [("root", 0, 0.0), ("tip", 0, 3.0), ("top", 2, 1.0)]:
            if abs(c[axis] - value) < 1e-9:
                faces[name] = s
    for name, s in faces.items():
        gmsh.model.addPhysicalGroup(2, [s], name=name)
    gmsh.option.setNumber("Mesh.MeshSizeMax", 0.5)
    gmsh.option.setNumber("Mesh.MeshSizeMin", 0.5)
    gmsh.model.mesh.generate(3)
    if order == 2:
        gmsh.model.mesh.setOrder(2)


def plate():
    gmsh.model.add("plate")
    r = gmsh.model.occ.addRectangle(0, 0, 0, 4, 1)
    h = gmsh.model.occ.addDisk(2, 0.5, 0, 0.25, 0.25)
    out, _ = gmsh.model.occ.cut([(2, r)], [(2, h)])
    gmsh.model.occ.synchronize()
    gmsh.model.addPhysicalGroup(2, [out[0][1]], name="plate")
    groups = {"left": [], "right": [], "hole": []}
    for _, c in gmsh.model.getEntities(1):
        m = gmsh.model.occ.getCenterOfMass(1, c)
        if abs(m[0]) < 1e-9:
            groups["left"].append(c)
        elif abs(m[0] - 4) < 1e-9:
            groups["right"].append(c)
        elif abs(m[0] - 2) < 1e-9 and abs(m[1] - 0.5) < 1e-9:
            groups["hole"].append(c)
    for name, c in groups.items():
        gmsh.model.addPhysicalGroup(1, c, name=name)
    gmsh.option.setNumber("Mesh.MeshSizeMax", 0.2)
    gmsh.model.mesh.generate(2)
    gmsh.model.mesh.setOrder(2)


def skfem_frequencies(quadratic, count=10):
    """Eigenfrequencies of the current box mesh (its Tet4 vertices) by scikit-fem."""
    from skfem import Basis, BilinearForm, ElementTetP1, ElementTetP2, ElementVector, MeshTet
    from skfem.helpers import dot
    from skfem.models.elasticity import lame_parameters, linear_elasticity

    tags, x, _ = gmsh.model.mesh.getNodes()
    where = {t: i for i, t in enumerate(tags)}
    types, _, nodes = gmsh.model.mesh.getElements(3)
    per = gmsh.model.mesh.getElementProperties(types[0])[3]
    t = np.array([where[n] for n in nodes[0]]).reshape(-1, per)[:, :4]
    used = np.unique(t)
    renumber = -np.ones(len(tags), dtype=int)
    renumber[used] = np.arange(len(used))
    p = x.reshape(-1, 3)[used].T
    mesh = MeshTet(p, renumber[t].T)
    element = ElementTetP2() if quadratic else ElementTetP1()
    basis = Basis(mesh, ElementVector(element), intorder=4 if quadratic else 2)
    lam, mu = lame_parameters(E, NU)
    K = linear_elasticity(lam, mu).assemble(basis)
    M = BilinearForm(lambda u, v, w: RHO * dot(u, v)).assemble(basis)
    clamped = basis.get_dofs(lambda x: np.isclose(x[0], 0.0)).all()
    free = np.setdiff1d(np.arange(basis.N), clamped)
    w2 = scipy.linalg.eigh(K[free][:, free].toarray(), M[free][:, free].toarray(),
                           eigvals_only=True, subset_by_index=[0, count - 1])
    return (np.sqrt(w2) / (2 * np.pi)).tolist()


gmsh.initialize()
gmsh.option.setNumber("General.Terminal", 0)
gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
gmsh.option.setNumber("Mesh.Binary", 0)
reference = {"source": f"gmsh {gmsh.__version__}, tools/gmsh-meshes/make_test_meshes.py"}
for name, make, args, quadratic in [("box_tet10", box, (2,), True), ("box_tet4", box, (1,), False),
                                    ("plate_tri6", plate, (), None)]:
    make(*args)
    gmsh.write(os.path.join(OUT, name + ".msh"))
    reference[name] = facts()
    if quadratic is not None:
        reference[name]["frequencies_hz"] = skfem_frequencies(quadratic)
    gmsh.model.remove()
gmsh.finalize()
with open(os.path.join(OUT, "reference.json"), "w") as f:
    json.dump(reference, f, indent=1)
print(json.dumps(reference, indent=1)[:3000])
