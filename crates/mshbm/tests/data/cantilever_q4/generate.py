"""A plane-stress cantilever of bilinear quadrilaterals assembled here with numpy, independently
of mshbm, written as Matrix Market files plus a model file: the test model of
crates/mshbm/tests/solve_start.rs (a stiff contact interface: ten bottom-face nodes near the
tip against a rigid stop below, where Newton from the linear response fails).

    python3 generate.py      # numpy and scipy; rewrites K.mtx, M.mtx, nodes.txt, model.toml
"""
import numpy as np
import scipy.io
import scipy.sparse as sp

L, h, nx, ny = 100.0, 10.0, 40, 4          # mm
E, nu, rho, t = 2.1e5, 0.3, 7.85e-9, 1.0   # MPa, -, t/mm^3, mm
gap, force = 0.05, -1.0                    # mm, N (downward, at the tip's mid-height node)
xs, ys = np.linspace(0, L, nx + 1), np.linspace(0, h, ny + 1)
nodes = np.array([[x, y] for y in ys for x in xs])
idx = lambda i, j: j * (nx + 1) + i
D = E / (1 - nu**2) * np.array([[1, nu, 0], [nu, 1, 0], [0, 0, (1 - nu) / 2]])
g = 1 / np.sqrt(3)
Ke, Me = np.zeros((8, 8)), np.zeros((8, 8))
X = np.array([[0, 0], [L / nx, 0], [L / nx, h / ny], [0, h / ny]])
for xi, eta in [(-g, -g), (g, -g), (g, g), (-g, g)]:
    dN = 0.25 * np.array([[-(1 - eta), (1 - eta), (1 + eta), -(1 + eta)],
                          [-(1 - xi), -(1 + xi), (1 + xi), (1 - xi)]])
    N = 0.25 * np.array([(1 - xi) * (1 - eta), (1 + xi) * (1 - eta), (1 + xi) * (1 + eta), (1 - xi) * (1 + eta)])
    J = dN @ X
    dx = np.linalg.solve(J, dN)
    B = np.zeros((3, 8))
    B[0, 0::2], B[1, 1::2], B[2, 0::2], B[2, 1::2] = dx[0], dx[1], dx[1], dx[0]
    Nm = np.zeros((2, 8))
    Nm[0, 0::2], Nm[1, 1::2] = N, N
    Ke += B.T @ D @ B * np.linalg.det(J) * t
    Me += rho * t * Nm.T @ Nm * np.linalg.det(J)
rows, cols, kv, mv = [], [], [], []
for j in range(ny):
    for i in range(nx):
        d = np.array([[2 * n, 2 * n + 1] for n in (idx(i, j), idx(i + 1, j), idx(i + 1, j + 1), idx(i, j + 1))]).ravel()
        for a in range(8):
            for b in range(8):
                rows.append(d[a]); cols.append(d[b]); kv.append(Ke[a, b]); mv.append(Me[a, b])
n = 2 * len(nodes)
for name, v in (("K.mtx", kv), ("M.mtx", mv)):
    scipy.io.mmwrite(name, sp.coo_matrix((v, (rows, cols)), shape=(n, n)).tocsr().tocoo(), precision=17, symmetry="symmetric")
np.savetxt("nodes.txt", nodes, fmt="%.17g")
clamped = [d for j in range(ny + 1) for d in (2 * idx(0, j), 2 * idx(0, j) + 1)]
stop = [i for i in range(nx + 1) if xs[i] >= L - 22.5]
with open("model.toml", "w") as f:
    f.write('# written by generate.py\nkind = "matrices"\nname = "Q4 cantilever on a stop near the tip"\n')
    f.write('[matrices]\nmass = "M.mtx"\nstiffness = "K.mtx"\n')
    f.write('[mesh]\ndofs_per_node = 2\ncoordinates = "nodes.txt"\ndirichlet = %s\n' % clamped)
    for p in stop:
        f.write('[[contacts]]\ndofs = [%d]\nw = [1.0]\ngap = %r\n' % (2 * p + 1, gap))
    f.write('[load]\nharmonic = [[%d, %r]]\n[damping]\nfirst_mode_ratio = 0.01\n' % (2 * idx(nx, ny // 2) + 1, force))
