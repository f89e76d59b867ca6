"""Batch runs of meshlap over a folder of meshes on a Dask cluster.

One Dask task per file, on ``dask.distributed``: a ``LocalCluster`` on this machine by
default, or any running cluster given its scheduler address. A failed file is
reported (status ``error`` with the message) without stopping the others; every output
is written atomically (a temporary file in the output folder, renamed when complete).

Command line::

    python -m meshlap.batch COMMAND INPUT_DIR OUTPUT_DIR [--scheduler ADDRESS]
        [--workers N] [--report FILE.json] [options]

COMMAND is ``compress`` (mesh → ``.mlz``), ``decompress`` (``.mlz`` → mesh),
``smooth`` and ``project`` (mesh → mesh, same format unless ``--output-format``) or
``info`` (mesh → ``.json``). A progress bar and a summary table go to stderr; the JSON
report (per file: input, output, status, seconds, input_bytes, output_bytes, error)
to ``OUTPUT_DIR/batch-report.json`` unless ``--report`` says otherwise.

From Python::

    from dask.distributed import Client
    report = meshlap.batch.run("compress", "meshes/", "out/", client=Client("tcp://host:8786"), bits=12)
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
from pathlib import Path
from typing import Any, Dict, Iterable, List, Optional, Sequence, Union

MESH_EXTENSIONS = (".obj", ".off", ".ply", ".stl")
COMMANDS = ("compress", "decompress", "smooth", "project", "info")

#: Options each command takes (forwarded to the meshlap function of the same name).
COMMAND_OPTIONS = {
    "compress": ("bits", "target_bpv", "mode", "operator", "patch_size", "keep_ratio", "preserve_order"),
    "decompress": ("output_format",),
    "smooth": ("filter", "operator", "lam", "steps", "solver", "preserve", "output_format"),
    "project": ("kind", "keep", "patch_size", "output_format"),
    "info": (),
}


def _atomic_write(path: Path, data: bytes) -> None:
    fd, tmp = tempfile.mkstemp(dir=str(path.parent), prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise


def _output_path(command: str, src: Path, out_dir: Path, options: Dict[str, Any]) -> Path:
    if command == "compress":
        return out_dir / (src.stem + ".mlz")
    if command == "info":
        return out_dir / (src.stem + ".json")
    ext = options.get("output_format")
    if command == "decompress":
        ext = ext or "ply"
    if ext:
        return out_dir / (src.stem + "." + ext.lstrip("."))
    return out_dir / src.name


def process_file(command: str, src: Union[str, Path], output_dir: Union[str, Path], options: Dict[str, Any]) -> Dict[str, Any]:
    """Runs ``command`` on one file and returns its report entry (never raises for a
    bad file: the error is in the entry). This is the Dask task."""
    import meshlap

    src, out_dir = Path(src), Path(output_dir)
    entry: Dict[str, Any] = {
        "input": str(src),
        "output": None,
        "status": "ok",
        "seconds": 0.0,
        "input_bytes": src.stat().st_size if src.exists() else None,
        "output_bytes": None,
        "error": None,
    }
    t0 = time.perf_counter()
    try:
        dst = _output_path(command, src, out_dir, options)
        if command == "compress":
            V, F = meshlap.read_mesh(src)
            kw = {k: options[k] for k in COMMAND_OPTIONS["compress"] if options.get(k) is not None}
            _atomic_write(dst, meshlap.compress(V, F, **kw))
        elif command == "decompress":
            V, F = meshlap.decompress(src.read_bytes())
            meshlap.write_mesh(dst, V, F)
        elif command == "smooth":
            V, F = meshlap.read_mesh(src)
            kw = {k: options[k] for k in COMMAND_OPTIONS["smooth"][:-1] if options.get(k) is not None}
            V2, _ = meshlap.smooth(V, F, **kw)
            meshlap.write_mesh(dst, V2, F)
        elif command == "project":
            V, F = meshlap.read_mesh(src)
            if options.get("kind") is None or options.get("keep") is None:
                raise meshlap.Error("project needs kind and keep")
            V2 = meshlap.project(V, F, options["kind"], options["keep"], options.get("patch_size"))
            meshlap.write_mesh(dst, V2, F)
        elif command == "info":
            V, F = meshlap.read_mesh(src)
            _atomic_write(dst, json.dumps(meshlap.info(V, F), indent=2).encode())
        else:
            raise meshlap.Error(f"unknown command {command!r}; choose one of {', '.join(COMMANDS)}")
        entry["output"] = str(dst)
        entry["output_bytes"] = dst.stat().st_size
    except Exception as e:  # a failed file is reported, never fatal to the batch
        entry["status"] = "error"
        entry["error"] = f"{type(e).__name__}: {e}"
    entry["seconds"] = time.perf_counter() - t0
    return entry


def _inputs(command: str, inputs: Union[str, Path, Sequence[Union[str, Path]]]) -> List[Path]:
    exts = (".mlz",) if command == "decompress" else MESH_EXTENSIONS
    if isinstance(inputs, (str, Path)):
        p = Path(inputs)
        if p.is_dir():
            return sorted(q for q in p.iterdir() if q.is_file() and q.suffix.lower() in exts)
        return [p]
    return [Path(q) for q in inputs]


class _Bar:
    """A text progress bar on stderr (redrawn in place on a terminal)."""

    def __init__(self, total: int, enabled: bool):
        self.total, self.done, self.failed, self.enabled = total, 0, 0, enabled
        self.tty = sys.stderr.isatty()

    def update(self, ok: bool) -> None:
        self.done += 1
        self.failed += 0 if ok else 1
        if not self.enabled:
            return
        width = 30
        fill = int(width * self.done / max(self.total, 1))
        line = f"[{'#' * fill}{'.' * (width - fill)}] {self.done}/{self.total} files, {self.failed} failed"
        sys.stderr.write(("\r" + line) if self.tty else (line + "\n"))
        if self.tty and self.done == self.total:
            sys.stderr.write("\n")
        sys.stderr.flush()


def summary_table(report: Sequence[Dict[str, Any]]) -> str:
    """The summary table of a report: one line per file and a total."""
    rows = [("file", "status", "seconds", "in bytes", "out bytes")]
    for e in report:
        rows.append(
            (
                Path(e["input"]).name,
                e["status"],
                f"{e['seconds']:.3f}",
                str(e["input_bytes"] if e["input_bytes"] is not None else "-"),
                str(e["output_bytes"] if e["output_bytes"] is not None else "-"),
            )
        )
    ok = sum(e["status"] == "ok" for e in report)
    rows.append(("total", f"{ok} ok, {len(report) - ok} failed", f"{sum(e['seconds'] for e in report):.3f}", "", ""))
    widths = [max(len(r[i]) for r in rows) for i in range(5)]
    lines = ["  ".join(c.ljust(w) for c, w in zip(r, widths)).rstrip() for r in rows]
    lines.insert(1, "  ".join("-" * w for w in widths))
    errors = [f"  {Path(e['input']).name}: {e['error']}" for e in report if e["error"]]
    return "\n".join(lines + (["errors:"] + errors if errors else []))


def run(
    command: str,
    inputs: Union[str, Path, Sequence[Union[str, Path]]],
    output_dir: Union[str, Path],
    client: Any = None,
    *,
    scheduler: Optional[str] = None,
    workers: Optional[int] = None,
    progress: bool = True,
    report_path: Union[str, Path, None] = None,
    **options: Any,
) -> List[Dict[str, Any]]:
    """Runs ``command`` on every input (a folder or a list of files), one Dask task
    per file, writing into ``output_dir``. ``client``: a ``dask.distributed.Client``;
    otherwise one is made for ``scheduler`` (an address such as
    ``tcp://10.0.0.5:8786``) or, without it, for a new ``LocalCluster`` of ``workers``
    processes (default 2, one thread each), closed at the end. ``options`` are the
    meshlap function's keyword options (``bits=12``, ``kind="sql", keep="10%"``, …).

    Returns the report (one dict per file, in input order) and writes it as JSON to
    ``report_path`` (default ``output_dir/batch-report.json``), atomically.
    """
    from dask.distributed import Client, LocalCluster, as_completed

    if command not in COMMANDS:
        raise ValueError(f"unknown command {command!r}; choose one of {', '.join(COMMANDS)}")
    unknown = set(options) - set(COMMAND_OPTIONS[command])
    if unknown:
        raise ValueError(f"{command} takes no option(s) {', '.join(sorted(unknown))}")
    out = Path(output_dir)
    out.mkdir(parents=True, exist_ok=True)
    files = _inputs(command, inputs)
    own_cluster = own_client = None
    if client is None:
        if scheduler:
            client = own_client = Client(scheduler)
        else:
            own_cluster = LocalCluster(
                n_workers=workers or 2, threads_per_worker=1, processes=True, host="127.0.0.1", dashboard_address=None
            )
            client = own_client = Client(own_cluster)
    try:
        futures = [
            client.submit(process_file, command, str(f), str(out.resolve()), options, key=f"meshlap-{command}-{i}-{f.name}", pure=False)
            for i, f in enumerate(files)
        ]
        index = {fut.key: i for i, fut in enumerate(futures)}
        results: List[Optional[Dict[str, Any]]] = [None] * len(files)
        bar = _Bar(len(files), progress)
        for fut in as_completed(futures):
            i = index[fut.key]
            try:
                entry = fut.result()
            except Exception as e:  # the worker died or the task could not run
                entry = {
                    "input": str(files[i]), "output": None, "status": "error", "seconds": 0.0,
                    "input_bytes": None, "output_bytes": None, "error": f"{type(e).__name__}: {e}",
                }
            results[i] = entry
            bar.update(entry["status"] == "ok")
    finally:
        if own_client is not None:
            own_client.close()
        if own_cluster is not None:
            own_cluster.close()
    report = [r for r in results if r is not None]
    rp = Path(report_path) if report_path else out / "batch-report.json"
    _atomic_write(rp, json.dumps({"command": command, "options": options, "files": report}, indent=2).encode())
    return report


def main(argv: Optional[Sequence[str]] = None) -> int:
    p = argparse.ArgumentParser(prog="python -m meshlap.batch", description=__doc__.split("\n\n")[0])
    p.add_argument("command", choices=COMMANDS)
    p.add_argument("input_dir")
    p.add_argument("output_dir")
    p.add_argument("--scheduler", metavar="ADDRESS", help="address of a running Dask scheduler (default: a LocalCluster)")
    p.add_argument("--workers", type=int, default=None, help="LocalCluster worker processes (default 2)")
    p.add_argument("--report", default=None, help="JSON report path (default OUTPUT_DIR/batch-report.json)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    g = p.add_argument_group("command options (as the meshlap functions / CLI flags)")
    g.add_argument("--bits", type=float)
    g.add_argument("--target-bpv", type=float)
    g.add_argument("--mode")
    g.add_argument("--operator")
    g.add_argument("--patch-size", type=int)
    g.add_argument("--keep-ratio", type=float)
    g.add_argument("--preserve-order", action="store_true", default=None)
    g.add_argument("--filter")
    g.add_argument("--lambda", dest="lam", type=float)
    g.add_argument("--steps", type=int)
    g.add_argument("--solver")
    g.add_argument("--preserve")
    g.add_argument("--kind")
    g.add_argument("--keep")
    g.add_argument("--output-format")
    a = p.parse_args(argv)
    opts = {k: v for k, v in vars(a).items() if k in COMMAND_OPTIONS[a.command] and v is not None}
    given = {k for k, v in vars(a).items() if v is not None} - {"command", "input_dir", "output_dir", "scheduler", "workers", "report", "no_progress"}
    stray = given - set(COMMAND_OPTIONS[a.command])
    if stray:
        p.error(f"{a.command} takes no option(s) {', '.join('--' + s.replace('_', '-') for s in sorted(stray))}")
    if a.command == "project" and opts.get("keep") is not None and not opts["keep"].endswith("%"):
        try:
            opts["keep"] = int(opts["keep"])
        except ValueError:
            p.error("--keep must be a count or a percentage like 10%")
    report = run(a.command, a.input_dir, a.output_dir, scheduler=a.scheduler, workers=a.workers,
                 progress=not a.no_progress, report_path=a.report, **opts)
    print(summary_table(report), file=sys.stderr)
    return 0 if all(e["status"] == "ok" for e in report) else 1


if __name__ == "__main__":
    sys.exit(main())
