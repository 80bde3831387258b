// The native part of the Python module `scanbench` (python/scanbench/__init__.py wraps it;
// docs/python.md). It calls the same pipelines as the command line (harness/pipelines/), so a
// result is the same bits as the command's for the same inputs, seed and thread count. Arrays go
// out as numpy views of the C++ storage (no copy: an Eigen 3 x n column-major matrix is an n x 3
// C-contiguous array) kept alive by the object that owns it; arrays coming in are copied once into
// Eigen storage, since the C++ types own their storage. JSON crosses as text (Python's json
// module parses it), which keeps numbers exact both ways. Long calls release the GIL.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "scanbench/core/errors.h"
#include "scanbench/core/io.h"
#include "scanbench/core/stage_data.h"
#include "scanbench/core/version.h"
#include "scanbench/harness/config/experiment.h"
#include "scanbench/harness/config/plugins.h"
#include "scanbench/harness/exec/eval.h"
#include "scanbench/harness/exec/runner.h"
#include "scanbench/harness/pipelines/algo_run.h"
#include "scanbench/harness/pipelines/registries.h"
#include "scanbench/harness/pipelines/run_local.h"
#include "scanbench/harness/pipelines/scan_run.h"
#include "scanbench/harness/results/finish.h"
#include "scanbench/harness/results/records.h"

namespace py = pybind11;
namespace fs = std::filesystem;
using scanbench::Json;

namespace {

/// Python's json.loads of a JSON text (numbers exact both ways, as nlohmann writes them).
py::object to_python(const Json& j) {
  return py::module_::import("json").attr("loads")(j.dump());
}
Json from_python(const py::object& o) {
  if (o.is_none()) return Json::object();
  return Json::parse(py::module_::import("json").attr("dumps")(o).cast<std::string>());
}

/// An n x k float32 (or int32) numpy view of column-major k x n storage owned by `owner`.
template <class T>
py::array view(const T* data, Eigen::Index cols, Eigen::Index rows, const py::object& owner) {
  if (cols == 0) return py::array_t<T>(std::vector<py::ssize_t>{0, rows});
  const std::vector<py::ssize_t> shape{static_cast<py::ssize_t>(cols),
                                       static_cast<py::ssize_t>(rows)};
  const std::vector<py::ssize_t> strides{static_cast<py::ssize_t>(rows * sizeof(T)),
                                         static_cast<py::ssize_t>(sizeof(T))};
  return py::array_t<T>(shape, strides, data, owner);
}
template <class T>
py::array view1(const T* data, Eigen::Index n, const py::object& owner) {
  const std::vector<py::ssize_t> shape{static_cast<py::ssize_t>(n)};
  const std::vector<py::ssize_t> strides{static_cast<py::ssize_t>(sizeof(T))};
  return py::array_t<T>(shape, strides, data, owner);
}

/// The stage data's kinds as a dict of numpy views: "points" (n x 3), "normals", "weights",
/// "scan_ids", "sensor_origins", "properties" {name: n}, "mixture" {...}, "mesh" {"vertices",
/// "faces"}, "covariance_mesh" {...}. The views share `owner`, which holds the data.
py::dict stage_dict(const std::shared_ptr<scanbench::StageData>& d) {
  const py::object owner = py::cast(d);
  py::dict out;
  const scanbench::PointCloud& c = d->points;
  if (c.size() > 0 || !d->mesh) {
    out["points"] = view<float>(c.positions.data(), c.positions.cols(), 3, owner);
    if (c.has_normals()) out["normals"] = view<float>(c.normals.data(), c.normals.cols(), 3, owner);
    if (c.has_weights()) out["weights"] = view1<float>(c.weights.data(), c.weights.size(), owner);
    if (c.has_scan_ids()) {
      out["scan_ids"] = view1<int>(c.scan_ids.data(), c.scan_ids.size(), owner);
    }
    if (c.sensor_origins.cols() > 0) {
      out["sensor_origins"] =
          view<float>(c.sensor_origins.data(), c.sensor_origins.cols(), 3, owner);
    }
    py::dict props;
    for (const auto& [name, v] : c.properties)
      props[py::str(name)] = view1<float>(v.data(), v.size(), owner);
    if (!c.properties.empty()) out["properties"] = props;
  }
  if (d->mixture) {
    const auto& m = *d->mixture;
    py::dict g;
    g["weights"] = view1<float>(m.weights.data(), m.weights.size(), owner);
    g["means"] = view<float>(m.means.data(), m.means.cols(), 3, owner);
    g["covariances"] = view<float>(m.covariances.data(), m.covariances.cols(), 6, owner);
    if (m.normal_axes.cols() > 0) {
      g["normal_axes"] = view<float>(m.normal_axes.data(), m.normal_axes.cols(), 3, owner);
      g["normal_spreads"] = view1<float>(m.normal_spreads.data(), m.normal_spreads.size(), owner);
    }
    out["mixture"] = g;
  }
  if (d->mesh) {
    py::dict m;
    m["vertices"] = view<float>(d->mesh->vertices.data(), d->mesh->vertices.cols(), 3, owner);
    m["faces"] = view<int>(d->mesh->faces.data(), d->mesh->faces.cols(), 3, owner);
    out["mesh"] = m;
  }
  if (d->covariance_mesh) {
    const auto& cm = *d->covariance_mesh;
    py::dict c;
    c["means"] = view<double>(cm.means.data(), cm.means.cols(), 3, owner);
    c["covariances"] = view<double>(cm.covariances.data(), cm.covariances.cols(), 6, owner);
    // Polygons as offsets into one index list (core/polygon_faces.h).
    c["face_offsets"] = view1<int>(cm.faces.offsets.data(),
                                   static_cast<Eigen::Index>(cm.faces.offsets.size()), owner);
    c["face_indices"] = view1<int>(cm.faces.indices.data(),
                                   static_cast<Eigen::Index>(cm.faces.indices.size()), owner);
    out["covariance_mesh"] = c;
  }
  return out;
}

/// An n x 3 array (any float dtype, any strides) copied into 3 x n float32 storage.
Eigen::Matrix3Xf matrix3x(const py::handle& a, const char* what) {
  const auto arr = py::array_t<float, py::array::c_style | py::array::forcecast>::ensure(a);
  if (!arr || arr.ndim() != 2 || arr.shape(1) != 3) {
    throw scanbench::ParamError(std::string("python: ") + what +
                                ": expected an array of shape (n, 3)");
  }
  Eigen::Matrix3Xf m(3, arr.shape(0));
  std::copy(arr.data(), arr.data() + arr.size(), m.data());
  return m;
}
Eigen::VectorXf vectorxf(const py::handle& a, Eigen::Index n, const char* what) {
  const auto arr = py::array_t<float, py::array::c_style | py::array::forcecast>::ensure(a);
  if (!arr || arr.ndim() != 1 || arr.shape(0) != n) {
    throw scanbench::ParamError(std::string("python: ") + what + ": expected an array of shape (" +
                                std::to_string(n) + ",)");
  }
  return Eigen::Map<const Eigen::VectorXf>(arr.data(), n);
}

/// The points of a dict {"points", "normals"?, "weights"?, "properties"?} or an n x 3 array.
scanbench::StageData stage_from(const py::object& data) {
  scanbench::StageData s;
  if (py::isinstance<py::dict>(data)) {
    const py::dict d = data.cast<py::dict>();
    if (!d.contains("points") && !d.contains("mesh")) {
      throw scanbench::ParamError("python: the input has neither 'points' nor 'mesh'");
    }
    if (d.contains("points")) s.points.positions = matrix3x(d["points"], "points");
    const Eigen::Index n = s.points.size();
    if (d.contains("normals")) s.points.normals = matrix3x(d["normals"], "normals");
    if (d.contains("weights")) s.points.weights = vectorxf(d["weights"], n, "weights");
    if (d.contains("properties")) {
      for (const auto& [k, v] : d["properties"].cast<py::dict>())
        s.points.properties[k.cast<std::string>()] = vectorxf(v, n, "properties");
    }
    if (d.contains("mesh")) {
      const py::dict m = d["mesh"].cast<py::dict>();
      scanbench::TriangleMesh mesh;
      mesh.vertices = matrix3x(m["vertices"], "mesh vertices");
      const auto f =
          py::array_t<int, py::array::c_style | py::array::forcecast>::ensure(m["faces"]);
      if (!f || f.ndim() != 2 || f.shape(1) != 3) {
        throw scanbench::ParamError("python: mesh faces: expected an array of shape (m, 3)");
      }
      mesh.faces.resize(3, f.shape(0));
      std::copy(f.data(), f.data() + f.size(), mesh.faces.data());
      s.mesh = std::move(mesh);
    }
  } else {
    s.points.positions = matrix3x(data, "points");
  }
  s.points.validate("python input");
  return s;
}

}  // namespace

PYBIND11_MODULE(_scanbench, m) {
  m.doc() = "scanbench's native module (use `import scanbench`)";
  // Errors: the C++ exception's one-line message, as the command line prints it.
  static py::exception<scanbench::Error> error(m, "Error");
  static py::exception<scanbench::ParamError> param_error(m, "ParamError", error.ptr());
  static py::exception<scanbench::InputError> input_error(m, "InputError", error.ptr());
  static py::exception<scanbench::IoError> io_error(m, "IoError", error.ptr());
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const scanbench::UnknownNameError& e) {
      PyErr_SetString(param_error.ptr(), e.what());
    } catch (const scanbench::ParamError& e) {
      PyErr_SetString(param_error.ptr(), e.what());
    } catch (const scanbench::InputError& e) {
      PyErr_SetString(input_error.ptr(), e.what());
    } catch (const scanbench::IoError& e) {
      PyErr_SetString(io_error.ptr(), e.what());
    } catch (const scanbench::Error& e) {
      PyErr_SetString(error.ptr(), e.what());
    }
  });
  py::class_<scanbench::StageData, std::shared_ptr<scanbench::StageData>>(m, "_StageData");

  m.def("version", [] { return std::string(scanbench::version_string()); });
  // The scanbench binary of the build this module was built in (the jobs' parent).
  m.attr("_build_binary") = SCANBENCH_PY_BUILD_BINARY;

  m.def(
      "registries_json",
      [](const std::string& kind) { return scanbench::harness::registries_json(kind).dump(); },
      py::arg("kind") = "");

  m.def(
      "scan",
      [](const std::string& dataset, const std::string& mesh, const std::string& preset,
         const py::object& params, std::uint64_t seed, int threads) {
        scanbench::harness::ScanRequest r;
        r.dataset = dataset;
        r.mesh = mesh;
        r.preset = preset;
        r.values = from_python(params);
        r.seed = seed;
        r.threads = threads;
        auto d = std::make_shared<scanbench::StageData>();
        Json record;
        {
          py::gil_scoped_release release;
          scanbench::scanner::Scan s = scanbench::harness::run_scan(r);
          d->points = std::move(s.cloud);
          record = std::move(s.record);
        }
        py::dict out = stage_dict(d);
        out["record"] = to_python(record);
        return out;
      },
      py::arg("dataset") = "", py::arg("mesh") = "", py::arg("preset") = "",
      py::arg("params") = py::none(), py::arg("seed") = 0, py::arg("threads") = 0);

  m.def(
      "write_scan_ply",
      [](const py::object& data, const std::string& path) {
        const scanbench::StageData s = stage_from(data);
        scanbench::write_point_cloud(s.points, path);
      },
      py::arg("data"), py::arg("path"));

  m.def(
      "run_algorithm",
      [](const std::string& name, const py::object& data, const py::object& params,
         std::uint64_t seed, int threads) {
        const scanbench::StageData in = stage_from(data);
        const Json given = from_python(params);
        auto d = std::make_shared<scanbench::StageData>();
        Json record = Json::object();
        {
          py::gil_scoped_release release;
          scanbench::harness::StepRun step =
              scanbench::harness::run_step(name, in, given, seed, threads);
          *d = std::move(step.output);
          record["algorithm"] = name;
          record["params"] = step.params;
          record["seed"] = seed;
          record["threads"] = threads;
          record["phases"] = step.phases;
          record["phases_cpu"] = step.phases_cpu;
          record["total_s"] = step.total_s;
        }
        py::dict out = stage_dict(d);
        out["record"] = to_python(record);
        return out;
      },
      py::arg("name"), py::arg("data"), py::arg("params") = py::none(), py::arg("seed") = 0,
      py::arg("threads") = 0);

  m.def(
      "evaluate_files",
      [](const py::object& request) {
        const Json j = from_python(request);
        scanbench::harness::EvalRequest r;
        r.dataset = j.value("dataset", std::string());
        r.mesh = j.value("mesh", std::string());
        r.points = j.value("points", std::string());
        r.output_mesh = j.value("output_mesh", std::string());
        r.scan = j.value("scan", std::string());
        r.dataset_params = j.value("dataset_params", Json::object());
        r.metric_params = j.value("metric_params", Json::object());
        r.metrics = j.value("metrics", std::vector<std::string>{});
        r.seed = j.value("seed", std::uint64_t{0});
        r.threads = j.value("threads", 0);
        scanbench::harness::EvalResult res;
        {
          py::gil_scoped_release release;
          res = scanbench::harness::evaluate_files(r);
        }
        return to_python(res.record);
      },
      py::arg("request"));

  m.def(
      "run_experiment",
      [](const std::string& config_file, const std::string& config_text, const std::string& out,
         const std::string& exe, int jobs, bool resume, bool quiet) {
        scanbench::harness::RunOptions o;
        o.out = out;
        o.jobs = jobs;
        o.resume = resume;
        o.quiet = quiet;
        o.command = "python scanbench.run";
        o.exe = exe;  // the jobs run in children of the scanbench binary, not of python
        Json summary = Json::object();
        {
          py::gil_scoped_release release;
          // A file as `scanbench run` reads it (plugins, paths relative to its folder); a dict
          // as a config without a folder.
          scanbench::harness::Experiment e;
          if (!config_file.empty()) {
            e = scanbench::harness::load_experiment(config_file);
          } else {
            const Json config = Json::parse(config_text);
            scanbench::harness::load_config_plugins(config, "<python dict>");
            e = scanbench::harness::parse_experiment(config, "<python dict>");
          }
          const scanbench::harness::RunSummary s = scanbench::harness::run_local(e, o);
          scanbench::harness::finish_run(o.out);
          summary["planned"] = s.planned;
          summary["skipped"] = s.skipped;
          summary["ran"] = s.ran;
          summary["by_status"] = s.by_status;
          summary["out"] = o.out.string();
        }
        return to_python(summary);
      },
      py::arg("config_file"), py::arg("config_text"), py::arg("out"), py::arg("exe"),
      py::arg("jobs") = 1, py::arg("resume") = false, py::arg("quiet") = true);

  m.def(
      "records_table_json",
      [](const std::string& dir) {
        return scanbench::harness::records_table(scanbench::harness::load_records(dir)).dump();
      },
      py::arg("dir"));

  m.def(
      "load_records_json",
      [](const std::string& dir) {
        Json a = Json::array();
        for (auto& r : scanbench::harness::load_records(dir))
          a.push_back(std::move(r));
        return a.dump();
      },
      py::arg("dir"));
}
