"""Rate–distortion race: meshlap's spectral codec vs Google Draco (DracoPy).

Run: bench/.venv/bin/python bench/compression.py [MESH ...] [--operators kirchhoff,sstl]
     [--bpv 3,4,5,6,7,8] [--samples N] [--json-out FILE] [--no-timing]
(default meshes: stanford-bunny.obj igea.ply, read from /work/shared/data/meshes).

Both sides code the same cleaned, manifold mesh (`meshlap clean --split-nonmanifold`).
Ours: `meshlap compress --target-bpv b --measure --json` for each b and operator (the
default `--mode auto` codes the geometry both spectrally and spatially and keeps the
lower error; the setting column names the coder it kept).
Draco: compression level 10 at 8..14 quantization bits; its decoded points are matched
to the input vertices through the index carried as a colour in a second encode
(Draco reorders vertices; see draco_with_map) and measured by
`meshlap compare --map`, i.e. with exactly the same metric code as ours. Draco's
connectivity cost is bounded from above by its size at 1 quantization bit.
Timing: `meshlap-bench codec` (encode and decode in memory) and DracoPy encode+decode,
same threads (BENCH_THREADS, default 2).
"""
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from common import THREADS, build, load_vf, meshlap_bench, table, timeit, mesh_path


def run_json(*args):
    exe = build() / "meshlap"
    out = subprocess.run([str(exe), *map(str, args)], check=True, capture_output=True, text=True).stdout
    return json.loads(out)


def write_obj(path, V, F):
    with open(path, "w") as f:
        for v in V:
            f.write("v %.9g %.9g %.9g\n" % (float(v[0]), float(v[1]), float(v[2])))
        for t in F:
            f.write(f"f {t[0] + 1} {t[1] + 1} {t[2] + 1}\n")


def draco_with_map(V, F, q, P):
    """Draco's decoded mesh with the input vertex of each point: the index rides along
    as a 24-bit RGB colour in a second encode with the same settings. Colours change
    Draco's traversal order but not the quantized positions: the second decode is used
    only if its points are, as a set, exactly the first one's. None otherwise."""
    import DracoPy
    idx = np.arange(len(V))
    rgb = np.stack([idx & 255, (idx >> 8) & 255, (idx >> 16) & 255], axis=1).astype(np.uint8)
    d = DracoPy.decode(DracoPy.encode(V, F, quantization_bits=q, compression_level=10, colors=rgb))
    P2 = np.asarray(d.points, dtype=float)
    T2 = np.asarray(d.faces, dtype=np.int64).reshape(-1, 3)
    C = np.asarray(d.colors).astype(np.int64)
    if P2.shape != P.shape or C.shape[0] != len(P2):
        return None
    if not np.array_equal(P[np.lexsort(P.T)], P2[np.lexsort(P2.T)]):
        return None
    m = C[:, 0] | (C[:, 1] << 8) | (C[:, 2] << 16)
    if len(np.unique(m)) != len(V) or m.max() >= len(V):
        return None
    return P2, T2, m


def draco_points(clean, V, F, samples, tmp):
    import DracoPy
    pts = []
    conn = len(DracoPy.encode(V, F, quantization_bits=1, compression_level=10)) * 8 / len(V)
    for q in range(8, 15):
        b = DracoPy.encode(V, F, quantization_bits=q, compression_level=10)
        d = DracoPy.decode(b)
        P = np.asarray(d.points, dtype=float)
        T = np.asarray(d.faces, dtype=np.int64).reshape(-1, 3)
        mapped = draco_with_map(V, F, q, P) if len(P) == len(V) else None
        obj = Path(tmp) / f"draco{q}.obj"
        args = ["compare", clean, obj, "--json", "--samples", samples]
        if mapped is not None:
            P, T, idx = mapped
            mp = Path(tmp) / f"draco{q}.map"
            mp.write_text("\n".join(map(str, idx)))
            args += ["--map", mp]
        write_obj(obj, P, T)
        c = run_json(*args)
        pts.append({"coder": "draco", "param": f"q{q}", "bpv": len(b) * 8 / len(V),
                    "connectivity_bpv_upper": conn, "distortion": c})
    return pts


def ours(clean, ops, bpvs, samples):
    pts = []
    for op in ops:
        for b in bpvs:
            r = run_json("compress", clean, "-o", Path(clean).with_suffix(".mlz"), "--operator", op,
                         "--target-bpv", b, "--measure", "--samples", samples, "--json")
            pts.append({"coder": f"meshlap-{op}", "param": f"{b:g} bpv {r['geometry_mode']}",
                        "bpv": r["bits_per_vertex"], "mode": r["geometry_mode"],
                        "connectivity_bpv": r["connectivity_bpv"], "distortion": r["distortion"]})
    return pts


def main():
    args = sys.argv[1:]
    opt = lambda name, default: args[args.index(name) + 1] if name in args else default
    ops = opt("--operators", "kirchhoff").split(",")
    bpvs = [float(x) for x in opt("--bpv", "3,4,5,6,7,8").split(",")]
    samples = int(opt("--samples", "100000"))
    json_out = opt("--json-out", None)
    flags = {"--operators", "--bpv", "--samples", "--json-out"}
    meshes = [a for i, a in enumerate(args) if not a.startswith("--") and (i == 0 or args[i - 1] not in flags)]
    meshes = meshes or ["stanford-bunny.obj", "igea.ply"]
    results = {}
    for name in meshes:
        path = mesh_path(name)
        with tempfile.TemporaryDirectory() as tmp:
            clean = Path(tmp) / "clean.ply"
            subprocess.run([str(build() / "meshlap"), "clean", "--split-nonmanifold", path, clean],
                           check=True, capture_output=True)
            V, F = load_vf(clean)
            pts = ours(clean, ops, bpvs, samples) + draco_points(clean, V, F, samples, tmp)
            results[name] = pts
            print(f"\n### {name} ({len(V)} vertices)\n")
            rows = []
            for p in pts:
                d = p["distortion"]
                vr = d["vertex_rms"]
                rows.append([p["coder"], p["param"], f"{p['bpv']:.2f}",
                             f"{p.get('connectivity_bpv', p.get('connectivity_bpv_upper')):.2f}",
                             "n/a" if vr is None else f"{vr:.3e}",
                             f"{max(d['a_to_b_rms'], d['b_to_a_rms']):.3e}", f"{d['hausdorff']:.3e}"])
            table(rows, ["coder", "setting", "bits/vertex", "connectivity bpv (Draco: ≤)",
                         "vertex RMS / diag", "Metro RMS / diag", "Hausdorff / diag"])
            if "--no-timing" not in args:
                t = meshlap_bench("codec", clean, "--repeat", "3")
                import DracoPy
                enc = lambda: DracoPy.encode(V, F, quantization_bits=10, compression_level=10)
                blob = enc()
                te = timeit(enc, 3)
                td = timeit(lambda: DracoPy.decode(blob), 3)
                print(f"\ntiming ({THREADS} threads): meshlap encode {t['encode']['median']:.3f} s, "
                      f"decode {t['decode']['median']:.3f} s (default settings, "
                      f"{t['bits_per_vertex']:.2f} bpv); Draco q10 encode {te:.3f} s, decode {td:.3f} s")
    if json_out:
        Path(json_out).write_text(json.dumps(results, indent=1))


if __name__ == "__main__":
    main()
