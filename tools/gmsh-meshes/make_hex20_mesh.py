"""A 20-node hexahedral (serendipity) mesh from Gmsh for crates/mshbm/tests/hex20_elements.rs
and tests/abaqus_meshes.rs, with scikit-fem's eigenfrequencies on the same mesh. Writes

* crates/mshbm/tests/data/gmsh/box_hex20.msh: the box [0, 3] x [0, 1] x [0, 0.8], a
  transfinite grid of 6 x 3 x 2 hexahedra made quadratic with Mesh.SecondOrderIncomplete
  (20-node, Gmsh type 17), physical groups "body", "root" (x = 0), "tip" (x = 3),
  "top" (z = 0.8);
* crates/mshbm/tests/data/abaqus/box_hex20.inp: Gmsh's own Abaqus export of that mesh
  (C3D20, element sets and node sets);
* crates/mshbm/tests/data/gmsh/hex20_reference.json: node and cell counts and the ten lowest
  eigenfrequencies with "root" clamped from scikit-fem's ElementHexS2 (its 20-node
  serendipity element, independent shape functions and node order) on the Hex8 cells of
  the same corners (the edges are straight, so the mid-side nodes are the edges' middles),
  E = 2.1e5, nu = 0.3, rho = 7.85e-9, quadrature exact for the mass (intorder 6).

    python3 -m venv venv && venv/bin/pip install gmsh -r ../fe-reference/requirements.txt
    venv/bin/python make_hex20_mesh.py
"""
import json
import os

import gmsh
import numpy as np
import scipy.linalg

HERE = os.path.dirname(os.path.abspath(__file__))
DATA = os.path.join(HERE, "..", "..", "crates", "mshbm", "tests", "data")
E, NU, RHO = 2.1e5, 0.3, 7.85e-9
# skfem's MeshHex vertex order (000, 001, 010, 100, 011, 101, 110, 111) from VTK's
TO_SKFEM = [0, 4, 3, 1, 7, 5, 2, 6]


def skfem_frequencies(count=10):
    from skfem import Basis, BilinearForm, ElementHexS2, ElementVector, MeshHex
    from skfem.helpers import dot
    from skfem.models.elasticity import lame_parameters, linear_elasticity

    tags, x, _ = gmsh.model.mesh.getNodes()
    where = {t: i for i, t in enumerate(tags)}
    types, _, nodes = gmsh.model.mesh.getElements(3)
    assert list(types) == [17], types
    t = np.array([where[n] for n in nodes[0]]).reshape(-1, 20)[:, :8]  # corners, VTK order
    used = np.unique(t)
    renumber = -np.ones(len(tags), dtype=int)
    renumber[used] = np.arange(len(used))
    p = x.reshape(-1, 3)[used].T
    mesh = MeshHex(p, renumber[t][:, TO_SKFEM].T)
    basis = Basis(mesh, ElementVector(ElementHexS2()), intorder=6)
    lam, mu = lame_parameters(E, NU)
    K = linear_elasticity(lam, mu).assemble(basis)
    M = BilinearForm(lambda u, v, w: RHO * dot(u, v)).assemble(basis)
    clamped = basis.get_dofs(lambda x: np.isclose(x[0], 0.0)).all()
    free = np.setdiff1d(np.arange(basis.N), clamped)
    w2 = scipy.linalg.eigh(K[free][:, free].toarray(), M[free][:, free].toarray(),
                           eigvals_only=True, subset_by_index=[0, count - 1])
    return {"dofs": int(basis.N), "sum_m": float(M.sum()),
            "frequencies_hz": (np.sqrt(w2) / (2 * np.pi)).tolist()}


gmsh.initialize()
gmsh.option.setNumber("General.Terminal", 0)
gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
gmsh.option.setNumber("Mesh.Binary", 0)
gmsh.model.add("box_hex20")
v = gmsh.model.occ.addBox(0, 0, 0, 3, 1, 0.8)
gmsh.model.occ.synchronize()
gmsh.model.addPhysicalGroup(3, [v], name="body")
for name, axis, value in [("root", 0, 0.0), ("tip", 0, 3.0), ("top", 2, 0.8)]:
    for _, s in gmsh.model.getEntities(2):
        if abs(gmsh.model.occ.getCenterOfMass(2, s)[axis] - value) < 1e-9:
            gmsh.model.addPhysicalGroup(2, [s], name=name)
for _, c in gmsh.model.getEntities(1):
    lo = gmsh.model.getBoundingBox(1, c)
    length = max(lo[3] - lo[0], lo[4] - lo[1], lo[5] - lo[2])
    cells = {3.0: 6, 1.0: 3, 0.8: 2}[round(length, 6)]
    gmsh.model.mesh.setTransfiniteCurve(c, cells + 1)
for _, s in gmsh.model.getEntities(2):
    gmsh.model.mesh.setTransfiniteSurface(s)
    gmsh.model.mesh.setRecombine(2, s)
gmsh.model.mesh.setTransfiniteVolume(v)
gmsh.option.setNumber("Mesh.SecondOrderIncomplete", 1)
gmsh.model.mesh.generate(3)
gmsh.model.mesh.setOrder(2)
gmsh.write(os.path.join(DATA, "gmsh", "box_hex20.msh"))
os.chdir(os.path.join(DATA, "abaqus"))  # the heading Gmsh writes is the file's name
gmsh.option.setNumber("Mesh.SaveGroupsOfNodes", 1)
gmsh.write("box_hex20.inp")
reference = {"source": f"gmsh {gmsh.__version__}, scikit-fem "
             + __import__("skfem").__version__ + ", tools/gmsh-meshes/make_hex20_mesh.py"}
tags = set()
types, _, nodes = gmsh.model.mesh.getElements(3)
tags.update(int(n) for n in nodes[0])
reference["nodes"] = len(tags)
reference["cells"] = len(nodes[0]) // 20
reference.update(skfem_frequencies())
gmsh.finalize()
with open(os.path.join(DATA, "gmsh", "hex20_reference.json"), "w") as f:
    json.dump(reference, f, indent=1)
print(json.dumps(reference, indent=1))
