"""scanbench from Python: scan, run any registered algorithm, score with any registered metric,
run experiment configs, and load results folders as pandas DataFrames (docs/python.md).

Arrays go in and out as numpy: points are (n, 3) float32 arrays. Every function calls the same
code as the command line, so a result is the same bits as the command's for the same inputs,
seed and thread count. Errors are scanbench.Error (ParamError, InputError, IoError) carrying the
command line's one-line message.
"""
import json as _json
import os as _os
import pathlib as _pathlib
import shutil as _shutil
import tempfile as _tempfile

from . import _scanbench as _native
from ._scanbench import Error, InputError, IoError, ParamError  # noqa: F401

__all__ = [
    "Error", "ParamError", "InputError", "IoError", "version", "registries", "algorithms",
    "metrics", "datasets", "scanners", "scan", "run_algorithm", "evaluate", "run",
    "load_records", "load_results",
]


def version():
    """The version string of the scanbench build (as `scanbench --version` prints first)."""
    return _native.version()


def registries(kind=""):
    """What `scanbench list --json` prints, as a dict: "algorithms", "metrics", "datasets",
    "scanners", each a list of entries with "name", "doc" and "params" (declared parameters:
    name, type, default, min, max, unit, doc). `kind` keeps one of them."""
    return _json.loads(_native.registries_json(kind))


def algorithms():
    """The registered algorithms (list of dicts, see registries)."""
    return registries("algorithms")["algorithms"]


def metrics():
    """The registered metrics (list of dicts, see registries)."""
    return registries("metrics")["metrics"]


def datasets():
    """The registered datasets (list of dicts, see registries)."""
    return registries("datasets")["datasets"]


def scanners():
    """The scanner presets (list of dicts, see registries)."""
    return registries("scanners")["scanners"]


def scan(dataset="", mesh="", preset="", params=None, seed=0, threads=0):
    """A virtual scan of a registered dataset or a mesh file (`scanbench scan`).

    Returns a dict: "points" (n, 3) float32, "scan_ids", "sensor_origins", "properties"
    ("outlier", "clean_x", ...) and "record" (the scan's JSON record). `params` overrides scanner
    parameters by name (checked as declared)."""
    return _native.scan(dataset=str(dataset), mesh=str(mesh), preset=str(preset), params=params,
                        seed=seed, threads=threads)


def run_algorithm(name, data, params=None, seed=0, threads=0):
    """Runs a registered algorithm (`scanbench algo NAME`) on points in memory.

    `data` is an (n, 3) array or a dict with "points" and optionally "normals", "weights",
    "properties" and "mesh" ({"vertices", "faces"}). Returns a dict of the products ("points",
    "normals", "mixture", "mesh", ...) as numpy views, and "record": the effective parameters and
    the phase times."""
    return _native.run_algorithm(name, data, params=params, seed=seed, threads=threads)


def evaluate(points=None, output_mesh=None, dataset="", mesh="", metrics=None, metric_params=None,
             dataset_params=None, scan=None, seed=0, threads=0):
    """Scores an output against a ground truth (`scanbench eval`): every registered metric, or
    the named ones. The output is `points` (an (n, 3) array, a dict with "points", or a file) or
    `output_mesh` (a file); the ground truth a dataset name or a mesh file. Returns the flat JSON
    object of `scanbench eval --json` as a dict.

    Arrays are written to a temporary binary PLY (float32, as scanbench writes points) that the
    same code then reads as the command line reads its file."""
    with _tempfile.TemporaryDirectory(prefix="scanbench-py-") as tmp:
        req = {"dataset": str(dataset), "mesh": str(mesh), "seed": seed, "threads": threads,
               "metrics": list(metrics or []), "metric_params": metric_params or {},
               "dataset_params": dataset_params or {}}
        if points is not None:
            if isinstance(points, (str, _os.PathLike)):
                req["points"] = str(points)
            else:
                path = _os.path.join(tmp, "points.ply")
                _native.write_scan_ply(points, path)
                req["points"] = path
        if output_mesh is not None:
            req["output_mesh"] = str(output_mesh)
        if scan is not None:
            if isinstance(scan, (str, _os.PathLike)):
                req["scan"] = str(scan)
            else:
                path = _os.path.join(tmp, "scan.ply")
                _native.write_scan_ply(scan, path)
                req["scan"] = path
        return _native.evaluate_files(req)


def _binary():
    """The scanbench binary whose children run the jobs: $SCANBENCH_BINARY, the installed one
    beside this package (<prefix>/bin), the build tree's, or the one on PATH."""
    env = _os.environ.get("SCANBENCH_BINARY")
    if env:
        return env
    here = _pathlib.Path(__file__).resolve().parent
    for cand in (here.parents[3] / "bin" / "scanbench" if len(here.parents) > 3 else None,
                 _pathlib.Path(_native._build_binary)):
        if cand is not None and cand.is_file() and _os.access(cand, _os.X_OK):
            return str(cand)
    found = _shutil.which("scanbench")
    if found:
        return found
    raise IoError("scanbench: no scanbench binary found (set SCANBENCH_BINARY)")


def run(config, out, jobs=1, resume=False, quiet=True):
    """Runs an experiment config as `scanbench run CONFIG -o OUT` does: a file path (read as the
    command reads it: plugins, paths relative to its folder) or a dict in the experiment schema
    (docs/experiments.md). A declared parameter protocol is tuned first, as by the command.
    Returns the run's summary; the records are in `out` (load them with load_results)."""
    if isinstance(config, (str, _os.PathLike)):
        path, text = str(config), ""
    else:
        path, text = "", _json.dumps(config)
    return _native.run_experiment(path, text, str(out), _binary(), jobs=jobs, resume=resume,
                                  quiet=quiet)


def load_records(folder):
    """The records of a results folder (runs.jsonl, or the jobs' records), as a list of dicts."""
    return _json.loads(_native.load_records_json(str(folder)))


def load_results(folder):
    """A results folder as a pandas DataFrame: one row per job, with the columns of runs.csv (id,
    key, status, dataset, scanner, variant, point, seed, repeats, params.*, metrics.* for every
    numeric metric key, time.total_median_s, time.cpu_median_s, time.<phase>_median_s,
    peak_rss_mb, error), from the same table (values at full precision, NaN where none)."""
    import pandas as pd

    t = _json.loads(_native.records_table_json(str(folder)))
    return pd.DataFrame(t["rows"], columns=t["columns"])
