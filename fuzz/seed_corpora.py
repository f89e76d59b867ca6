#!/usr/bin/env python3
"""Writes the seed corpora of the fuzz targets into fuzz/corpus/<target>/.

Seeds: the small files of tests/data (malformed readers' cases, the golden .mlz files)
plus small hand-made valid files of every format and variant (written here, so the
seeds do not depend on a meshlap build). Only the standard library; run from anywhere:

    python3 fuzz/seed_corpora.py

The committed, minimised corpora live in tests/data/fuzz/<target>/ (see RELIABILITY.md);
they are added to the seeds too, so a new run starts where the last one stopped.
"""

import pathlib
import shutil
import struct

ROOT = pathlib.Path(__file__).resolve().parent.parent
DATA = ROOT / "tests" / "data"
OUT = ROOT / "fuzz" / "corpus"

# A tetrahedron: vertices and faces.
V = [(0.0, 0.0, 0.0), (1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)]
F = [(0, 2, 1), (0, 1, 3), (0, 3, 2), (1, 2, 3)]


def obj_seeds():
    tet = "".join(f"v {x} {y} {z}\n" for x, y, z in V) + "".join(
        f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in F
    )
    quad = (
        "# a quad and a triangle, with texture and normal indices\n"
        "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0.5 0.5 1e-3\n"
        "vt 0 0\nvn 0 0 1\n"
        "f 1/1/1 2/1/1 3/1/1 4/1/1\nf -1//1 -2//1 -3//1\n"
        "g part\nusemtl m\ns off\n"
    )
    return {"tet.obj": tet, "quad_negative.obj": quad}


def off_seeds():
    tet = "OFF\n4 4 6\n" + "".join(f"{x} {y} {z}\n" for x, y, z in V) + "".join(
        f"3 {a} {b} {c}\n" for a, b, c in F
    )
    coff = (
        "COFF # coloured\n5 2 0\n"
        "0 0 0 255 0 0 255\n1 0 0 0 255 0 255\n1 1 0 0 0 255 255\n"
        "0 1 0 9 9 9 255\n0.5 0.5 1 1 1 1 255\n"
        "4 0 1 2 3\n3 0 1 4\n"
    )
    split = "OFF\n# counts on their own line\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"
    return {"tet.off": tet, "coff_quad.off": coff, "split_header.off": split}


def ply_ascii_seeds():
    head = "ply\nformat ascii 1.0\ncomment tetrahedron\nelement vertex 4\n"
    head += "property float x\nproperty float y\nproperty float z\nproperty uchar red\n"
    tet = head + "element face 4\nproperty list uchar int vertex_indices\nend_header\n"
    tet += "".join(f"{x} {y} {z} 7\n" for x, y, z in V)
    tet += "".join(f"3 {a} {b} {c}\n" for a, b, c in F)
    strips = head.replace("comment tetrahedron", "comment strips")
    strips += "element tristrips 1\nproperty list int int vertex_indices\n"
    strips += "element edge 1\nproperty int vertex1\nproperty int vertex2\nend_header\n"
    strips += "".join(f"{x} {y} {z} 1\n" for x, y, z in V)
    strips += "7 0 1 2 3 -1 3 0\n0 1\n"
    return {"tet_ascii.ply": tet, "tristrips_ascii.ply": strips}


def ply_binary_file(order):
    fmt = "<" if order == "binary_little_endian" else ">"
    head = (
        f"ply\nformat {order} 1.0\nelement vertex 4\nproperty double x\n"
        "property double y\nproperty double z\nelement face 4\n"
        "property list uchar uint vertex_indices\nend_header\n"
    ).encode()
    body = b"".join(struct.pack(fmt + "3d", *p) for p in V)
    body += b"".join(struct.pack(fmt + "B3I", 3, *f) for f in F)
    return head + body


def ply_binary_seeds():
    # Mode byte: even = the rest is the whole file (see fuzz/src/entry.rs).
    seeds = {
        "raw_le.bin": b"\x00" + ply_binary_file("binary_little_endian"),
        "raw_be.bin": b"\x02" + ply_binary_file("binary_big_endian"),
    }
    # Mode byte odd: generated header. Bits: 1 big-endian, 2..4 coordinate type
    # (6 = float, 7 = double); byte 1: count type (1 = uchar) | index type << 3
    # (4 = int); u16 vertex and face counts; then the body.
    for name, mode, coord in [("gen_float_le.bin", 0b1 | (6 << 2), "<3f"),
                              ("gen_double_be.bin", 0b11 | (7 << 2), ">3d")]:
        fmt = coord[0]
        body = b"".join(struct.pack(coord, *p) for p in V)
        body += b"".join(struct.pack(fmt + "B3i", 3, *f) for f in F)
        seeds[name] = bytes([mode, 1 | (4 << 3)]) + struct.pack("<HH", 4, 4) + body
    return seeds


def obj_variants_seeds():
    # First byte: the smallest chunk, 1 + byte % 64 (see fuzz/src/entry.rs).
    return {f"chunk{1 + b % 64}_{name}": bytes([b]) + content.encode()
            for b, (name, content) in zip([0, 6, 63], obj_seeds().items())}


def ply_variants_seeds():
    # The files of ply_binary; the mode byte's top three bits set the blocks, 1 + bits.
    seeds = {}
    for k, (name, content) in enumerate(sorted(ply_binary_seeds().items())):
        seeds[f"blocks{1 + k % 8}_{name}"] = bytes([content[0] | (k % 8) << 5]) + content[1:]
    return seeds


def stl_ascii_seeds():
    out = "solid tet\n"
    for f in F:
        out += " facet normal 0 0 0\n  outer loop\n"
        out += "".join("   vertex {} {} {}\n".format(*V[i]) for i in f)
        out += "  endloop\n endfacet\n"
    return {"tet_ascii.stl": out + "endsolid tet\n"}


def stl_records():
    return b"".join(
        struct.pack("<12fH", 0, 0, 0, *V[f[0]], *V[f[1]], *V[f[2]], 0) for f in F
    )


def stl_binary_seeds():
    whole = b"solid but binary".ljust(80, b" ") + struct.pack("<I", len(F)) + stl_records()
    # Mode 0 (mod 3): the whole file; mode 1: records only, header generated.
    return {"raw.bin": b"\x00" + whole, "records.bin": b"\x01" + stl_records()}


def mtx_seeds():
    general = (
        "%%MatrixMarket matrix coordinate real general\n% comment\n3 3 5\n"
        "1 1 2.0\n2 1 -1\n1 2 -1\n2 2 1e-3\n3 3 0.5\n"
    )
    sym = "%%MatrixMarket matrix coordinate real symmetric\n2 2 2\n1 1 1.5\n2 1 -0.25\n"
    return {"general.mtx": general, "symmetric.mtx": sym}


def npy_file(descr, shape, data, version=1, fortran=False):
    d = "{'descr': '%s', 'fortran_order': %s, 'shape': %s, }" % (
        descr, "True" if fortran else "False", shape)
    hlen = 4 if version > 1 else 2
    pad = (64 - (6 + 2 + hlen + len(d) + 1) % 64) % 64
    header = (d + " " * pad + "\n").encode()
    size = struct.pack("<I" if version > 1 else "<H", len(header))
    return b"\x93NUMPY" + bytes([version, 0]) + size + header + data


def npy_seeds():
    return {
        "f8_fortran.npy": npy_file("<f8", "(2, 2)", struct.pack("<4d", 1, 2, 3, 4), fortran=True),
        "f4_c.npy": npy_file("<f4", "(2, 3)", struct.pack("<6f", *range(6))),
        "i4_1d.npy": npy_file("<i4", "(3,)", struct.pack("<3i", 7, -8, 9)),
        "u1_v2.npy": npy_file("|u1", "(2,)", b"\x01\x02", version=2),
        "be_f8.npy": npy_file(">f8", "(1, 1)", struct.pack(">d", -2.5)),
    }


def open_seeds():
    """Face lists for the `open` target: [options byte, vertex count − 1, faces …]."""
    tet = [(0, 2, 1), (0, 1, 3), (1, 2, 3), (0, 3, 2)]
    octa = [(0, 2, 4), (2, 1, 4), (1, 3, 4), (3, 0, 4), (2, 0, 5), (1, 2, 5), (3, 1, 5), (0, 3, 5)]

    def unit(bits, n, faces):
        return bytes([bits, n - 1] + [v for f in faces for v in f])

    return {
        "tet.bin": unit(7, 4, tet),
        "tet_dup_same.bin": unit(7, 4, tet + [tet[1]]),
        "tet_dup_reversed.bin": unit(2, 4, tet + [(1, 0, 3)]),
        "tet_two_copies.bin": unit(6, 4, [(3, 1, 0)] + tet + [(0, 3, 1)]),
        "fin.bin": unit(7, 5, tet + [(0, 1, 4)]),  # an edge of three faces
        "degenerate.bin": unit(5, 5, tet + [(4, 4, 1)]),
        "unused.bin": unit(4, 8, octa[:4]),
        "bowtie.bin": unit(7, 5, [(0, 1, 2), (0, 3, 4)]),  # a non-manifold vertex
        "octahedron.bin": unit(3, 6, octa),
        "out_of_range.bin": unit(15, 4, tet + [(0, 1, 4)]),
        "no_faces.bin": unit(7, 3, []),
        # A face and its copy sharing no edge with any other face: the duplicate is
        # found from the twins (`check_clean_given`), not by the counting sort.
        "pair_reversed.bin": unit(0, 3, [(0, 1, 2), (0, 2, 1)]),
        "pair_same.bin": unit(0, 3, [(0, 1, 2), (1, 2, 0)]),
        "octahedron_and_pair.bin": unit(2, 9, octa + [(6, 7, 8), (8, 7, 6)]),
    }


def write(target, files):
    d = OUT / target
    d.mkdir(parents=True, exist_ok=True)
    for name, content in files.items():
        (d / name).write_bytes(content.encode() if isinstance(content, str) else content)


def copy_matching(target, pattern, src=DATA / "malformed"):
    d = OUT / target
    d.mkdir(parents=True, exist_ok=True)
    for p in sorted(src.glob(pattern)):
        if p.stat().st_size <= 16384:
            shutil.copy(p, d / p.name)


def main():
    write("obj", obj_seeds())
    copy_matching("obj", "*.obj")
    copy_matching("obj", "*.obj", DATA / "mlz")
    write("obj_variants", obj_variants_seeds())
    write("off", off_seeds())
    copy_matching("off", "*.off")
    write("ply_ascii", ply_ascii_seeds())
    copy_matching("ply_ascii", "*.ply")
    write("ply_binary", ply_binary_seeds())
    write("ply_variants", ply_variants_seeds())
    write("stl_ascii", stl_ascii_seeds())
    copy_matching("stl_ascii", "*.stl")
    write("stl_binary", stl_binary_seeds())
    copy_matching("mlz", "*.mlz", DATA / "mlz")
    copy_matching("mlz_threads", "*.mlz", DATA / "mlz")
    write("mtx", mtx_seeds())
    write("npy", npy_seeds())
    write("open", open_seeds())
    # The committed minimised corpora (from earlier runs).
    for committed in sorted((DATA / "fuzz").glob("*")):
        if committed.is_dir():
            copy_matching(committed.name, "*", committed)
    # The differential targets start from the plain targets' corpora too: OBJ files
    # behind a chunk byte, binary PLY inputs as they are (their mode bytes' top bits
    # pick the blocks).
    for k, p in enumerate(sorted((DATA / "fuzz" / "obj").glob("*"))):
        if p.is_file() and p.stat().st_size <= 16384:
            (OUT / "obj_variants" / f"obj-{p.name}").write_bytes(bytes([k * 37 % 256]) + p.read_bytes())
    copy_matching("ply_variants", "*", DATA / "fuzz" / "ply_binary")
    copy_matching("mlz_threads", "*", DATA / "fuzz" / "mlz")
    for d in sorted(OUT.iterdir()):
        print(f"{d.name}: {len(list(d.iterdir()))} seeds")


if __name__ == "__main__":
    main()
