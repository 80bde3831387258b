# Type stubs of the Python module scanbench (docs/python.md), written by hand beside
# __init__.py: editors complete the functions and see their types.
import os
from typing import Any, Mapping, Sequence, TypedDict, Union

import numpy as np
import numpy.typing as npt
import pandas as pd

PathLike = Union[str, os.PathLike[str]]
Points = npt.NDArray[np.float32]  # shape (n, 3)
PointsIn = Union[npt.ArrayLike, Mapping[str, Any]]

class Error(Exception): ...
class ParamError(Error): ...
class InputError(Error): ...
class IoError(Error): ...

class StageArrays(TypedDict, total=False):
    points: Points
    normals: Points
    weights: npt.NDArray[np.float32]
    scan_ids: npt.NDArray[np.int32]
    sensor_origins: Points
    properties: dict[str, npt.NDArray[np.float32]]
    mixture: dict[str, npt.NDArray[np.float32]]
    mesh: dict[str, npt.NDArray[Any]]
    covariance_mesh: dict[str, npt.NDArray[Any]]
    record: dict[str, Any]

def version() -> str: ...
def registries(kind: str = ...) -> dict[str, list[dict[str, Any]]]: ...
def algorithms() -> list[dict[str, Any]]: ...
def metrics() -> list[dict[str, Any]]: ...
def datasets() -> list[dict[str, Any]]: ...
def scanners() -> list[dict[str, Any]]: ...
def scan(
    dataset: str = ...,
    mesh: PathLike = ...,
    preset: str = ...,
    params: Mapping[str, Any] | None = ...,
    seed: int = ...,
    threads: int = ...,
) -> StageArrays: ...
def run_algorithm(
    name: str,
    data: PointsIn,
    params: Mapping[str, Any] | None = ...,
    seed: int = ...,
    threads: int = ...,
) -> StageArrays: ...
def evaluate(
    points: PointsIn | PathLike | None = ...,
    output_mesh: PathLike | None = ...,
    dataset: str = ...,
    mesh: PathLike = ...,
    metrics: Sequence[str] | None = ...,
    metric_params: Mapping[str, Any] | None = ...,
    dataset_params: Mapping[str, Any] | None = ...,
    scan: PointsIn | PathLike | None = ...,
    seed: int = ...,
    threads: int = ...,
) -> dict[str, Any]: ...
def run(
    config: PathLike | Mapping[str, Any],
    out: PathLike,
    jobs: int = ...,
    resume: bool = ...,
    quiet: bool = ...,
) -> dict[str, Any]: ...
def load_records(folder: PathLike) -> list[dict[str, Any]]: ...
def load_results(folder: PathLike) -> pd.DataFrame: ...
