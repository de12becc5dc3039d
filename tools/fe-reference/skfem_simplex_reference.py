"""Reference eigenfrequencies of small simplex meshes (linear and quadratic triangles and
tetrahedra) from scikit-fem, an independent finite-element code, for
crates/mshbm/tests/simplex_elements.rs. Writes
crates/mshbm/tests/data/skfem_simplex_reference.json with each linear mesh (nodes and
cells, so that mshbm assembles the same mesh; the quadratic mesh adds a node at the middle
of every edge) and the results.

    pip install -r requirements.txt && python3 skfem_simplex_reference.py

Meshes (clamped on x = 0, consistent mass, quadrature exact for the mass as mshbm's:
order 2 for linear, 4 for quadratic elements):
* 2D: the rectangle 3 × 1.5 cut into 6 × 3 squares, each into two triangles (scikit-fem's
  MeshTri.init_tensor), plane stress and plane strain, P1 and P2;
* 3D: the box 3 × 1 × 1 in 3 × 2 × 2 cubes, each cut into tetrahedra by scikit-fem's
  MeshTet.init_tensor, P1 and P2.
E = 2.1e5, nu = 0.3, rho = 7.85e-9 (mm, N, t); thickness 1 in 2D.
"""
import json
import os

import numpy as np
import scipy.linalg
from skfem import (Basis, BilinearForm, ElementTetP1, ElementTetP2, ElementTriP1,
                   ElementTriP2, ElementVector, MeshTet, MeshTri)
from skfem.helpers import dot
from skfem.models.elasticity import lame_parameters, linear_elasticity

E, NU, RHO = 2.1e5, 0.3, 7.85e-9


@BilinearForm
def mass(u, v, w):
    return RHO * dot(u, v)


def frequencies(mesh, element, intorder, lam, mu, count=10):
    basis = Basis(mesh, ElementVector(element), intorder=intorder)
    K = linear_elasticity(lam, mu).assemble(basis)
    M = mass.assemble(basis)
    clamped = basis.get_dofs(lambda x: np.isclose(x[0], 0.0)).all()
    free = np.setdiff1d(np.arange(basis.N), clamped)
    Kf = K[free][:, free].toarray()
    Mf = M[free][:, free].toarray()
    w2 = scipy.linalg.eigh(Kf, Mf, eigvals_only=True)
    return {
        "frequencies_hz": (np.sqrt(w2[:count]) / (2 * np.pi)).tolist(),
        "trace_k": float(K.diagonal().sum()),
        "trace_m": float(M.diagonal().sum()),
        "sum_m": float(M.sum()),
        "dofs": int(basis.N),
    }


def mesh_of(mesh):
    return {"nodes": mesh.p.T.tolist(), "cells": mesh.t.T.tolist()}


lam, mu = lame_parameters(E, NU)
lam_plane_stress = 2 * lam * mu / (lam + 2 * mu)
tri = MeshTri.init_tensor(np.linspace(0, 3.0, 7), np.linspace(0, 1.5, 4))
tet = MeshTet.init_tensor(np.linspace(0, 3.0, 4), np.linspace(0, 1.0, 3), np.linspace(0, 1.0, 3))
out = {
    "source": "scikit-fem " + __import__("skfem").__version__
    + ", tools/fe-reference/skfem_simplex_reference.py",
    "triangles": mesh_of(tri),
    "tetrahedra": mesh_of(tet),
    "tri3_plane_stress": frequencies(tri, ElementTriP1(), 2, lam_plane_stress, mu),
    "tri3_plane_strain": frequencies(tri, ElementTriP1(), 2, lam, mu),
    "tri6_plane_stress": frequencies(tri, ElementTriP2(), 4, lam_plane_stress, mu),
    "tri6_plane_strain": frequencies(tri, ElementTriP2(), 4, lam, mu),
    "tet4": frequencies(tet, ElementTetP1(), 2, lam, mu),
    "tet10": frequencies(tet, ElementTetP2(), 4, lam, mu),
}
here = os.path.dirname(os.path.abspath(__file__))
path = os.path.join(here, "..", "..", "crates", "mshbm", "tests", "data",
                    "skfem_simplex_reference.json")
with open(path, "w") as f:
    json.dump(out, f, indent=1)
print(json.dumps({k: v for k, v in out.items() if "frequencies_hz" in v}, indent=1))
