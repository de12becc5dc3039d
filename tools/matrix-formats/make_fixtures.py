"""Harwell-Boeing fixtures for crates/mshbm/tests/matrix_formats.rs, written by SciPy's
own writer (scipy.io.hb_write), independent of mshbm's reader. Writes, in
crates/mshbm/tests/data/matrix_formats/:

* bar_stiffness.rua: the stiffness of examples/bar_matrices (101 DOFs) as SciPy writes it,
  real unsymmetric assembled (RUA; SciPy writes no other type);
* bar_mass.rsa: the lower triangle of the bar's mass, written by SciPy as RUA and relabelled
  RSA (real symmetric assembled): an RSA file stores exactly that lower triangle, column
  by column, so only the type code in the header changes.

The Matrix Market twins are examples/bar_matrices/stiffness.mtx and mass.mtx.

    python3 -m venv venv && venv/bin/pip install scipy==1.17.1
    venv/bin/python make_fixtures.py
"""
import os

import scipy.io
import scipy.sparse

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.join(HERE, "..", "..")
BAR = os.path.join(ROOT, "examples", "bar_matrices")
OUT = os.path.join(ROOT, "crates", "mshbm", "tests", "data", "matrix_formats")

os.makedirs(OUT, exist_ok=True)
k = scipy.sparse.csc_matrix(scipy.io.mmread(os.path.join(BAR, "stiffness.mtx")))
m = scipy.sparse.csc_matrix(scipy.io.mmread(os.path.join(BAR, "mass.mtx")))

scipy.io.hb_write(os.path.join(OUT, "bar_stiffness.rua"), k)
# the round trip through SciPy's own reader is exact
back = scipy.io.hb_read(os.path.join(OUT, "bar_stiffness.rua"))
assert (back != k).nnz == 0

lower = os.path.join(OUT, "bar_mass.rsa")
scipy.io.hb_write(lower, scipy.sparse.csc_matrix(scipy.sparse.tril(m)))
with open(lower) as f:
    lines = f.read().split("\n")
assert lines[2].startswith("RUA")
lines[2] = "RSA" + lines[2][3:]
with open(lower, "w") as f:
    f.write("\n".join(lines))
print("written", OUT)
