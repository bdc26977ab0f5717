// The Python front door (`btfstudio._core`, docs/python.md): BTF files behind the Decoder API as
// numpy arrays, and every declared request run through ops::run with a progress callback and
// cancellation through the run context. No use case is implemented here: a third front door
// over the same declarations and the same engine functions as `btfsim` and the studio.
#include <btf/compress/cbtf.h>
#include <btf/compress/codec.h>
#include <btf/compress/lookup.h>
#include <btf/compress/mip.h>
#include <btf/core/progress.h>
#include <btf/core/sysinfo.h>
#include <btf/directions/direction_set.h>
#include <btf/geometry/tile_builder.h>
#include <btf/io/image_io.h>
#include <btf/scene/scene.h>
#include <btf/ops/ops.h>
#include <btf/store/btf_store.h>
#include <btf/store/levels.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <exception>
#include <memory>
#include <mutex>
#include <thread>

namespace py = pybind11;
using namespace btf;

namespace {

// Exceptions visible from Python (created in PYBIND11_MODULE).
PyObject* g_error = nullptr;
PyObject* g_cancelled = nullptr;

// Runs fn with the GIL released, translating the engine's errors to the module's exceptions.
template <class F>
auto released(F&& fn) {
  py::gil_scoped_release nogil;
  return fn();
}

double deg(double r) {
  return r * 180.0 / kPi;
}
double rad(double d) {
  return d * kPi / 180.0;
}

// A BTF file opened at any of its levels (each opened once, on first use).
class PyBtf {
 public:
  PyBtf(std::string path, const std::string& memoryBudget)
      : m_path(std::move(path)), m_budget(parseBytes(memoryBudget)) {
    released([&] {
      m_compressed = isCompressedFile(m_path);
      if (m_compressed) {
        CompressedBtf c = readCompressed(m_path);
        m_pyramid = int(c.levels.size());
        m_codec = c.codec;
        m_vmf = c.vmf();  // its own visibility map (8-bit coded), when it carries one
      }
      m_levels.resize(1);
      m_levels[0] = openBtfLevel(m_path, 0, m_budget);
      return 0;
    });
    const BtfInfo& I = m_levels[0]->info();
    m_levels.resize(m_pyramid > 0 ? size_t(m_pyramid) : mipLevels(I.nu, I.nv).size());
    m_dense.resize(m_levels.size());
    if (!m_compressed) {
      m_reader = std::make_unique<BtfReader>(m_path);
      m_codec = "raw";
    }
  }

  const BtfInfo& info() const { return m_levels[0]->info(); }
  const std::string& path() const { return m_path; }
  const std::string& codec() const { return m_codec; }
  int levels() const { return int(m_levels.size()); }
  bool pyramid() const { return m_pyramid > 0; }

  // Levels and dense values are made outside the lock with the GIL released, then published
  // under it (never wait on the lock while another thread needs the GIL back).
  const Decoder& level(int k) {
    if (k < 0 || k >= levels())
      throw Error(m_path + ": level " + std::to_string(k) + " is outside 0.." +
                  std::to_string(levels() - 1));
    {
      std::lock_guard lock(m_mutex);
      if (m_levels[size_t(k)]) return *m_levels[size_t(k)];
    }
    std::shared_ptr<const Decoder> d = released([&] { return openBtfLevel(m_path, k, m_budget); });
    std::lock_guard lock(m_mutex);
    if (!m_levels[size_t(k)]) m_levels[size_t(k)] = std::move(d);
    return *m_levels[size_t(k)];
  }

  // Every value of level k in memory, read once, when it fits the memory budget (else null: the
  // lookups then ask the decoder value by value).
  const std::vector<float>* dense(int k) {
    const Decoder& d = level(k);
    const BtfInfo& I = d.info();
    const double bytes = double(I.texels()) * double(I.texelBytes());
    if (m_budget > 0 && bytes > double(m_budget)) return nullptr;
    {
      std::lock_guard lock(m_mutex);
      if (m_dense[size_t(k)]) return m_dense[size_t(k)].get();
    }
    auto all = std::make_unique<std::vector<float>>(released([&] { return allValues(d); }));
    std::lock_guard lock(m_mutex);
    if (!m_dense[size_t(k)]) m_dense[size_t(k)] = std::move(all);
    return m_dense[size_t(k)].get();
  }

  py::array_t<double> directions() const {
    const BtfInfo& I = info();
    py::array_t<double> a({I.nDirs(), 2});
    auto m = a.mutable_unchecked<2>();
    for (int k = 0; k < I.nDirs(); ++k)
      m(k, 0) = I.dirsDeg[size_t(k)][0], m(k, 1) = I.dirsDeg[size_t(k)][1];
    return a;
  }

  // The spatial image at one pair, rows top first as `btfsim slice` writes its EXR.
  py::array_t<float> slice(std::pair<double, double> view, std::pair<double, double> light,
                           int lev) {
    const Decoder& d = level(lev);
    checkAngles(view, "view");
    checkAngles(light, "light");
    const BtfInfo& I = d.info();
    const std::vector<float> img = released([&] {
      return spatialSlice(d, rad(view.first), rad(view.second), rad(light.first),
                          rad(light.second));
    });
    py::array_t<float> a({I.nv, I.nu, 3});
    float* o = a.mutable_data();
    for (int j = 0; j < I.nv; ++j)
      std::memcpy(o + size_t(j) * I.nu * 3, img.data() + size_t(I.nv - 1 - j) * I.nu * 3,
                  size_t(I.nu) * 3 * sizeof(float));
    return a;
  }

  // views × lights × RGB of texel (u, v) (column u, row v from the bottom, as the store).
  py::array_t<float> texel(int u, int v, int lev) {
    const Decoder& d = level(lev);
    const BtfInfo& I = d.info();
    if (u < 0 || v < 0 || u >= I.nu || v >= I.nv)
      throw Error("texel (" + std::to_string(u) + ", " + std::to_string(v) + ") is outside the " +
                  std::to_string(I.nu) + "x" + std::to_string(I.nv) + " texel grid of level " +
                  std::to_string(lev));
    py::array_t<float> a({I.nDirs(), I.nDirs(), 3});
    float* o = a.mutable_data();
    released([&] {
      d.texel(int64_t(v) * I.nu + u, o);
      return 0;
    });
    return a;
  }

  py::array_t<float> brdf(int lev) {
    const Decoder& d = level(lev);
    const int n = d.info().nDirs();
    const std::vector<float> avg = released([&] { return tileAverage(d); });
    py::array_t<float> a({n, n, 3});
    std::memcpy(a.mutable_data(), avg.data(), avg.size() * sizeof(float));
    return a;
  }

  py::array_t<float> values(
      const py::array_t<double, py::array::c_style | py::array::forcecast>& uv,
      const py::array_t<double, py::array::c_style | py::array::forcecast>& wi,
      const py::array_t<double, py::array::c_style | py::array::forcecast>& wo, int lev) {
    auto shape = [](const py::array& a, ssize_t cols, const char* name) {
      if (a.ndim() != 2 || a.shape(1) != cols)
        throw Error(std::string("values: ") + name + " must be an N x " + std::to_string(cols) +
                    " array (got " + std::to_string(a.ndim()) + " dimensions)");
      return a.shape(0);
    };
    const ssize_t n = shape(uv, 2, "uv");
    if (shape(wi, 3, "wi") != n || shape(wo, 3, "wo") != n)
      throw Error("values: uv, wi and wo must have the same number of rows");
    const Decoder& d = level(lev);
    py::array_t<float> out({n, ssize_t(3)});
    float* o = out.mutable_data();
    const double *pu = uv.data(), *pi = wi.data(), *po = wo.data();
    // A continuous decoder (neural) is read at the pair itself, as `btfsim render` reads it;
    // the others' values are interpolated between the set's directions, from memory when they fit.
    const std::vector<float>* all = d.continuous() ? nullptr : dense(lev);
    released([&] {
      if (all)
        evaluateBatch(d.info(), all->data(), size_t(n), pu, pi, po, o);
      else
        evaluateBatch(d, size_t(n), pu, pi, po, o);
      return 0;
    });
    return out;
  }

  // The visibility map: directions × nv × nu × (coverage, mean depth), rows bottom first as the
  // store — a raw store's, or the one a .cbtf carries (8-bit coded); None for a flat tile or a
  // .cbtf written before the files carried it.
  py::object vmf() {
    const BtfInfo& I = info();
    if (m_compressed) {
      if (m_vmf.empty()) return py::none();
      py::array_t<float> a({I.nDirs(), I.nv, I.nu, 2});
      std::memcpy(a.mutable_data(), m_vmf.data(), m_vmf.size() * sizeof(float));
      return py::object(std::move(a));
    }
    if (!m_reader || !I.hasVmf) return py::none();
    py::array_t<float> a({I.nDirs(), I.nv, I.nu, 2});
    float* o = a.mutable_data();
    released([&] {
      for (int k = 0; k < I.nDirs(); ++k) {
        const auto m = m_reader->readVmf(k);
        std::memcpy(o + size_t(k) * m.size(), m.data(), m.size() * sizeof(float));
      }
      return 0;
    });
    return py::object(std::move(a));
  }

 private:
  static void checkAngles(const std::pair<double, double>& a, const char* what) {
    if (!std::isfinite(a.first) || !std::isfinite(a.second) || a.first < 0 || a.first >= 90)
      throw Error(std::string(what) + ": θ must be in [0, 90) degrees and φ finite");
  }

  std::string m_path;
  uint64_t m_budget;
  bool m_compressed = false;
  int m_pyramid = 0;
  std::string m_codec;
  std::mutex m_mutex;
  std::vector<std::shared_ptr<const Decoder>> m_levels;
  std::unique_ptr<BtfReader> m_reader;
  std::vector<float> m_vmf;  // a .cbtf's decoded visibility map
  std::vector<std::unique_ptr<std::vector<float>>> m_dense;
};

// Runs a request on a worker thread; this thread polls its progress, calls the Python callbacks
// with the GIL held, and cancels through the run context when a callback returns False, raises,
// or Ctrl-C arrives. Returns the report's JSON as `--json` prints it.
py::object runRequest(const std::string& command,
                      const std::vector<std::pair<std::string, std::string>>& options,
                      const py::object& progress, const py::object& notes, bool keepPartial) {
  ops::Request req(command);
  for (const auto& [k, v] : options) req.set(k, v);
  req.validate();

  CancelToken cancel;
  ProgressState state;
  RunContext ctx;
  ctx.cancel = &cancel;
  ctx.progress = false;
  ctx.keepPartial = keepPartial;
  std::mutex noteMutex;
  std::vector<std::string> pendingNotes;
  std::string json;
  std::exception_ptr failure;
  std::atomic<bool> done{false};
  std::thread worker([&] {
    ProgressState* prev = ProgressReporter::observe(&state);
    try {
      const ops::Report rep = ops::run(req, ctx, [&](const std::string& s) {
        std::lock_guard lock(noteMutex);
        pendingNotes.push_back(s);
      });
      json = rep.json.dump();
    } catch (...) {
      failure = std::current_exception();
    }
    ProgressReporter::observe(prev);
    done = true;
  });

  // An exception raised by a callback or Ctrl-C: the run is cancelled, then it is re-raised.
  std::unique_ptr<py::error_already_set> pyFailure;
  auto flush = [&] {
    std::vector<std::string> lines;
    {
      std::lock_guard lock(noteMutex);
      lines.swap(pendingNotes);
    }
    if (!notes.is_none())
      for (const auto& l : lines) notes(l);
    if (!progress.is_none()) {
      const py::object r = progress(state.currentStage(), state.done.load(), state.total.load());
      if (!r.is_none() && !r.cast<bool>()) cancel.cancel();
    }
  };
  while (!done) {
    {
      py::gil_scoped_release nogil;
      for (int k = 0; k < 10 && !done; ++k)
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    if (pyFailure) continue;
    if (PyErr_CheckSignals() != 0) {
      cancel.cancel();
      pyFailure = std::make_unique<py::error_already_set>();
      continue;
    }
    try {
      flush();
    } catch (py::error_already_set& e) {
      cancel.cancel();
      pyFailure = std::make_unique<py::error_already_set>(std::move(e));
    }
  }
  {
    py::gil_scoped_release nogil;
    worker.join();
  }
  if (!pyFailure) try {
      flush();
    } catch (py::error_already_set& e) {
      pyFailure = std::make_unique<py::error_already_set>(std::move(e));
    }
  if (pyFailure) throw std::move(*pyFailure);
  if (failure) std::rethrow_exception(failure);
  return py::module_::import("json").attr("loads")(json);
}

py::list commandDecls() {
  py::list out;
  for (const auto& c : ops::commands()) {
    py::dict d;
    d["name"] = c.name;
    d["doc"] = c.doc;
    d["positional"] = c.positional;
    py::list opts;
    for (const auto& p : c.options) {
      py::dict o;
      o["name"] = p.name;
      o["option"] = ops::optionName(c, p.name);
      o["type"] = paramTypeName(p.type);
      o["default"] = p.def.empty() ? py::cast(p.defStr) : py::cast(p.def);
      o["min"] = p.min;
      o["max"] = p.max;
      o["required"] = p.required;
      o["choices"] = p.choices;
      o["doc"] = p.doc;
      o["repeatable"] = p.repeatable;
      o["scene_key"] = c.sceneKeys.count(p.name) != 0;
      opts.append(o);
    }
    d["options"] = opts;
    out.append(d);
  }
  return out;
}

// The tile's micro-geometry as the simulator builds it: for renderers of our own (the Mitsuba
// reference of docs/render.md) that trace the real relief instead of the BTF.
py::dict tileGeometry(const std::string& path) {
  Scene scene;
  TileGeometry g;
  released([&] {
    scene = loadScene(path);
    g = buildTileGeometry(scene);
    return 0;
  });
  const size_t nv = g.mesh.pos.size(), nt = g.mesh.tri.size();
  py::array_t<float> pos({nv, size_t(3)}), nrm({nv, size_t(3)});
  py::array_t<uint32_t> tri({nt, size_t(3)});
  py::array_t<uint16_t> mat(nt);
  for (size_t i = 0; i < nv; ++i)
    for (int c = 0; c < 3; ++c) {
      pos.mutable_at(i, c) = g.mesh.pos[i][c];
      nrm.mutable_at(i, c) = g.mesh.nrm.empty() ? 0.f : g.mesh.nrm[i][c];
    }
  for (size_t t = 0; t < nt; ++t) {
    for (int c = 0; c < 3; ++c) tri.mutable_at(t, c) = g.mesh.tri[t][c];
    mat.mutable_at(t) = g.triMaterial[t];
  }
  py::dict d;
  d["size"] = std::pair<double, double>(g.Lx, g.Ly);
  d["positions"] = pos;
  d["normals"] = nrm;
  d["triangles"] = tri;
  d["materials"] = mat;
  d["z_range"] = std::pair<float, float>(g.zmin, g.zmax);
  std::vector<std::string> names;
  for (const auto& md : scene.materials) names.push_back(md.name);
  d["material_names"] = names;
  d["scene_json"] = sceneToJson(scene);
  return d;
}

}  // namespace

PYBIND11_MODULE(_core, m) {
  m.doc() = "BTF Studio's engine: BTF files as numpy arrays, and the requests of btfsim.";
  g_error = PyErr_NewExceptionWithDoc("btfstudio.BtfError",
                                      "An error of the engine, with btfsim's one-line message.",
                                      PyExc_RuntimeError, nullptr);
  g_cancelled = PyErr_NewExceptionWithDoc(
      "btfstudio.Cancelled", "A run cancelled through its run context.", g_error, nullptr);
  m.attr("BtfError") = py::handle(g_error);
  m.attr("Cancelled") = py::handle(g_cancelled);
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const Cancelled& e) {
      PyErr_SetString(g_cancelled, e.what());
    } catch (const Error& e) {
      PyErr_SetString(g_error, e.what());
    }
  });

  py::class_<PyBtf>(m, "Btf", "A .btf store or a .cbtf file of any codec, at any of its levels.")
      .def(py::init<std::string, std::string>(), py::arg("path"), py::arg("memory_budget") = "4G")
      .def_property_readonly("path", &PyBtf::path)
      .def_property_readonly("codec", &PyBtf::codec, "'raw' for a .btf store, else the codec")
      .def_property_readonly("levels", &PyBtf::levels,
                             "texel levels that open: a pyramid's own, else every box level")
      .def_property_readonly("pyramid", &PyBtf::pyramid)
      .def_property_readonly("nu", [](const PyBtf& b) { return b.info().nu; })
      .def_property_readonly("nv", [](const PyBtf& b) { return b.info().nv; })
      .def_property_readonly("texels", [](const PyBtf& b) { return b.info().texels(); })
      .def_property_readonly("direction_set", [](const PyBtf& b) { return b.info().directionSet; })
      .def_property_readonly("directions", &PyBtf::directions,
                             "N x 2 (θ, φ) in degrees, shared by views and lights")
      .def_property_readonly("header", [](const PyBtf& b) { return infoToJson(b.info()); })
      .def("level_size",
           [](PyBtf& b, int k) {
             const BtfInfo& I = b.level(k).info();
             return std::pair<int, int>(I.nu, I.nv);
           })
      .def("slice", &PyBtf::slice, py::arg("view"), py::arg("light"), py::arg("level") = 0)
      .def("texel", &PyBtf::texel, py::arg("u"), py::arg("v"), py::arg("level") = 0)
      .def("brdf", &PyBtf::brdf, py::arg("level") = 0)
      .def("values", &PyBtf::values, py::arg("uv"), py::arg("wi"), py::arg("wo"),
           py::arg("level") = 0)
      .def("vmf", &PyBtf::vmf);

  m.def("run_request", &runRequest, py::arg("command"), py::arg("options"),
        py::arg("progress") = py::none(), py::arg("notes") = py::none(),
        py::arg("keep_partial") = false);
  m.def(
      "read_image",
      [](const std::string& path) {
        int w = 0, h = 0;
        const std::vector<float> px = released([&] { return readRgbImage(path, &w, &h); });
        py::array_t<float> a({h, w, 3});
        std::memcpy(a.mutable_data(), px.data(), px.size() * sizeof(float));
        return a;
      },
      py::arg("path"), "An EXR, PNG or JPEG as H x W x 3 float32, top row first (linear for EXR).");
  m.def("tile_geometry", &tileGeometry, py::arg("scene"),
        "The scene's tile as the simulator builds it: positions, shading normals, triangles, "
        "material index per triangle, the tile's size and the canonical scene JSON.");
  m.def("commands", &commandDecls, "Every command's declaration (options, types, ranges, docs).");
  (void)deg;
}
