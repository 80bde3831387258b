"""The Python module against the command line (docs/python.md): the same bytes for the same
inputs, seed and thread count; parameters checked as declared, with the same one-line message;
arrays out as numpy views; the GIL released in long calls; a results folder as a DataFrame.

Run by ctest (tests/CMakeLists.txt: PYTHONPATH=build/python, SCANBENCH_BINARY=the binary)."""
import json
import os
import pathlib
import subprocess
import threading
import time

import numpy as np
import pytest

import scanbench as sb

BIN = os.environ["SCANBENCH_BINARY"]
DTYPES = {"float": "<f4", "float32": "<f4", "double": "<f8", "float64": "<f8", "int": "<i4",
          "int32": "<i4", "uint": "<u4", "uint32": "<u4", "uchar": "u1", "uint8": "u1",
          "char": "i1", "int8": "i1", "short": "<i2", "ushort": "<u2"}


def cli(*args, check=True):
    r = subprocess.run([BIN, *map(str, args)], capture_output=True, text=True)
    if check:
        assert r.returncode == 0, r.stderr
    return r


def read_ply_vertices(path):
    """The vertex element of a binary little-endian PLY as a numpy structured array (an oracle
    independent of scanbench's reader)."""
    data = pathlib.Path(path).read_bytes()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    header = data[:end].decode("ascii").splitlines()
    assert "format binary_little_endian 1.0" in header
    fields, count, in_vertex = [], 0, False
    for line in header:
        parts = line.split()
        if parts[:1] == ["element"]:
            in_vertex = parts[1] == "vertex"
            if in_vertex:
                count = int(parts[2])
        elif parts[:1] == ["property"] and in_vertex:
            assert parts[1] != "list"
            fields.append((parts[2], DTYPES[parts[1]]))
    return np.frombuffer(data, dtype=np.dtype(fields), count=count, offset=end)


def xyz(v):
    return np.stack([v["x"], v["y"], v["z"]], axis=1)


@pytest.fixture(scope="module")
def scan_file(tmp_path_factory):
    out = tmp_path_factory.mktemp("scan") / "scan.ply"
    cli("scan", "--dataset", "sphere", "--preset", "moderate", "--set", "views=3", "--set",
        "resolution=48", "--seed", 7, "--threads", 2, "-o", out)
    return out


def test_registries_are_what_list_prints():
    assert sb.registries() == json.loads(cli("list", "--json").stdout)
    names = [a["name"] for a in sb.algorithms()]
    assert "resample.wlop" in names and "filter.gpf" in names
    wlop = next(a for a in sb.algorithms() if a["name"] == "resample.wlop")
    assert {"name", "type", "default", "doc"} <= set(wlop["params"][0])


def test_scan_is_the_commands_scan(scan_file):
    s = sb.scan(dataset="sphere", preset="moderate", params={"views": 3, "resolution": 48},
                seed=7, threads=1)
    v = read_ply_vertices(scan_file)
    assert s["points"].dtype == np.float32 and s["points"].shape == (len(v), 3)
    assert np.array_equal(s["points"], xyz(v))  # bit for bit, at another thread count
    assert np.array_equal(s["properties"]["outlier"], v["outlier"])
    assert s["record"]["seed"] == 7 and s["record"]["input"]["dataset"] == "sphere"


def test_algorithm_is_the_commands_algorithm(scan_file, tmp_path):
    out = tmp_path / "wlop.ply"
    cli("algo", "resample.wlop", "-i", scan_file, "-o", out, "--set", "h=0.1", "--set",
        "iterations=5", "--seed", 3, "--threads", 2)
    pts = xyz(read_ply_vertices(scan_file))
    r = sb.run_algorithm("resample.wlop", pts, {"h": 0.1, "iterations": 5}, seed=3, threads=1)
    assert np.array_equal(r["points"], xyz(read_ply_vertices(out)))
    assert r["record"]["params"]["h"] == 0.1 and r["record"]["params"]["iterations"] == 5
    assert r["record"]["total_s"] > 0


def test_outputs_are_views_of_the_cpp_storage(scan_file):
    pts = xyz(read_ply_vertices(scan_file))
    r = sb.run_algorithm("normals.pca", pts, {"k": 10})
    for key in ("points", "normals"):
        a = r[key]
        assert a.dtype == np.float32 and a.shape == (len(pts), 3)
        assert not a.flags.owndata and a.base is not None and a.flags.c_contiguous
    assert np.allclose(np.linalg.norm(r["normals"], axis=1), 1.0, atol=1e-5)


def test_a_mixture_comes_out_as_arrays(scan_file):
    pts = xyz(read_ply_vertices(scan_file))
    r = sb.run_algorithm("mixture.hem", pts, seed=2)
    g = r["mixture"]
    k = len(g["weights"])
    assert 0 < k < len(pts)
    assert g["means"].shape == (k, 3) and g["covariances"].shape == (k, 6)
    assert g["means"].dtype == np.float32 and not g["means"].flags.owndata


def test_metric_is_the_commands_metric(scan_file, tmp_path):
    out = tmp_path / "eval.json"
    cli("eval", "--dataset", "sphere", "--points", scan_file, "--metrics",
        "accuracy.p2plane,accuracy.chamfer", "--seed", 5, "-o", out)
    want = json.loads(out.read_text())
    pts = read_ply_vertices(scan_file)
    got = sb.evaluate(points=xyz(pts), dataset="sphere",
                      metrics=["accuracy.p2plane", "accuracy.chamfer"], seed=5)
    for key in ("p2plane_mean_rel", "p2plane_rms_rel", "chamfer_rel", "fscore"):
        assert got[key] == want[key], key


def test_bad_parameter_raises_the_commands_message(scan_file, tmp_path):
    r = cli("algo", "resample.wlop", "-i", scan_file, "-o", tmp_path / "x.ply", "--set", "hh=1",
            check=False)
    assert r.returncode == 2
    line = r.stderr.strip().removeprefix("scanbench: ")
    with pytest.raises(sb.ParamError) as e:
        sb.run_algorithm("resample.wlop", np.zeros((4, 3), np.float32), {"hh": 1})
    assert str(e.value) == line
    with pytest.raises(sb.ParamError, match="unknown algorithm 'resample.wlopp'"):
        sb.run_algorithm("resample.wlopp", np.zeros((4, 3), np.float32))
    with pytest.raises(sb.ParamError, match=r"shape \(n, 3\)"):
        sb.run_algorithm("resample.wlop", np.zeros((4, 2), np.float32))
    assert issubclass(sb.ParamError, sb.Error)


def test_long_calls_release_the_gil(scan_file):
    pts = xyz(read_ply_vertices(scan_file))
    done = threading.Event()
    ticks = [0]

    def work():
        sb.run_algorithm("resample.wlop", pts, {"h": 0.1, "iterations": 40}, threads=1)
        done.set()

    t = threading.Thread(target=work)
    t0 = time.perf_counter()
    t.start()
    while not done.is_set():
        ticks[0] += 1  # Python code running beside the C++ call
        time.sleep(0.001)
    t.join()
    elapsed = time.perf_counter() - t0
    # Held GIL: the loop would not run until the call returns (one tick at most).
    assert elapsed < 0.02 or ticks[0] > 3


def test_run_and_load_results(tmp_path):
    config = {
        "scanbench_experiment": 1,
        "name": "py-run",
        "seed": 1,
        "repeats": 1,
        "datasets": [{"name": "sphere"}, {"name": "torus"}],
        "scanners": [{"preset": "moderate", "label": "small",
                      "params": {"views": 3, "resolution": 32}}],
        "variants": [{"label": "wlop", "algorithm": "resample.wlop",
                      "params": {"h": 0.1, "iterations": 3}}],
        "metrics": ["accuracy.p2plane"],
    }
    out = tmp_path / "run"
    s = sb.run(config, out, jobs=2)
    assert s["planned"] == 2 and s["by_status"] == {"ok": 2}
    df = sb.load_results(out)
    assert len(df) == 2 and list(df["status"]) == ["ok", "ok"]
    header = (out / "runs.csv").read_text().splitlines()[0].split(",")
    assert list(df.columns) == header
    assert "metrics.p2plane_mean_rel" in df.columns and df["metrics.p2plane_mean_rel"].notna().all()
    records = [json.loads(l) for l in (out / "runs.jsonl").read_text().splitlines()]
    by_id = {r["id"]: r for r in records}
    for _, row in df.iterrows():
        assert row["metrics.p2plane_mean_rel"] == by_id[row["id"]]["metrics"]["p2plane_mean_rel"]


def test_run_resolves_a_protocol_as_the_command_does(tmp_path):
    config = {
        "scanbench_experiment": 1,
        "name": "py-protocol",
        "seed": 1,
        "repeats": 1,
        "datasets": [{"name": "sphere"}],
        "scanners": [{"preset": "moderate", "label": "small",
                      "params": {"views": 3, "resolution": 32}}],
        "variants": [{"label": "wlop", "algorithm": "resample.wlop",
                      "params": {"iterations": 3}}],
        "metrics": ["accuracy.p2plane"],
        "protocol": {
            "tuning": {"datasets": [{"name": "torus"}], "seed": 2},
            "objective": {"quantity": "p2plane_mean_rel", "direction": "min"},
            "variants": {"wlop": {"resample.wlop.h": {"source": "tuned",
                                                       "range": [0.05, 0.1, 0.2]}}},
        },
    }
    file = tmp_path / "exp.json"
    file.write_text(json.dumps(config))
    cli("run", file, "-o", tmp_path / "cli", "-j", 2, "-q")
    sb.run(file, tmp_path / "py", jobs=2)
    want = json.loads((tmp_path / "cli" / "protocol.json").read_text())
    got = json.loads((tmp_path / "py" / "protocol.json").read_text())
    assert got == want
    h = [r["params"]["resample.wlop.h"] for r in sb.load_records(tmp_path / "py")]
    assert h and all(x == h[0] for x in h) and h[0] in (0.05, 0.1, 0.2)
    assert [r["metrics"] for r in sb.load_records(tmp_path / "py")] == \
        [r["metrics"] for r in sb.load_records(tmp_path / "cli")]
