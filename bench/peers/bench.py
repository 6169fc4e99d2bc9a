"""Peer benchmark of volga's mesh voxelization: OpenVDB, Open3D, trimesh.

Run through bench/peers/run.sh, which installs the peers and builds volga first. Each
(tool, N) runs in its own process, so no tool's caches or heap help another, and the
tools of a task take turns call by call. Writes a markdown table to stdout and between
the markers of docs/BENCHMARKS.md (methodology there).

Heavy (minutes, up to ~7 GiB for trimesh at 512): not part of CI.
"""

import argparse
import filecmp
import json
import os
import platform
import re
import shlex
import shutil
import statistics
import subprocess
import sys
import tempfile
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, HERE)
from common import (exact_unsigned_distance, load_obj, read_binvox,  # noqa: E402
                    read_volga_nrrd, voxel_size, winding_number)

HALF_WIDTH = 3
BEGIN = "<!-- peers-benchmark:begin (written by bench/peers/bench.py; do not edit by hand) -->"
END = "<!-- peers-benchmark:end -->"
SAMPLE_SEED = 20240  # the same voxel sample on every run
NOTES = (
    "Notes: volga (rayon) and OpenVDB (TBB) use both cores; Open3D's and trimesh's calls are "
    "single-threaded (the libraries, not the setup; nobody is pinned). Every tool is timed "
    "the same way: a process that has read the mesh and made one warm-up call times each "
    "further call (volga: `volga bench voxelize --serve`; its result is checked "
    "byte-identical to the fresh process's output). The row 'volga (fresh process per "
    "run)' is the `voxelize` stage of a new `volga voxelize` process each run, what a "
    "one-off command sees. Ratio = peer time / volga (warm) time at the same N ((b) and "
    "(c) against volga's 26-separating surface). Peer "
    "memory is the peak RSS of a process that only loads the mesh and voxelizes once "
    "(interpreter, library and mesh included); volga's is the `voxelize` stage's peak RSS "
    "from its report (mesh included), and in parentheses the largest peak of all its stages "
    "(reading, voxelizing, writing). Distance error and sign are on {sample:,} sampled band voxels "
    "(references described above). 26-separating = `volga validate --mesh` finds no "
    "26-tunnel through the bunny (the bunny is open, so in the whole grid the white voxels "
    "are one region for every tool).")


def log(msg):
    print(msg, file=sys.stderr, flush=True)


# --------------------------------------------------------------------------- processes

def run_timed_rss(cmd, **kw):
    """Runs cmd under GNU time; returns (CompletedProcess, max RSS bytes)."""
    p = subprocess.run(["/usr/bin/time", "-v"] + cmd, capture_output=True, text=True, **kw)
    m = re.search(r"Maximum resident set size \(kbytes\): (\d+)", p.stderr)
    return p, (int(m.group(1)) * 1024 if m else None)


def check(p, what):
    if p.returncode != 0:
        raise RuntimeError(f"{what} failed (exit {p.returncode}):\n{p.stdout[-2000:]}\n{p.stderr[-3000:]}")


class PeerServer:
    """A tool serving timed calls for one N in its own process (it has made its warm-up
    call once this returns): a peer's worker.py in its interpreter, or `volga bench
    voxelize --serve` (the same line protocol). Its stderr is ours, for diagnostics."""

    def __init__(self, tool, python, mesh, n, cmd=None):
        self.tool, self.n = tool, n
        cmd = cmd or [python, os.path.join(HERE, "worker.py"), tool, mesh, str(n)]
        self.proc = subprocess.Popen(cmd, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
        self.info = self._ask(None)
        self.times, self.voxels = [], None

    def _ask(self, command):
        if command is not None:
            self.proc.stdin.write(command + "\n")
            self.proc.stdin.flush()
        line = self.proc.stdout.readline()
        if not line:
            raise RuntimeError(f"{self.tool} worker at N={self.n} died (exit {self.proc.wait()})")
        return json.loads(line)

    def run(self):
        r = self._ask("run")
        self.times.append(r["t"])
        self.voxels = r["voxels"]

    def dump(self, path):
        self._ask(f"dump {path}")

    def close(self):
        self.proc.stdin.close()
        if self.proc.wait() != 0:
            raise RuntimeError(f"{self.tool} worker at N={self.n} exited with {self.proc.returncode}")


def peer_peak_memory(tool, python, mesh, n):
    """Peak RSS of a process that only loads the mesh and makes one call (interpreter,
    library and mesh included; said in the notes)."""
    p, rss = run_timed_rss([python, os.path.join(HERE, "worker.py"), tool, mesh, str(n), "--once"])
    check(p, f"{tool} memory run at N={n}")
    return rss


class Volga:
    def __init__(self, exe, mesh, workdir, name="volga"):
        self.mesh = mesh
        # Benchmark a private copy: a concurrent `cargo build` must not swap the
        # binary between rows of one table.
        self.exe = exe
        if os.path.exists(exe):
            self.exe = os.path.join(workdir, name)
            shutil.copy2(exe, self.exe)
        self.missing = self._why_missing()

    def _why_missing(self):
        if not os.path.exists(self.exe):
            return f"{self.exe} not built (run bench/peers/run.sh, which builds it)"
        p = subprocess.run([self.exe, "voxelize", "--help"], capture_output=True, text=True)
        if p.returncode != 0:
            return "`volga voxelize` not available yet"
        return None

    def has_validate(self):
        if not os.path.exists(self.exe):
            return None
        p = subprocess.run([self.exe, "validate", "--help"], capture_output=True, text=True)
        return p.stdout if p.returncode == 0 else None

    def server(self, n, mode_args):
        """volga warm in one process, as the peers are measured: `volga bench voxelize
        --serve` reads the mesh once, makes one untimed warm-up run, then times each
        `run` request (the voxelization only, as the `voxelize` stage)."""
        return PeerServer("volga", None, self.mesh, n,
                          cmd=[self.exe, "bench", "voxelize", self.mesh, "--resolution", str(n)]
                          + mode_args + ["--serve"])

    def voxelize(self, n, mode_args, out, report):
        """One `volga voxelize` run; returns its report. Its time is the report's
        `voxelize` stage, which leaves out reading the mesh and writing the file, as
        only the library call is timed for the peers."""
        cmd = [self.exe, "voxelize", self.mesh, "--resolution", str(n)] + mode_args + [
            "--out", out, "--report", report]
        check(subprocess.run(cmd, capture_output=True, text=True), " ".join(cmd))
        with open(report) as f:
            rep = json.load(f)
        if [s.get("name") for s in rep.get("stages", [])].count("voxelize") != 1:
            raise RuntimeError(f"{report}: expected one `voxelize` stage, got {rep.get('stages')}")
        return rep


def volga_summary(reports, server, dump, cold_out):
    """volga's figures for one task: the median warm time (from its server, measured as
    the peers are), the median fresh-process time (the `voxelize` stage of each
    `volga voxelize` report) and the peak memories from those reports. The server's
    last result is dumped and must be byte-identical to the fresh process's output.

    Memory comes from the reports, not /usr/bin/time: volga resets the kernel's
    high-water mark at each stage (/proc/self/clear_refs), which is also what GNU time
    reads at exit, so that would show only the last stage."""
    if not reports or server is None:
        return None
    server.dump(dump)
    server.close()
    same = (lambda a, b: filecmp.cmp(a, b, shallow=False))
    if dump.endswith(".nrrd"):
        ok = same(dump[:-5] + ".raw", cold_out[:-5] + ".raw")
    else:
        ok = same(dump, cold_out)
    if not ok:
        raise RuntimeError(f"volga's warm result {dump} differs from its fresh-process output {cold_out}")
    stage = [next(s for s in r["stages"] if s["name"] == "voxelize") for r in reports]
    return {"time": statistics.median(server.times),
            "cold_time": statistics.median(s["wall_s"] for s in stage),
            "mem": max(s.get("peak_mem_bytes") or 0 for s in stage) or None,
            "all_mem": max(s.get("peak_mem_bytes") or 0 for r in reports for s in r["stages"]) or None,
            "report": reports[-1]}


def cold_row(n, task, summary, peer, peer_time):
    """The row of volga measured one fresh process per run (`volga voxelize --report`,
    its `voxelize` stage): what a one-off command-line run sees."""
    t = summary["cold_time"]
    return dict(n=n, task=task, tool="volga (fresh process per run)", time=fmt_time(t),
                ratio=f"{peer}/this {peer_time / t:.2f}")


def interleaved(repeats, volga_run, servers):
    """A warm-up run of volga in a fresh process, then `repeats` rounds of one call of
    every tool: volga in a fresh process, then every server (volga's warm server
    first). Taking turns call by call spreads outside load (the two cores are shared
    with whatever else runs) over all tools alike, instead of onto whichever ran during
    a burst. The servers made their warm-up calls when they started."""
    reports = []
    if volga_run:
        volga_run(0)
    for i in range(1, repeats + 1):
        if volga_run:
            reports.append(volga_run(i))
        for s in servers:
            s.run()
    return reports


# --------------------------------------------------------------------------- accuracy

def sample_rows(n_total, k):
    rng = np.random.default_rng(SAMPLE_SEED)
    return np.sort(rng.choice(n_total, size=min(k, n_total), replace=False))


def distance_accuracy(points, values, h, verts, tris):
    """(max |distance error| in voxels, wrong-sign fraction) of signed distances
    `values` at world `points`. The error compares magnitudes with the exact unsigned
    distance, so a wrong sign is not counted twice; the sign is judged on its own
    against the generalized winding number (inside iff ≥ ½, negative inside). A value
    of exactly 0 lies on the surface and has no wrong sign."""
    t0 = time.time()
    exact = exact_unsigned_distance(points, verts, tris)
    wn = winding_number(points, verts, tris)
    log(f"    reference on {len(points)} voxels: {time.time() - t0:.1f} s")
    err = np.abs(np.abs(values.astype(np.float64)) - exact).max() / h
    inside = wn >= 0.5
    wrong = ((values < 0) & ~inside) | ((values > 0) & inside)
    return float(err), float(wrong.mean())


def reference_self_test(verts, tris):
    """Checks the brute-force references before trusting them. Distance: never above a
    dense sampling of random triangles and close to it, and equal to trimesh's
    independent closest point on the mesh up to 1e-6 h (trimesh is a few 1e-8 too far on
    some triangles, where sampling sides with ours). Winding number: exactly 0 or 1 on
    a closed sphere away from its surface."""
    import trimesh

    rng = np.random.default_rng(1)
    for _ in range(4):
        t = rng.normal(size=(3, 3))
        q = rng.normal(size=(40, 3)) * 1.5
        ours = exact_unsigned_distance(q, t, np.array([[0, 1, 2]]))
        u = rng.random((100_000, 2))
        u[u.sum(1) > 1] = 1 - u[u.sum(1) > 1]
        s = t[0] + u[:, :1] * (t[1] - t[0]) + u[:, 1:] * (t[2] - t[0])
        sampled = np.sqrt(((q[:, None] - s[None]) ** 2).sum(-1)).min(1)
        assert np.all(ours <= sampled + 1e-12) and np.all(sampled - ours < 0.05), (ours, sampled)
    h = voxel_size(verts, 512)
    pts = rng.uniform(verts.min(0) - 0.01, verts.max(0) + 0.01, (8, 3))
    ours = exact_unsigned_distance(pts, verts, tris)
    tri = verts[tris]
    theirs = [np.linalg.norm(trimesh.triangles.closest_point(tri, np.repeat(p[None], len(tri), 0)) - p,
                             axis=1).min() for p in pts]
    assert np.allclose(ours, theirs, rtol=0, atol=1e-6 * h), (ours, theirs)
    sphere = trimesh.creation.icosphere(3)
    q = rng.normal(size=(64, 3))
    q = q[np.abs(np.linalg.norm(q, axis=1) - 1) > 0.05]
    wn = winding_number(q, sphere.vertices, sphere.faces)
    assert np.allclose(wn, np.linalg.norm(q, axis=1) < 1, atol=1e-9), wn


def volga_band(nrrd_path):
    """Band voxels of a volga distance NRRD: (ijk, values, centre0, spacing, note).

    Volga stores every voxel of its dense box; voxels outside the narrow band carry
    the background (`volga_background:=` in the header), possibly with either sign
    (outside/inside). So the band is every voxel whose value is not ±background.
    """
    data, origin, spacing, fields = read_volga_nrrd(nrrd_path)
    bg = float(fields["volga_background"])
    flat = np.asarray(data).ravel(order="F")
    mask = (np.abs(flat) != abs(bg)) & np.isfinite(flat)
    idx = np.flatnonzero(mask)
    sizes = data.shape
    i = idx % sizes[0]
    j = (idx // sizes[0]) % sizes[1]
    k = idx // (sizes[0] * sizes[1])
    vals = flat[idx]
    h = float(spacing[0])
    note = (f"background {bg:g}; {len(idx)} voxels ≠ ±background, of which "
            f"{int(np.sum(np.abs(vals) < HALF_WIDTH * h))} have |v| < {HALF_WIDTH}h; "
            f"max |v| in band = {np.abs(vals).max() / h:.3f} h")
    return np.stack([i, j, k], 1), vals, origin, spacing, note


# --------------------------------------------------------------------------- validation

def validate(volga, help_text, binvox, mesh):
    """26-separability of a .binvox by `volga validate`, or why it is not known."""
    if help_text is None:
        return "n/a (volga validate not yet available)", None
    # The bunny is open: the white voxels are one region through its holes whatever
    # the voxelizer does, so separability is only meaningful against the mesh
    # (no 26-tunnel crossing it), which `--mesh` asks for.
    cmd = [volga.exe, "validate", binvox, "--connectivity", "26", "--json"]
    if "--mesh" in help_text:
        cmd[3:3] = ["--mesh", mesh]
    p = subprocess.run(cmd, capture_output=True, text=True)
    detail = p.stdout.strip()
    if p.returncode == 0:
        verdict = "yes"
    elif p.returncode == 1:
        verdict = "no"
        tunnels = _find_count(detail, "tunnel")
        if tunnels is not None:
            verdict += f" ({tunnels} tunnels)"
    else:
        verdict = f"error (exit {p.returncode})"
        detail = p.stderr.strip()[-500:]
    shown = ["volga"] + [shlex.quote(os.path.basename(c) if c.endswith(".binvox") else
                                     os.path.relpath(c, REPO) if c == mesh else c) for c in cmd[1:]]
    summary = detail if verdict.startswith("error") else _validate_summary(detail)
    return verdict, {"cmd": " ".join(shown), "summary": summary}


def _validate_summary(text):
    """Tunnels, cover and whole-grid white components from validate's JSON
    (schema in docs/VALIDATE.md), for the details under the table."""
    try:
        rep = json.loads(text).get("report", {})
    except ValueError:
        return ""
    mesh = rep.get("mesh") or {}
    parts = []
    if "tunnel_count" in mesh:
        parts.append(f"{mesh['tunnel_count']} tunnels")
    if "covers" in mesh:
        parts.append(f"covers the mesh: {mesh['covers']}")
    if "white_component_count" in rep:
        parts.append(f"{rep['white_component_count']} white component(s) in the whole grid")
    return ", ".join(parts)


def _find_count(text, key):
    """A count of `key`s in validate's JSON (schema in docs/VALIDATE.md), if findable."""
    try:
        doc = json.loads(text)
    except ValueError:
        return None
    found = []

    def walk(o):
        if isinstance(o, dict):
            for k, v in o.items():
                if key in k.lower():
                    found.append(v)
                walk(v)
        elif isinstance(o, list):
            for v in o:
                walk(v)

    walk(doc)
    for v in found:
        if isinstance(v, int):
            return v
        if isinstance(v, list):
            return len(v)
    return None


# --------------------------------------------------------------------------- report

def fmt_err(e):
    return f"{e:.3f}" if e >= 0.001 else f"{e:.1e}"


def fmt_time(t):
    return "—" if t is None else (f"{t:.3f} s" if t < 10 else f"{t:.1f} s")


def fmt_mem(b):
    if b is None:
        return "—"
    return f"{b / 2**30:.2f} GiB" if b >= 2**30 else f"{b / 2**20:.0f} MiB"


def machine():
    model = "unknown"
    with open("/proc/cpuinfo") as f:
        for line in f:
            if line.startswith("model name"):
                model = line.split(":", 1)[1].strip()
                break
    mem = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    return f"{os.cpu_count()} cores (nproc {len(os.sched_getaffinity(0))}), {model}, {mem / 2**30:.0f} GiB RAM, Linux {platform.release()}"


def git_rev():
    try:
        rev = subprocess.run(["git", "-C", REPO, "rev-parse", "--short", "HEAD"],
                             capture_output=True, text=True).stdout.strip()
        dirty = subprocess.run(["git", "-C", REPO, "status", "--porcelain", "--untracked-files=no"],
                               capture_output=True, text=True).stdout.strip()
        return rev + ("+dirty" if dirty else "")
    except OSError:
        return "unknown"


def table(rows):
    head = ("| N | task | tool | median time | peer/volga time | voxels | max \\|dist err\\| (voxels) "
            "| wrong-sign fraction | 26-separating? | peak memory |")
    out = [head, "|" + "---|" * 10]
    for r in rows:
        out.append("| " + " | ".join(str(r.get(k, "—")) for k in (
            "n", "task", "tool", "time", "ratio", "voxels", "err", "sign", "sep", "mem")) + " |")
    return "\n".join(out)


def write_docs(path, body):
    block = f"{BEGIN}\n{body}\n{END}"
    text = open(path).read() if os.path.exists(path) else "# Benchmarks\n"
    if BEGIN in text and END in text:
        text = text[:text.index(BEGIN)] + block + text[text.index(END) + len(END):]
    else:
        text = text.rstrip("\n") + "\n\n" + block + "\n"
    with open(path, "w") as f:
        f.write(text)


# --------------------------------------------------------------------------- main

def main():
    ap = argparse.ArgumentParser(description="Peer benchmark of volga voxelize (see docs/BENCHMARKS.md)")
    ap.add_argument("--mesh", default=os.path.join(REPO, "tests", "data", "stanford-bunny.obj"))
    ap.add_argument("--sizes", type=int, nargs="+", default=[128, 256, 512])
    ap.add_argument("--repeats", type=int, default=5, help="timed runs after one warm-up (median reported)")
    ap.add_argument("--sample", type=int, default=2000, help="band voxels checked against brute force")
    ap.add_argument("--skip-trimesh-above", type=int, default=None, metavar="N",
                    help="skip trimesh for N above this (it takes ~40 s and 6 GiB at 512)")
    ap.add_argument("--volga", default=os.path.join(REPO, "target", "release", "volga"))
    ap.add_argument("--volga-before", metavar="BIN",
                    help="an earlier volga binary, served warm in the same rounds: rows 'volga before' "
                         "with their own peer/volga ratios, to show a change's cost in one run")
    ap.add_argument("--system-python", default="/usr/bin/python3", help="interpreter with pyopenvdb")
    ap.add_argument("--docs", default=os.path.join(REPO, "docs", "BENCHMARKS.md"))
    ap.add_argument("--no-docs", action="store_true", help="print the table only")
    ap.add_argument("--workdir", help="keep outputs here (default: a temporary directory, removed)")
    a = ap.parse_args()

    mesh = os.path.abspath(a.mesh)
    verts, tris = load_obj(mesh)
    reference_self_test(verts, tris)
    load_at_start = os.getloadavg()[0]
    workdir = a.workdir or tempfile.mkdtemp(prefix="volga-peers-")
    os.makedirs(workdir, exist_ok=True)
    volga = Volga(os.path.abspath(a.volga), mesh, workdir)
    before = Volga(os.path.abspath(a.volga_before), mesh, workdir, "volga-before") if a.volga_before else None
    if volga.missing:
        log(f"*** volga rows are MISSING: {volga.missing}. Running the peers alone. ***")
    vhelp = volga.has_validate()
    if vhelp is None:
        log("*** `volga validate` not available: 26-separability column left n/a ***")
    pythons = {"openvdb": a.system_python, "open3d": sys.executable, "trimesh": sys.executable}
    names = {"openvdb": "OpenVDB", "open3d": "Open3D", "trimesh": "trimesh"}

    rows, details, versions = [], [], {}
    if not volga.missing:
        details.append(f"volga binary: {os.path.relpath(a.volga, REPO)}, built "
                       f"{time.strftime('%Y-%m-%d %H:%M', time.localtime(os.path.getmtime(a.volga)))}, "
                       "copied before the first run")

    def serve(tool, n):
        log(f"  starting {tool} (parse + warm-up)")
        s = PeerServer(tool, pythons[tool], mesh, n)
        versions[names[tool]] = s.info["version"]
        return s

    def volga_runner(n, mode_args, out, tag):
        if volga.missing:
            return None
        return lambda i: volga.voxelize(n, mode_args, out, os.path.join(workdir, f"{tag}_report{i}.json"))

    for n in a.sizes:
        h = voxel_size(verts, n)
        log(f"N={n} (h={h:.6g})")

        # (a) narrow-band signed distance ------------------------------------------
        task = "(a) signed distance, band ±3"
        vdb = serve("openvdb", n)
        dist_args = ["--distance", str(HALF_WIDTH)]
        dist_out = os.path.join(workdir, f"volga_dist_{n}.nrrd")
        vsrv = None if volga.missing else volga.server(n, dist_args)
        bsrv = before.server(n, dist_args) if before else None
        log(f"  (a) volga warm-up, then {a.repeats} rounds of volga (fresh process, warm server) + OpenVDB")
        reports = interleaved(a.repeats, volga_runner(n, dist_args, dist_out, f"dist{n}"),
                              [s for s in (vsrv, bsrv, vdb) if s])
        vdb_npz = os.path.join(workdir, f"openvdb_{n}.npz")
        vdb.dump(vdb_npz)
        vdb.close()
        if bsrv:
            bsrv.close()
            bt = statistics.median(bsrv.times)
            rows.append(dict(n=n, task=task, tool="volga before (warm)", time=fmt_time(bt),
                             ratio=f"OpenVDB/this {statistics.median(vdb.times) / bt:.2f}"))
        va = volga_summary(reports, vsrv, os.path.join(workdir, f"volga_dist_{n}_served.nrrd"), dist_out)
        t = statistics.median(vdb.times)
        if va:
            ijk, vals, origin, spacing, note = volga_band(dist_out)
            details.append(f"volga distance N={n}: {note}; {va['report'].get('threads', '?')} threads per its report")
            pick = sample_rows(len(vals), a.sample)
            verr, vsign = distance_accuracy(origin + ijk[pick] * spacing, vals[pick], h, verts, tris)
            rows.append(dict(n=n, task=task, tool="**volga** (warm)", time=fmt_time(va["time"]), ratio="1",
                             voxels=f"{len(vals):,}", err=fmt_err(verr), sign=f"{vsign:.4f}", sep="—",
                             mem=f"{fmt_mem(va['mem'])} (all stages {fmt_mem(va['all_mem'])})"))
            rows.append(cold_row(n, task, va, "OpenVDB", t))
        else:
            rows.append(dict(n=n, task=task, tool="volga", time="missing"))
        z = np.load(vdb_npz)
        pick = sample_rows(len(z["values"]), a.sample)
        err, sign = distance_accuracy(z["centre0"] + z["ijk"][pick] * z["step"], z["values"][pick],
                                      h, verts, tris)
        rows.append(dict(n=n, task=task, tool="OpenVDB (2 threads)", time=fmt_time(t),
                         ratio=f"{t / va['time']:.2f}" if va else "n/a", voxels=f"{vdb.voxels:,}",
                         err=fmt_err(err), sign=f"{sign:.4f}", sep="—",
                         mem=fmt_mem(peer_peak_memory("openvdb", pythons["openvdb"], mesh, n))))

        # (b) binary 26-separating surface, (c) trimesh -------------------------------
        tools = ["open3d"]
        if a.skip_trimesh_above is None or n <= a.skip_trimesh_above:
            tools.append("trimesh")
        servers = [serve(tool, n) for tool in tools]
        sep_args = ["--separability", "26"]
        sep_out = os.path.join(workdir, f"volga_sep26_{n}.binvox")
        vsrv = None if volga.missing else volga.server(n, sep_args)
        bsrv = before.server(n, sep_args) if before else None
        log(f"  (b, c) volga warm-up, then {a.repeats} rounds of volga (fresh process, warm server) + "
            f"{' + '.join(tools)}")
        reports = interleaved(a.repeats, volga_runner(n, sep_args, sep_out, f"sep{n}"),
                              [s for s in [vsrv, bsrv] + servers if s])
        if bsrv:
            bsrv.close()
            bt = statistics.median(bsrv.times)
            rows.append(dict(n=n, task="(b) 26-separating surface", tool="volga before (warm)",
                             time=fmt_time(bt),
                             ratio=f"Open3D/this {statistics.median(servers[0].times) / bt:.2f}"))
        for s in servers:
            s.dump(os.path.join(workdir, f"{s.tool}_{n}.binvox"))
            s.close()
        vb = volga_summary(reports, vsrv, os.path.join(workdir, f"volga_sep26_{n}_served.binvox"), sep_out)
        if vb:
            cnt = len(read_binvox(sep_out)[0])
            details.append(f"volga 26-separating N={n}: {cnt} voxels in the .binvox, "
                           f"{vb['report'].get('voxels', {}).get('active', '?')} active per its report, "
                           f"{vb['report'].get('threads', '?')} threads")
            sep, det = validate(volga, vhelp, sep_out, mesh)
            if det:
                details.append(f"validate volga N={n}: `{det['cmd']}`: {det['summary']}")
            task = "(b) 26-separating surface"
            rows.append(dict(n=n, task=task, tool="**volga** (warm)", time=fmt_time(vb["time"]),
                             ratio="1", voxels=f"{cnt:,}", sep=sep,
                             mem=f"{fmt_mem(vb['mem'])} (all stages {fmt_mem(vb['all_mem'])})"))
            rows.append(cold_row(n, task, vb, "Open3D", statistics.median(servers[0].times)))
        else:
            rows.append(dict(n=n, task="(b) 26-separating surface", tool="volga", time="missing"))
        for s in servers:
            out = os.path.join(workdir, f"{s.tool}_{n}.binvox")
            cnt = len(read_binvox(out)[0])
            assert cnt == s.voxels, (s.tool, cnt, s.voxels)
            sep, det = validate(volga, vhelp, out, mesh)
            if det:
                details.append(f"validate {s.tool} N={n}: `{det['cmd']}`: {det['summary']}")
            t = statistics.median(s.times)
            label, task = {"open3d": ("Open3D VoxelGrid (1 thread)", "(b) 26-separating surface"),
                           "trimesh": ("trimesh voxelized (1 thread)", "(c) surface (subdivide)")}[s.tool]
            log(f"  {s.tool}: peak-memory run")
            rows.append(dict(n=n, task=task, tool=label, time=fmt_time(t),
                             ratio=f"{t / vb['time']:.2f}" if vb else "n/a", voxels=f"{cnt:,}", sep=sep,
                             mem=fmt_mem(peer_peak_memory(s.tool, pythons[s.tool], mesh, n))))
        if "trimesh" not in tools:
            rows.append(dict(n=n, task="(c) surface (subdivide)", tool="trimesh",
                             time=f"skipped (--skip-trimesh-above {a.skip_trimesh_above})"))
        print(table([x for x in rows if x["n"] == n]), flush=True)

    cmd = "bench/peers/run.sh" if os.environ.get("VOLGA_PEERS_VIA_RUN_SH") else "python bench/peers/bench.py"
    args = sys.argv[1:]
    body = [
        f"Produced by `{cmd}{' ' + shlex.join(args) if args else ''}` on {time.strftime('%Y-%m-%d')}, "
        f"volga {git_rev()}, mesh `{os.path.relpath(mesh, REPO)}` "
        f"({len(tris):,} triangles).",
        "",
        f"Machine: {machine()}; load average {load_at_start:.2f} at the start (the two cores "
        "are shared, so other work adds noise to every row alike).",
        "",
        "Peers: " + ", ".join(f"{k} {v}" for k, v in versions.items()) + ".",
        "",
    ]
    if volga.missing:
        body += [f"**volga rows are missing: {volga.missing}** — the peers were measured alone; "
                 "no volga figure is implied.", ""]
    body += [table(rows), "", NOTES.format(sample=a.sample), ""]
    if details:
        body += ["Details:", ""] + [f"- {d}" for d in details] + [""]
    text = "\n".join(body)
    print("\n" + text)
    if not a.no_docs:
        write_docs(a.docs, text)
        log(f"wrote {a.docs}")
    if not a.workdir:
        shutil.rmtree(workdir, ignore_errors=True)


if __name__ == "__main__":
    main()
