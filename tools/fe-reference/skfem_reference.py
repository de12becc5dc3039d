"""Reference eigenfrequencies of small linear-elastic meshes from scikit-fem, an independent
finite-element code, for crates/mshbm/tests/solid_elements.rs. Writes
crates/mshbm/tests/data/skfem_reference.json.

    pip install -r requirements.txt && python3 skfem_reference.py

Meshes (both clamped on x = 0, consistent mass, full Gauss integration as mshbm):
* 2D: the rectangle 3 × 1.5 in 6 × 3 bilinear quadrilaterals, plane stress and plane strain;
* 3D: the box 3 × 1 × 1 in 3 × 2 × 2 trilinear hexahedra.
E = 2.1e5, nu = 0.3, rho = 7.85e-9 (mm, N, t); thickness 1 in 2D.
"""
import json
import os

import numpy as np
import scipy.linalg
from skfem import Basis, BilinearForm, ElementHex1, ElementQuad1, ElementVector, MeshHex, MeshQuad
from skfem.helpers import dot
from skfem.models.elasticity import lame_parameters, linear_elasticity

E, NU, RHO = 2.1e5, 0.3, 7.85e-9


@BilinearForm
def mass(u, v, w):
    return RHO * dot(u, v)


def frequencies(mesh, element, lam, mu, count=10):
    basis = Basis(mesh, ElementVector(element), intorder=2)
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


lam, mu = lame_parameters(E, NU)
lam_plane_stress = 2 * lam * mu / (lam + 2 * mu)
quad = MeshQuad.init_tensor(np.linspace(0, 3.0, 7), np.linspace(0, 1.5, 4))
hexa = MeshHex.init_tensor(np.linspace(0, 3.0, 4), np.linspace(0, 1.0, 3), np.linspace(0, 1.0, 3))
out = {
    "source": "scikit-fem " + __import__("skfem").__version__ + ", tools/fe-reference/skfem_reference.py",
    "plane_stress": frequencies(quad, ElementQuad1(), lam_plane_stress, mu),
    "plane_strain": frequencies(quad, ElementQuad1(), lam, mu),
    "solid": frequencies(hexa, ElementHex1(), lam, mu),
}
here = os.path.dirname(os.path.abspath(__file__))
path = os.path.join(here, "..", "..", "crates", "mshbm", "tests", "data", "skfem_reference.json")
with open(path, "w") as f:
    json.dump(out, f, indent=1)
print(json.dumps(out, indent=1))
