"""Binary MSH 4.1 seeds of the reader fuzz test (crates/mshbm/tests/fuzz/mod.rs), in
crates/mshbm/tests/fuzz_corpus/meshes_binary/:

* tiny_tet_le8.msh, tiny_tet_be8.msh, tiny_tet_le4.msh: the one-tetrahedron mesh of
  tests/fuzz_corpus/meshes/tiny_tet.msh written by this script's own writer (Python's
  struct, following the Gmsh reference manual's "MSH file format" section), little-endian
  with 8-byte size_t, big-endian, and 4-byte size_t: all three must read as the ASCII file
  (tests/gmsh_meshes.rs);
* box_tet4_binary.msh: tests/data/gmsh/box_tet4.msh written again by Gmsh as binary.

    python3 -m venv venv && venv/bin/pip install gmsh
    venv/bin/python make_binary_seeds.py
"""
import os
import struct

import gmsh

HERE = os.path.dirname(os.path.abspath(__file__))
TESTS = os.path.join(HERE, "..", "..", "crates", "mshbm", "tests")
OUT = os.path.join(TESTS, "fuzz_corpus", "meshes_binary")

NAMES = [(2, 1, "base"), (3, 2, "body")]
# (dim, tag, box, physical tags, bounding entities)
ENTITIES = [(2, 1, [0, 0, 0, 1, 1, 0], [1], []), (3, 1, [0, 0, 0, 1, 1, 1], [2], [])]
NODES = [(1, [0, 0, 0]), (2, [1, 0, 0]), (3, [0, 1, 0]), (4, [0, 0, 1])]
# (dim, entity, type, [(tag, nodes)])
ELEMENTS = [(2, 1, 2, [(1, [1, 2, 3])]), (3, 1, 4, [(2, [1, 2, 3, 4])])]


def tiny_tet(order, size):
    st = "Q" if size == 8 else "I"
    p = lambda fmt, *v: struct.pack(order + fmt, *v)
    out = bytearray(b"$MeshFormat\n4.1 1 %d\n" % size)
    out += p("i", 1) + b"\n$EndMeshFormat\n"
    out += b"$PhysicalNames\n%d\n" % len(NAMES)
    for d, t, n in NAMES:
        out += b'%d %d "%s"\n' % (d, t, n.encode())
    out += b"$EndPhysicalNames\n$Entities\n"
    out += p(st * 4, 0, 0, 1, 1)
    for d, tag, box, phys, bound in ENTITIES:
        out += p("i", tag) + p("d" * 6, *box) + p(st, len(phys)) + p("i" * len(phys), *phys)
        out += p(st, len(bound)) + p("i" * len(bound), *bound)
    out += b"\n$EndEntities\n$Nodes\n"
    out += p(st * 4, 1, len(NODES), 1, len(NODES))
    out += p("iii", 3, 1, 0) + p(st, len(NODES))
    for t, _ in NODES:
        out += p(st, t)
    for _, x in NODES:
        out += p("ddd", *x)
    out += b"\n$EndNodes\n$Elements\n"
    out += p(st * 4, len(ELEMENTS), 2, 1, 2)
    for d, e, t, els in ELEMENTS:
        out += p("iii", d, e, t) + p(st, len(els))
        for tag, nodes in els:
            out += p(st * (1 + len(nodes)), tag, *nodes)
    out += b"\n$EndElements\n"
    return bytes(out)


os.makedirs(OUT, exist_ok=True)
for name, order, size in [("le8", "<", 8), ("be8", ">", 8), ("le4", "<", 4)]:
    with open(os.path.join(OUT, f"tiny_tet_{name}.msh"), "wb") as f:
        f.write(tiny_tet(order, size))

gmsh.initialize()
gmsh.option.setNumber("General.Terminal", 0)
gmsh.open(os.path.join(TESTS, "data", "gmsh", "box_tet4.msh"))
gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
gmsh.option.setNumber("Mesh.Binary", 1)
gmsh.write(os.path.join(OUT, "box_tet4_binary.msh"))
gmsh.finalize()
