// dpc._core: a thin layer over dpc.h. It allocates numpy outputs, releases the GIL while C runs,
// and turns every dpc_status into the matching dpc.errors exception with the C message.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <algorithm>
#include <string>
#include <vector>

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
    Model(const std::string &path, int isa, unsigned threads, int backend, int input) {
        dpc_load_options options;
        dpc_load_options_init(&options);
        options.isa = static_cast<dpc_isa>(isa);
        options.threads = threads;
        options.backend = static_cast<dpc_backend>(backend);
        options.input = static_cast<dpc_input>(input);
        call([&] { return dpc_model_load_file(path.c_str(), &options, &model_); });
        call([&] { return dpc_model_get_info(model_, &info_); });
        call([&] { return dpc_model_get_backend(model_, &backend_); });
        call([&] { return dpc_model_get_input(model_, &input_); });
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
        d["backend"] = static_cast<int>(backend_);
        d["input"] = static_cast<int>(input_);
        d["device"] = std::string(dpc_model_device(model_));
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

    const dpc_model *handle() const { return model_; }

  private:
    dpc_model *model_ = nullptr;
    dpc_model_info info_{};
    dpc_backend backend_ = DPC_BACKEND_CPU;
    dpc_input input_ = DPC_INPUT_UNIFORM;
};

py::array_t<float> uniform(uint64_t seed, size_t m, size_t n) {
    py::array_t<float> out({m, n});
    float *p = out.mutable_data();
    call([&] { return dpc_uniform(seed, m, n, p); });
    return out;
}

py::array_t<float> stratified(uint64_t seed, size_t m, size_t n) {
    py::array_t<float> out({m, n});
    float *p = out.mutable_data();
    call([&] { return dpc_stratified(seed, m, n, p); });
    return out;
}

// ---- the sampler (dpc_sampler_*) -------------------------------------------------------------

using ArrayU32 = py::array_t<uint32_t, py::array::c_style>;

class Sampler {
  public:
    Sampler(const std::vector<const Model *> &models, uint32_t spp, uint32_t dims, uint64_t seed) {
        std::vector<const dpc_model *> handles;
        for (const Model *m : models) handles.push_back(m->handle());
        dpc_sampler_options o;
        dpc_sampler_options_init(&o);
        o.models = handles.data();
        o.n_models = static_cast<uint32_t>(handles.size());
        o.samples_per_pixel = spp;
        o.dimensions = dims;
        o.seed = seed;
        call([&] { return dpc_sampler_create(&o, &sampler_); });
        spp_ = spp;
        dims_ = dims;
    }
    ~Sampler() { dpc_sampler_free(sampler_); }
    Sampler(const Sampler &) = delete;
    Sampler &operator=(const Sampler &) = delete;

    // Lookups for arrays of equal size (the Python side broadcasts): out has `width` floats per entry.
    py::array_t<float> get(const ArrayU32 &x, const ArrayU32 &y, const ArrayU32 &index, const ArrayU32 &dim,
                           int width) const {
        const py::ssize_t n = x.size();
        if (y.size() != n || index.size() != n || dim.size() != n)
            raise_status(DPC_ERROR_INVALID_ARGUMENT, "x, y, index and dim must have the same size");
        py::array_t<float> out(width == 2 ? std::vector<py::ssize_t>{n, 2} : std::vector<py::ssize_t>{n});
        float *o = out.mutable_data();
        const uint32_t *xp = x.data(), *yp = y.data(), *ip = index.data(), *dp = dim.data();
        call([&] {
            dpc_status st = DPC_OK;
            for (py::ssize_t i = 0; i < n && st == DPC_OK; i++)
                st = width == 2 ? dpc_sampler_get_2d(sampler_, xp[i], yp[i], ip[i], dp[i], o + 2 * i)
                                : dpc_sampler_get_1d(sampler_, xp[i], yp[i], ip[i], dp[i], o + i);
            return st;
        });
        return out;
    }

    py::array_t<float> table(uint32_t t) const {
        const float *p = nullptr;
        call([&] { return dpc_sampler_table(sampler_, t, &p); });
        py::array_t<float> out({static_cast<py::ssize_t>(spp_), static_cast<py::ssize_t>(2)});
        std::copy(p, p + static_cast<size_t>(spp_) * 2, out.mutable_data());
        return out;
    }

  private:
    dpc_sampler *sampler_ = nullptr;
    uint32_t spp_ = 0, dims_ = 0;
};

py::array_t<float> sampler_mask() {
    py::array_t<float> out({32, 32, 3});
    std::copy(dpc_sampler_mask(), dpc_sampler_mask() + 32 * 32 * 3, out.mutable_data());
    return out;
}

// ---- training support: one filter layer in float64 (dpc_layer_forward / dpc_layer_backward) --

using Array64 = py::array_t<double, py::array::c_style>;

// A Python int (or numpy integer) as a 64-bit mask; anything else is an InvalidArgumentError.
uint64_t to_mask(py::handle h, const std::string &what) {
    py::object v = py::reinterpret_steal<py::object>(PyNumber_Index(h.ptr()));
    if (!v) {
        PyErr_Clear();
        raise_status(DPC_ERROR_INVALID_ARGUMENT, what + " must be an int");
    }
    if (v < py::int_(0)) raise_status(DPC_ERROR_INVALID_ARGUMENT, what + " must not be negative");
    unsigned long long out = PyLong_AsUnsignedLongLong(v.ptr());
    if (out == static_cast<unsigned long long>(-1) && PyErr_Occurred()) {
        PyErr_Clear();
        raise_status(DPC_ERROR_INVALID_ARGUMENT, what + " does not fit in 64 bits");
    }
    return out;
}

// The layer description and the batch shape of x: (m, n) is one set, (B, m, n) is B sets.
struct LayerCall {
    std::vector<uint64_t> masks;
    std::vector<double> radius;
    dpc_layer_desc desc{};
    size_t count = 1, m = 0;
    std::vector<py::ssize_t> shape;
};

LayerCall layer_call(const Array64 &x, const Array64 &kernels, const py::sequence &subspaces,
                     const std::vector<double> &radius, double eps, py::handle fixed) {
    LayerCall c;
    if (x.ndim() != 2 && x.ndim() != 3)
        raise_status(DPC_ERROR_INVALID_ARGUMENT, "x must have shape (m, n) or (batch, m, n)");
    if (kernels.ndim() != 2) raise_status(DPC_ERROR_INVALID_ARGUMENT, "kernels must have shape (s, b)");
    const size_t s = static_cast<size_t>(kernels.shape(0)), b = static_cast<size_t>(kernels.shape(1));
    const size_t n = static_cast<size_t>(x.shape(x.ndim() - 1));
    if (static_cast<size_t>(py::len(subspaces)) != s || radius.size() != s)
        raise_status(DPC_ERROR_INVALID_ARGUMENT,
                     "kernels has " + std::to_string(s) + " rows but subspaces has " +
                         std::to_string(py::len(subspaces)) + " and radius " + std::to_string(radius.size()) +
                         " entries: all three must agree");
    // Larger values would wrap in the uint32 fields; the C checks give the precise ranges.
    if (n > DPC_MAX_DIMS || s > 0xFFFFFFFFu || b > 0xFFFFFFFFu)
        raise_status(DPC_ERROR_INVALID_ARGUMENT, "x has " + std::to_string(n) + " dims (at most " +
                                                     std::to_string(DPC_MAX_DIMS) + ") or kernels is too large");
    for (size_t t = 0; t < s; t++) c.masks.push_back(to_mask(subspaces[t], "subspaces[" + std::to_string(t) + "]"));
    c.radius = radius;
    c.desc.dims = static_cast<uint32_t>(n);
    c.desc.n_subspaces = static_cast<uint32_t>(s);
    c.desc.bins = static_cast<uint32_t>(b);
    c.desc.subspaces = c.masks.data();
    c.desc.radius = c.radius.data();
    c.desc.eps = eps;
    c.desc.fixed = to_mask(fixed, "fixed");
    c.m = static_cast<size_t>(x.shape(x.ndim() - 2));
    c.count = x.ndim() == 3 ? static_cast<size_t>(x.shape(0)) : 1;
    c.shape.assign(x.shape(), x.shape() + x.ndim());
    return c;
}

Array64 layer_forward(const Array64 &x, const Array64 &kernels, const py::sequence &subspaces,
                      const std::vector<double> &radius, double eps, py::handle fixed, uint32_t threads) {
    LayerCall c = layer_call(x, kernels, subspaces, radius, eps, fixed);
    Array64 y(c.shape);
    double *yp = y.mutable_data();
    const double *xp = x.data(), *kp = kernels.data();
    call([&] { return dpc_layer_forward(&c.desc, kp, c.count, c.m, xp, yp, threads); });
    return y;
}

py::tuple layer_backward(const Array64 &x, const Array64 &kernels, const py::sequence &subspaces,
                         const std::vector<double> &radius, double eps, py::handle fixed, const Array64 &grad_y,
                         uint32_t threads) {
    LayerCall c = layer_call(x, kernels, subspaces, radius, eps, fixed);
    if (grad_y.ndim() != x.ndim() || !std::equal(c.shape.begin(), c.shape.end(), grad_y.shape()))
        raise_status(DPC_ERROR_INVALID_ARGUMENT, "grad_y must have the shape of x");
    Array64 gx(c.shape);
    Array64 gk({kernels.shape(0), kernels.shape(1)});
    double *gxp = gx.mutable_data(), *gkp = gk.mutable_data();
    const double *xp = x.data(), *kp = kernels.data(), *gyp = grad_y.data();
    call([&] { return dpc_layer_backward(&c.desc, kp, c.count, c.m, xp, gyp, gxp, gkp, threads); });
    return py::make_tuple(gx, gk);
}

void register_layer_training(py::module_ &mod) {
    mod.def("layer_forward", &layer_forward, py::arg("x"), py::arg("kernels"), py::arg("subspaces"),
            py::arg("radius"), py::arg("eps"), py::arg("fixed"), py::arg("threads"),
            "One PointFilter layer in float64: x (m, n) or (batch, m, n) -> y of the same shape.");
    mod.def("layer_backward", &layer_backward, py::arg("x"), py::arg("kernels"), py::arg("subspaces"),
            py::arg("radius"), py::arg("eps"), py::arg("fixed"), py::arg("grad_y"), py::arg("threads"),
            "Gradients of one PointFilter layer: (grad_x like x, grad_kernels (s, b) summed over sets).");
}

}  // namespace

PYBIND11_MODULE(_core, mod) {
    mod.doc() = "libdpc bindings (use the dpc package, not this module)";
    mod.attr("__version__") = dpc_version_string();
    mod.attr("FORMAT_VERSION") = DPC_FORMAT_VERSION;
    py::class_<Model>(mod, "Model")
        .def(py::init<const std::string &, int, unsigned, int, int>(), py::arg("path"), py::arg("isa"),
             py::arg("threads"), py::arg("backend"), py::arg("input"))
        .def("info", &Model::info)
        .def("metadata", &Model::metadata)
        .def("generate", &Model::generate, py::arg("seed"), py::arg("n_points"))
        .def("generate_batch", &Model::generate_batch, py::arg("seed"), py::arg("count"), py::arg("n_points"))
        .def("filter", &Model::filter, py::arg("points"));
    py::class_<Sampler>(mod, "Sampler")
        .def(py::init<const std::vector<const Model *> &, uint32_t, uint32_t, uint64_t>(), py::arg("models"),
             py::arg("spp"), py::arg("dims"), py::arg("seed"))
        .def("get", &Sampler::get, py::arg("x"), py::arg("y"), py::arg("index"), py::arg("dim"), py::arg("width"))
        .def("table", &Sampler::table, py::arg("t"));
    mod.def("sampler_mask", &sampler_mask);
    mod.def("uniform", &uniform, py::arg("seed"), py::arg("m"), py::arg("n"));
    mod.def("stratified", &stratified, py::arg("seed"), py::arg("m"), py::arg("n"));
    register_layer_training(mod);
}
