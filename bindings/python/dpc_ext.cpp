// dpc._core: a thin layer over dpc.h. It allocates numpy outputs, releases the GIL while C runs,
// and turns every dpc_status into the matching dpc.errors exception with the C message.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <string>

#include "dpc/dpc.h"

namespace py = pybind11;

namespace {

[[noreturn]] void raise_status(dpc_status status, const std::string &message) {
    py::object errors = py::module_::import("dpc.errors");
    py::object cls = errors.attr("BY_STATUS").attr("get")(static_cast<int>(status), errors.attr("DpcError"));
    PyErr_SetObject(cls.ptr(), py::str(message).ptr());
    throw py::error_already_set();
}

// Call f with the GIL released; raise on failure (the message is read on the same thread).
template <class F>
void call(F &&f) {
    dpc_status status;
    std::string message;
    {
        py::gil_scoped_release release;
        status = f();
        if (status != DPC_OK) message = dpc_last_error();
    }
    if (status != DPC_OK) raise_status(status, message);
}

class Model {
  public:
    Model(const std::string &path, int isa, unsigned threads) {
        dpc_load_options options;
        dpc_load_options_init(&options);
        options.isa = static_cast<dpc_isa>(isa);
        options.threads = threads;
        call([&] { return dpc_model_load_file(path.c_str(), &options, &model_); });
        call([&] { return dpc_model_get_info(model_, &info_); });
    }
    ~Model() { dpc_model_free(model_); }
    Model(const Model &) = delete;
    Model &operator=(const Model &) = delete;

    py::dict info() const {
        py::dict d;
        d["dims"] = info_.dims;
        d["n_points"] = info_.n_points;
        d["layers"] = info_.layers;
        py::list axes, shape;
        for (uint32_t g = 0; g < info_.grid_dims; g++) {
            axes.append(info_.grid_axis[g]);
            shape.append(info_.grid_shape[g]);
        }
        d["grid_axes"] = axes;
        d["grid_shape"] = shape;
        d["isa"] = static_cast<int>(info_.isa);
        d["threads"] = info_.threads;
        return d;
    }

    py::dict metadata() const {
        py::dict d;
        for (size_t i = 0, n = dpc_model_metadata_count(model_); i < n; i++) {
            const char *k, *v;
            call([&] { return dpc_model_metadata_at(model_, i, &k, &v); });
            d[py::str(k)] = py::str(v);
        }
        return d;
    }

    py::array_t<float> generate(uint64_t seed, size_t n_points) const {
        size_t m = n_points ? n_points : info_.n_points;
        py::array_t<float> out({m, static_cast<size_t>(info_.dims)});
        float *p = out.mutable_data();
        call([&] { return dpc_generate_n(model_, seed, n_points, p); });
        return out;
    }

    py::array_t<float> generate_batch(uint64_t seed, size_t count, size_t n_points) const {
        size_t m = n_points ? n_points : info_.n_points;
        py::array_t<float> out({count, m, static_cast<size_t>(info_.dims)});
        float *p = out.mutable_data();
        call([&] { return dpc_generate_batch(model_, seed, count, n_points, p); });
        return out;
    }

    void filter(py::array_t<float, py::array::c_style> points) const {
        if (points.ndim() != 2 || points.shape(1) != static_cast<py::ssize_t>(info_.dims))
            raise_status(DPC_ERROR_INVALID_ARGUMENT, "points must have shape (m, dims)");
        if (!points.writeable()) raise_status(DPC_ERROR_INVALID_ARGUMENT, "points must be writeable");
        size_t m = static_cast<size_t>(points.shape(0));
        float *p = points.mutable_data();
        call([&] { return dpc_filter(model_, m, p); });
    }

  private:
    dpc_model *model_ = nullptr;
    dpc_model_info info_{};
};

py::array_t<float> uniform(uint64_t seed, size_t m, size_t n) {
    py::array_t<float> out({m, n});
    float *p = out.mutable_data();
    call([&] { return dpc_uniform(seed, m, n, p); });
    return out;
}

}  // namespace

PYBIND11_MODULE(_core, mod) {
    mod.doc() = "libdpc bindings (use the dpc package, not this module)";
    mod.attr("__version__") = dpc_version_string();
    mod.attr("FORMAT_VERSION") = DPC_FORMAT_VERSION;
    py::class_<Model>(mod, "Model")
        .def(py::init<const std::string &, int, unsigned>(), py::arg("path"), py::arg("isa"), py::arg("threads"))
        .def("info", &Model::info)
        .def("metadata", &Model::metadata)
        .def("generate", &Model::generate, py::arg("seed"), py::arg("n_points"))
        .def("generate_batch", &Model::generate_batch, py::arg("seed"), py::arg("count"), py::arg("n_points"))
        .def("filter", &Model::filter, py::arg("points"));
    mod.def("uniform", &uniform, py::arg("seed"), py::arg("m"), py::arg("n"));
}
