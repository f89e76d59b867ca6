"""The Dask batch runner on a folder of built-in meshes with one broken file, on a
2-worker LocalCluster on loopback."""

import json

import numpy as np
import pytest

import meshlap

distributed = pytest.importorskip("dask.distributed")
import meshlap.batch as batch  # noqa: E402


@pytest.fixture(scope="module")
def client():
    cluster = distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=False, protocol="tcp://", host="127.0.0.1",
        dashboard_address=None
    )
    c = distributed.Client(cluster)
    yield c
    c.close()
    cluster.close()


@pytest.fixture
def folder(tmp_path):
    src = tmp_path / "in"
    src.mkdir()
    for name, spec in [("sphere.obj", "builtin:icosphere:2"), ("torus.ply", "builtin:torus:12:8"), ("cube.off", "builtin:cube:3")]:
        meshlap.write_mesh(src / name, *meshlap.read_mesh(spec))
    (src / "broken.obj").write_text("v 0 0 0\nv 1 0 0\nf 1 2 7\n")
    (src / "notes.txt").write_text("not a mesh")
    return src


def test_compress_batch_reports_the_broken_file_and_finishes_the_rest(client, folder, tmp_path):
    out = tmp_path / "out"
    report = batch.run("compress", folder, out, client=client, progress=False, bits=12)
    by = {p.split("/")[-1]: e for p, e in ((e["input"], e) for e in report)}
    assert set(by) == {"sphere.obj", "torus.ply", "cube.off", "broken.obj"}
    assert by["broken.obj"]["status"] == "error" and "MeshIOError" in by["broken.obj"]["error"]
    for name in ["sphere.obj", "torus.ply", "cube.off"]:
        e = by[name]
        assert e["status"] == "ok" and e["output_bytes"] > 0 and e["seconds"] > 0
    saved = json.loads((out / "batch-report.json").read_text())
    assert saved["command"] == "compress" and len(saved["files"]) == 4
    assert sorted(p.name for p in out.iterdir()) == ["batch-report.json", "cube.mlz", "sphere.mlz", "torus.mlz"]
    # No temporary files are left; the outputs decode to the inputs' meshes.
    V, F = meshlap.read_mesh(folder / "torus.ply")
    V2, F2 = meshlap.decompress((out / "torus.mlz").read_bytes())
    assert V2.shape == V.shape and F2.shape == F.shape
    # decompress as a batch too, back to meshes.
    back = batch.run("decompress", out, tmp_path / "back", client=client, progress=False, output_format="obj")
    assert [e["status"] for e in back] == ["ok"] * 3
    table = batch.summary_table(report)
    assert "3 ok, 1 failed" in table and "broken.obj" in table


def test_info_smooth_project_batches(client, folder, tmp_path):
    rep = batch.run("info", folder, tmp_path / "info", client=client, progress=False)
    ok = [e for e in rep if e["status"] == "ok"]
    assert len(ok) == 3
    d = json.loads((tmp_path / "info" / "sphere.json").read_text())
    assert d["vertices"] == 162
    rep = batch.run("smooth", [folder / "sphere.obj"], tmp_path / "s", client=client, progress=False, operator="kirchhoff", lam=1.0)
    assert rep[0]["status"] == "ok"
    Vs, _ = meshlap.read_mesh(tmp_path / "s" / "sphere.obj")
    V, F = meshlap.read_mesh(folder / "sphere.obj")
    np.testing.assert_allclose(Vs, meshlap.smooth(V, F, operator="kirchhoff", lam=1.0)[0], atol=1e-12)
    rep = batch.run("project", [folder / "sphere.obj"], tmp_path / "p", client=client, progress=False, kind="sql", keep="10%")
    assert rep[0]["status"] == "ok"


def test_unknown_command_and_option(tmp_path, client):
    with pytest.raises(ValueError, match="unknown command"):
        batch.run("explode", tmp_path, tmp_path / "o", client=client)
    with pytest.raises(ValueError, match="takes no option"):
        batch.run("info", tmp_path, tmp_path / "o", client=client, bits=3)


def test_command_line_on_a_local_cluster(folder, tmp_path):
    """`python -m meshlap.batch` with its own 2-process LocalCluster on loopback."""
    import subprocess
    import sys

    out = tmp_path / "cli"
    r = subprocess.run(
        [sys.executable, "-m", "meshlap.batch", "compress", str(folder), str(out), "--workers", "2", "--bits", "10"],
        capture_output=True, text=True, timeout=300,
    )
    assert r.returncode == 1, r.stderr  # one file failed
    assert "3 ok, 1 failed" in r.stderr
    assert (out / "batch-report.json").exists() and (out / "cube.mlz").exists()
