// dpc._core: a thin layer over dpc.h. It allocates numpy outputs, releases the GIL while C runs,
// and turns every dpc_status into the matching dpc.errors exception with the C message.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
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
template <class F> void call(F &&f) {
    dpc_status status;
    std::string message;
    {
        py::gil_scoped_release release;
        status = f();
        if (status != DPC_OK) message = dpc_last_error();
    }
    if (status != DPC_OK) raise_status(status, message);
}

// ---- long calls off the Python thread: Ctrl-C, progress, no partial output --------------------

// One long libdpc call (a generate request, a sampler's creation), run on a worker thread so
// that the calling thread can notice Ctrl-C (PyErr_CheckSignals) and report progress while
// libdpc works. The work owns its output and keeps the models alive: if the worker has not
// stopped shortly after a cancel, it is detached and frees both when libdpc returns, so nothing
// outlives what it uses.
struct Work {
    std::atomic<bool> cancel{false};
    std::atomic<uint64_t> done{0}, total{0};
    std::mutex mu;
    std::condition_variable cv;
    bool finished = false;
    dpc_status status = DPC_OK;
    std::string message;
    virtual ~Work() = default;
    virtual dpc_status run() = 0; // on the worker thread; progress through work_progress
};

int work_progress(void *user, uint64_t done, uint64_t total) {
    Work *w = static_cast<Work *>(user);
    w->done.store(done);
    w->total.store(total);
    return w->cancel.load() ? 1 : 0;
}

void work_thread(const std::shared_ptr<Work> &w) {
    const dpc_status st = w->run();
    std::string msg = st != DPC_OK ? dpc_last_error() : "";
    {
        std::lock_guard<std::mutex> g(w->mu);
        w->status = st;
        w->message = std::move(msg);
        w->finished = true;
    }
    w->cv.notify_all();
}

// Wait (GIL released) up to `ms` milliseconds for the work; whether it finished.
bool work_wait(Work &w, int ms) {
    py::gil_scoped_release release;
    std::unique_lock<std::mutex> lk(w.mu);
    return w.cv.wait_for(lk, std::chrono::milliseconds(ms), [&] { return w.finished; });
}

// Stop work the caller no longer wants: ask libdpc to stop, give it a moment, else let the
// worker finish on its own (it owns what it uses).
void work_abandon(const std::shared_ptr<Work> &w, std::thread &t) {
    w->cancel.store(true);
    if (work_wait(*w, 100)) t.join();
    else t.detach();
}

// Run w on a worker thread; every 50 ms check for Ctrl-C (the pending KeyboardInterrupt, or
// another signal handler's exception, is raised) and call progress(done, total) when it moved.
void run_off_thread(const std::shared_ptr<Work> &w, const py::object &progress) {
    std::thread t(work_thread, w);
    uint64_t shown = UINT64_MAX;
    while (!work_wait(*w, 50)) {
        if (PyErr_CheckSignals() != 0) {
            work_abandon(w, t);
            throw py::error_already_set();
        }
        const uint64_t done = w->done.load();
        if (!progress.is_none() && done != shown) {
            shown = done;
            try {
                progress(done, w->total.load());
            } catch (...) {
                work_abandon(w, t);
                throw;
            }
        }
    }
    t.join();
    if (w->status != DPC_OK) raise_status(w->status, w->message);
    if (!progress.is_none() && w->done.load() != shown) progress(w->done.load(), w->total.load());
}

// One generate request; owns the output buffer.
struct Job final : Work {
    std::shared_ptr<dpc_model> model;
    uint64_t seed = 0;
    size_t count = 0, n_points = 0;
    float *buf = nullptr; // malloc'd; handed to numpy on success
    ~Job() override { std::free(buf); }
    dpc_status run() override {
        dpc_generate_options o;
        dpc_generate_options_init(&o);
        o.progress = work_progress;
        o.user = this;
        return dpc_generate_ex(model.get(), seed, count, n_points, &o, buf);
    }
};

// Below this many point-layers a request runs on the calling thread (a thread costs more than
// it takes; it ends within milliseconds anyway).
constexpr double INLINE_WORK = 1 << 21;

class Model {
  public:
    Model(const std::string &path, dpc_isa isa, unsigned threads, dpc_backend backend, dpc_input input,
          double max_neighbours) {
        if (path.find('\0') != std::string::npos)
            raise_status(DPC_ERROR_INVALID_ARGUMENT, "the model path contains a NUL character");
        dpc_load_options options;
        dpc_load_options_init(&options);
        options.isa = isa;
        options.threads = threads;
        options.backend = backend;
        options.input = input;
        options.max_neighbours = max_neighbours;
        dpc_model *raw = nullptr;
        call([&] { return dpc_model_load_file(path.c_str(), &options, &raw); });
        model_.reset(raw, dpc_model_free);
        call([&] { return dpc_model_get_info(raw, &info_); });
        call([&] { return dpc_model_get_backend(raw, &backend_); });
        call([&] { return dpc_model_get_input(raw, &input_); });
        call([&] { return dpc_model_get_balance(raw, &balance_); });
        call([&] { return dpc_model_neighbours(raw, &neighbours_); });
    }
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
        d["isa"] = info_.isa;
        d["threads"] = info_.threads;
        d["backend"] = backend_;
        d["input"] = input_;
        d["balance"] = balance_;
        d["device"] = std::string(dpc_model_device(model_.get()));
        d["neighbours"] = neighbours_;
        return d;
    }

    py::dict metadata() const {
        py::dict d;
        for (size_t i = 0, n = dpc_model_metadata_count(model_.get()); i < n; i++) {
            const char *k, *v;
            call([&] { return dpc_model_metadata_at(model_.get(), i, &k, &v); });
            d[py::str(k)] = py::str(v);
        }
        return d;
    }

    // The floats of a request, checked by libdpc (every count error is its status) and against
    // the caller's byte limit, before anything is allocated.
    size_t checked_floats(size_t count, size_t n_points, double max_bytes) const {
        size_t floats = 0;
        call([&] { return dpc_generate_size(model_.get(), count, n_points, &floats); });
        const double bytes = static_cast<double>(floats) * sizeof(float);
        if (bytes > max_bytes)
            raise_status(DPC_ERROR_LIMIT,
                         "the output would take " + std::to_string(floats) + " floats (" + gib(bytes) +
                             "), more than the limit of " + gib(max_bytes) +
                             ": pass max_bytes (CLI: --max-output, environment: DPC_MAX_OUTPUT_BYTES) to raise it");
        return floats;
    }

    py::array_t<float> generate(uint64_t seed, size_t count, size_t n_points, bool batch, double max_bytes,
                                py::object progress) const {
        const size_t floats = checked_floats(count, n_points, max_bytes);
        const size_t m = n_points ? n_points : info_.n_points;
        auto job = std::make_shared<Job>();
        job->model = model_;
        job->seed = seed;
        job->count = count;
        job->n_points = n_points;
        job->buf = static_cast<float *>(std::malloc(std::max<size_t>(floats, 1) * sizeof(float)));
        if (!job->buf) raise_status(DPC_ERROR_OUT_OF_MEMORY, "out of memory for " + gib(floats * 4.0) + " of points");
        const double work = static_cast<double>(count) * m * info_.layers;
        if (progress.is_none() && work < INLINE_WORK) {
            call([&] { return dpc_generate_batch(model_.get(), seed, count, n_points, job->buf); });
        } else {
            run_off_thread(job, progress);
        }
        float *data = job->buf;
        job->buf = nullptr;
        py::capsule owner(data, [](void *p) { std::free(p); });
        std::vector<py::ssize_t> shape;
        if (batch) shape.push_back(static_cast<py::ssize_t>(count));
        shape.push_back(static_cast<py::ssize_t>(m));
        shape.push_back(static_cast<py::ssize_t>(info_.dims));
        return py::array_t<float>(shape, data, owner);
    }

    void filter(py::array_t<float, py::array::c_style> points) const {
        if (points.ndim() != 2 || points.shape(1) != static_cast<py::ssize_t>(info_.dims))
            raise_status(DPC_ERROR_INVALID_ARGUMENT, "points must have shape (m, dims)");
        if (!points.writeable()) raise_status(DPC_ERROR_INVALID_ARGUMENT, "points must be writeable");
        size_t m = static_cast<size_t>(points.shape(0));
        float *p = points.mutable_data();
        call([&] { return dpc_filter(model_.get(), m, p); });
    }

    // n_points points following a (height, width) density (dpc_generate_density): (m, 2).
    py::array_t<float> generate_density(py::array_t<float, py::array::c_style | py::array::forcecast> density,
                                        uint64_t seed, size_t n_points) const {
        if (density.ndim() != 2)
            raise_status(DPC_ERROR_INVALID_ARGUMENT, "density must be a 2-D array (height, width)");
        const uint64_t h = static_cast<uint64_t>(density.shape(0)), w = static_cast<uint64_t>(density.shape(1));
        if (h > UINT32_MAX || w > UINT32_MAX || h * w > DPC_DENSITY_MAX_CELLS)
            raise_status(DPC_ERROR_LIMIT, "density is " + std::to_string(h) + " x " + std::to_string(w) +
                                              " cells, at most " + std::to_string(DPC_DENSITY_MAX_CELLS) + " in all");
        size_t floats = 0;
        call([&] { return dpc_generate_size(model_.get(), 1, n_points, &floats); });
        const size_t m = floats / info_.dims;
        py::array_t<float> out({static_cast<py::ssize_t>(m), static_cast<py::ssize_t>(2)});
        const float *d = density.data();
        float *o = out.mutable_data();
        call([&] {
            return dpc_generate_density(model_.get(), d, static_cast<uint32_t>(w), static_cast<uint32_t>(h), seed, m,
                                        o);
        });
        return out;
    }

    const dpc_model *handle() const { return model_.get(); }
    std::shared_ptr<dpc_model> shared() const { return model_; }

  private:
    static std::string gib(double bytes) {
        char buf[64];
        std::snprintf(buf, sizeof buf, "%.3g GiB", bytes / (1024.0 * 1024.0 * 1024.0));
        return buf;
    }

    std::shared_ptr<dpc_model> model_;
    dpc_model_info info_{};
    dpc_backend backend_ = DPC_BACKEND_CPU;
    dpc_input input_ = DPC_INPUT_UNIFORM;
    uint32_t balance_ = 0;
    double neighbours_ = 0.0;
};

// The input generators: sizes checked before the array is allocated.
py::array_t<float> input_points(uint64_t seed, size_t m, size_t n, double max_bytes, bool stratified) {
    if (m == 0 || n == 0) raise_status(DPC_ERROR_INVALID_ARGUMENT, "m and n must be positive");
    if (stratified && m > DPC_MAX_POINTS)
        raise_status(DPC_ERROR_LIMIT,
                     std::to_string(m) + " points requested, at most " + std::to_string(DPC_MAX_POINTS));
    if (m > SIZE_MAX / n / sizeof(float)) raise_status(DPC_ERROR_LIMIT, "m * n overflows");
    if (static_cast<double>(m) * n * sizeof(float) > max_bytes)
        raise_status(DPC_ERROR_LIMIT, "the output would take " + std::to_string(m * n) +
                                          " floats, more than max_bytes: pass a larger max_bytes to raise it");
    py::array_t<float> out({m, n});
    float *p = out.mutable_data();
    call([&] { return stratified ? dpc_stratified(seed, m, n, p) : dpc_uniform(seed, m, n, p); });
    return out;
}

// ---- the sampler (dpc_sampler_*) -------------------------------------------------------------

using ArrayU32 = py::array_t<uint32_t, py::array::c_style>;

// A sampler's creation (seconds to minutes for large progressive tables); owns the models'
// references and, until taken, the sampler.
struct SamplerBuild final : Work {
    std::vector<std::shared_ptr<dpc_model>> models;
    std::vector<const dpc_model *> handles;
    dpc_sampler_options options{};
    dpc_sampler *sampler = nullptr;
    ~SamplerBuild() override { dpc_sampler_free(sampler); }
    dpc_status run() override {
        options.models = handles.data();
        options.n_models = static_cast<uint32_t>(handles.size());
        options.progress = work_progress;
        options.user = this;
        return dpc_sampler_create(&options, &sampler);
    }
};

class Sampler {
  public:
    // Created off the calling thread (see run_off_thread): Ctrl-C raises KeyboardInterrupt at
    // once, progress(done, total) counts the tables' sets.
    Sampler(const std::vector<const Model *> &models, uint32_t spp, uint32_t dims, uint64_t seed, uint32_t fold_from,
            uint32_t net_dims, uint32_t net_layout, uint32_t frames, py::object progress) {
        auto build = std::make_shared<SamplerBuild>();
        for (const Model *m : models) {
            build->models.push_back(m->shared());
            build->handles.push_back(m->handle());
        }
        dpc_sampler_options &o = build->options;
        dpc_sampler_options_init(&o);
        o.samples_per_pixel = spp;
        o.dimensions = dims;
        o.seed = seed;
        o.fold_from = fold_from;
        o.net_dims = net_dims;
        o.net_layout = net_layout;
        o.frames = frames;
        run_off_thread(build, progress);
        sampler_ = build->sampler;
        build->sampler = nullptr;
        spp_ = spp * frames; // points per table
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

    // dpc_sampler_get_info: the options as created, net_dims resolved by libdpc.
    py::dict info() const {
        dpc_sampler_info i{};
        i.struct_size = sizeof i;
        call([&] { return dpc_sampler_get_info(sampler_, &i); });
        py::dict d;
        d["samples_per_pixel"] = i.samples_per_pixel;
        d["dimensions"] = i.dimensions;
        d["fold_from"] = i.fold_from;
        d["net_slots"] = i.net_slots;
        d["progressive"] = static_cast<bool>(i.progressive);
        d["seed"] = i.seed;
        d["net_layout"] = i.net_layout;
        d["frames"] = i.frames;
        return d;
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
        raise_status(DPC_ERROR_INVALID_ARGUMENT, "kernels has " + std::to_string(s) + " rows but subspaces has " +
                                                     std::to_string(py::len(subspaces)) + " and radius " +
                                                     std::to_string(radius.size()) + " entries: all three must agree");
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

dpc_layer_options layer_options(uint32_t threads, dpc_isa isa) {
    dpc_layer_options o;
    dpc_layer_options_init(&o);
    o.threads = threads;
    o.isa = isa;
    return o;
}

Array64 layer_forward(const Array64 &x, const Array64 &kernels, const py::sequence &subspaces,
                      const std::vector<double> &radius, double eps, py::handle fixed, uint32_t threads, dpc_isa isa) {
    LayerCall c = layer_call(x, kernels, subspaces, radius, eps, fixed);
    Array64 y(c.shape);
    double *yp = y.mutable_data();
    const double *xp = x.data(), *kp = kernels.data();
    const dpc_layer_options o = layer_options(threads, isa);
    call([&] { return dpc_layer_forward_ex(&c.desc, kp, c.count, c.m, xp, yp, &o); });
    return y;
}

py::tuple layer_backward(const Array64 &x, const Array64 &kernels, const py::sequence &subspaces,
                         const std::vector<double> &radius, double eps, py::handle fixed, const Array64 &grad_y,
                         uint32_t threads, dpc_isa isa) {
    LayerCall c = layer_call(x, kernels, subspaces, radius, eps, fixed);
    if (grad_y.ndim() != x.ndim() || !std::equal(c.shape.begin(), c.shape.end(), grad_y.shape()))
        raise_status(DPC_ERROR_INVALID_ARGUMENT, "grad_y must have the shape of x");
    Array64 gx(c.shape);
    Array64 gk({kernels.shape(0), kernels.shape(1)});
    double *gxp = gx.mutable_data(), *gkp = gk.mutable_data();
    const double *xp = x.data(), *kp = kernels.data(), *gyp = grad_y.data();
    const dpc_layer_options o = layer_options(threads, isa);
    call([&] { return dpc_layer_backward_ex(&c.desc, kp, c.count, c.m, xp, gyp, gxp, gkp, &o); });
    return py::make_tuple(gx, gk);
}

void register_layer_training(py::module_ &mod) {
    mod.def("layer_forward", &layer_forward, py::arg("x"), py::arg("kernels"), py::arg("subspaces"), py::arg("radius"),
            py::arg("eps"), py::arg("fixed"), py::arg("threads"), py::arg("isa") = DPC_ISA_AUTO,
            "One PointFilter layer in float64: x (m, n) or (batch, m, n) -> y of the same shape.");
    mod.def("layer_backward", &layer_backward, py::arg("x"), py::arg("kernels"), py::arg("subspaces"),
            py::arg("radius"), py::arg("eps"), py::arg("fixed"), py::arg("grad_y"), py::arg("threads"),
            py::arg("isa") = DPC_ISA_AUTO,
            "Gradients of one PointFilter layer: (grad_x like x, grad_kernels (s, b) summed over sets).");
}

// The enums of dpc.h, so that Python names them from the header instead of repeating the values.
void register_enums(py::module_ &mod) {
    py::enum_<dpc_isa>(mod, "Isa", "dpc_isa: the CPU code path")
        .value("AUTO", DPC_ISA_AUTO)
        .value("SCALAR", DPC_ISA_SCALAR)
        .value("AVX2", DPC_ISA_AVX2)
        .value("AVX512", DPC_ISA_AVX512);
    py::enum_<dpc_backend>(mod, "Backend", "dpc_backend: what runs the cascade")
        .value("AUTO", DPC_BACKEND_AUTO)
        .value("CPU", DPC_BACKEND_CPU)
        .value("VULKAN", DPC_BACKEND_VULKAN);
    py::enum_<dpc_input>(mod, "Input", "dpc_input: the input points a model filters")
        .value("AUTO", DPC_INPUT_AUTO)
        .value("UNIFORM", DPC_INPUT_UNIFORM)
        .value("STRATIFIED", DPC_INPUT_STRATIFIED);
}

// The defaults of dpc_load_options_init and dpc_layer_options_init, read from libdpc.
py::dict load_defaults() {
    dpc_load_options o;
    dpc_load_options_init(&o);
    dpc_layer_options l;
    dpc_layer_options_init(&l);
    py::dict d;
    d["isa"] = o.isa;
    d["threads"] = o.threads;
    d["backend"] = o.backend;
    d["input"] = o.input;
    d["max_neighbours"] = o.max_neighbours;
    d["layer_threads"] = l.threads;
    d["layer_isa"] = l.isa;
    return d;
}

// Points a host-side step (dpc_balance, dpc_relax_prefixes, dpc_order_levels) changes in place.
using points_in = py::array_t<float, py::array::c_style | py::array::forcecast>;

// The step on a copy of the caller's (m, n) points, which stay as they were:
// step(float *copy, m, n) -> dpc_status.
template <class Step> py::array_t<float> changed_copy(const points_in &points, Step step) {
    if (points.ndim() != 2) raise_status(DPC_ERROR_INVALID_ARGUMENT, "points must be (m, n)");
    py::array_t<float> out({points.shape(0), points.shape(1)});
    std::memcpy(out.mutable_data(), points.data(), sizeof(float) * points.size());
    const size_t m = points.shape(0), n = points.shape(1);
    call([&, p = out.mutable_data()] { return step(p, m, n); });
    return out;
}

// ---- threshold masks (dpc_mask_design) ----------------------------------------------------------

// Polled by libdpc every 65,536 proposals: reports to the caller's progress(done, total), if any,
// and stops the design on a pending Ctrl-C or an exception from progress (the call then raises
// that instead of CancelledError).
struct MaskCall {
    py::object progress;
    bool stopped = false;
};

int mask_progress(void *user, uint64_t done, uint64_t total) {
    MaskCall *c = static_cast<MaskCall *>(user);
    py::gil_scoped_acquire gil;
    if (PyErr_CheckSignals() != 0) {
        c->stopped = true;
        return 1;
    }
    if (!c->progress.is_none()) {
        PyObject *r =
            PyObject_CallFunction(c->progress.ptr(), "KK", (unsigned long long)done, (unsigned long long)total);
        if (!r) {
            c->stopped = true;
            return 1;
        }
        Py_DECREF(r);
    }
    return 0;
}

// (ranks (frames, size, size, channels) uint32, {energy_start, energy_end, accepted}).
py::tuple mask_design(uint32_t size, uint32_t frames, uint32_t channels, uint32_t steps_per_pixel, py::handle seed,
                      py::object progress) {
    dpc_mask_options o;
    dpc_mask_options_init(&o);
    o.size = size, o.frames = frames, o.channels = channels, o.steps_per_pixel = steps_per_pixel;
    const uint64_t s = to_mask(seed, "seed");
    size_t count = 0;
    const dpc_status checked = dpc_mask_count(&o, &count); // every option error, before allocating
    if (checked != DPC_OK) raise_status(checked, dpc_last_error());
    py::array_t<uint32_t> out({size_t(frames), size_t(size), size_t(size), size_t(channels)});
    MaskCall call{std::move(progress)};
    o.progress = mask_progress;
    o.user = &call;
    dpc_mask_stats stats{};
    uint32_t *dst = out.mutable_data();
    dpc_status st;
    std::string message;
    {
        py::gil_scoped_release release;
        st = dpc_mask_design(&o, s, dst, &stats);
        if (st != DPC_OK) message = dpc_last_error();
    }
    if (call.stopped) throw py::error_already_set(); // the pending KeyboardInterrupt or exception
    if (st != DPC_OK) raise_status(st, message);
    py::dict d;
    d["energy_start"] = stats.energy_start;
    d["energy_end"] = stats.energy_end;
    d["accepted"] = stats.accepted;
    return py::make_tuple(out, d);
}

} // namespace

PYBIND11_MODULE(_core, mod) {
    mod.doc() = "libdpc bindings (use the dpc package, not this module)";
    mod.attr("__version__") = dpc_version_string();
    mod.attr("VERSION_NUMBER") = dpc_version_number();
    mod.attr("FORMAT_VERSION") = DPC_FORMAT_VERSION;
    register_enums(mod);
    mod.def("load_defaults", &load_defaults);
    py::class_<Model>(mod, "Model")
        .def(py::init<const std::string &, dpc_isa, unsigned, dpc_backend, dpc_input, double>(), py::arg("path"),
             py::arg("isa"), py::arg("threads"), py::arg("backend"), py::arg("input"),
             py::arg("max_neighbours") = DPC_DEFAULT_MAX_NEIGHBOURS)
        .def("info", &Model::info)
        .def("metadata", &Model::metadata)
        .def("generate", &Model::generate, py::arg("seed"), py::arg("count"), py::arg("n_points"), py::arg("batch"),
             py::arg("max_bytes"), py::arg("progress") = py::none(),
             "count sets of n_points points (0: the trained count): (count, m, n) if batch else (m, n); "
             "runs off the calling thread when large, so Ctrl-C stops it (KeyboardInterrupt) and "
             "progress(done, total) is called on the calling thread")
        .def("filter", &Model::filter, py::arg("points"))
        .def("generate_density", &Model::generate_density, py::arg("density"), py::arg("seed"), py::arg("n_points"));
    mod.attr("DENSITY_MAX_CELLS") = DPC_DENSITY_MAX_CELLS;
    mod.attr("DEFAULT_MAX_NEIGHBOURS") = DPC_DEFAULT_MAX_NEIGHBOURS;
    mod.attr("MAX_POINTS") = DPC_MAX_POINTS;
    mod.attr("SAMPLER_MAX_SPP") = DPC_SAMPLER_MAX_SPP;
    mod.attr("SAMPLER_MAX_DIMENSIONS") = DPC_SAMPLER_MAX_DIMENSIONS;
    mod.attr("SAMPLER_NO_FOLD") = DPC_SAMPLER_NO_FOLD;
    mod.attr("SAMPLER_NET_DIMS_AUTO") = DPC_SAMPLER_NET_DIMS_AUTO;
    mod.attr("SAMPLER_AUTO_NETS_SPP") = DPC_SAMPLER_AUTO_NETS_SPP;
    mod.attr("SAMPLER_NETS_PER_PIXEL") = DPC_SAMPLER_NETS_PER_PIXEL;
    mod.attr("SAMPLER_NETS_SCREEN") = DPC_SAMPLER_NETS_SCREEN;
    mod.attr("SAMPLER_NETS_AUTO") = DPC_SAMPLER_NETS_AUTO;
    mod.attr("SAMPLER_SCREEN_NETS_BELOW") = DPC_SAMPLER_SCREEN_NETS_BELOW;
    py::class_<Sampler>(mod, "Sampler")
        .def(py::init<const std::vector<const Model *> &, uint32_t, uint32_t, uint64_t, uint32_t, uint32_t, uint32_t,
                      uint32_t, py::object>(),
             py::arg("models"), py::arg("spp"), py::arg("dims"), py::arg("seed"), py::arg("fold_from"),
             py::arg("net_dims"), py::arg("net_layout"), py::arg("frames") = 1u, py::arg("progress") = py::none())
        .def("get", &Sampler::get, py::arg("x"), py::arg("y"), py::arg("index"), py::arg("dim"), py::arg("width"))
        .def("table", &Sampler::table, py::arg("t"))
        .def("info", &Sampler::info);
    mod.def("sampler_mask", &sampler_mask);
    mod.def(
        "find_model",
        [](const std::string &name) {
            if (name.find('\0') != std::string::npos)
                raise_status(DPC_ERROR_INVALID_ARGUMENT, "the model name contains a NUL character");
            std::vector<char> path(DPC_PATH_MAX);
            call([&] { return dpc_model_find(name.c_str(), path.data(), path.size()); });
            return std::string(path.data());
        },
        py::arg("name"), "dpc_model_find: the path of the model file named name (DPC_MODEL_PATH, then model_dir())");
    mod.def("model_dir", [] { return std::string(dpc_model_dir()); });
    mod.def("mask_design", &mask_design, py::arg("size"), py::arg("frames"), py::arg("channels"),
            py::arg("steps_per_pixel"), py::arg("seed"), py::arg("progress") = py::none());
    {
        dpc_mask_options o; // dpc.mask_design's default, read from libdpc
        dpc_mask_options_init(&o);
        mod.attr("MASK_STEPS_PER_PIXEL") = o.steps_per_pixel;
    }
    mod.def(
        "isa_supported", [](dpc_isa isa) { return dpc_isa_supported(isa) != 0; }, py::arg("isa"));
    mod.def(
        "uniform",
        [](uint64_t seed, size_t m, size_t n, double max_bytes) { return input_points(seed, m, n, max_bytes, false); },
        py::arg("seed"), py::arg("m"), py::arg("n"), py::arg("max_bytes"));
    mod.def(
        "stratified",
        [](uint64_t seed, size_t m, size_t n, double max_bytes) { return input_points(seed, m, n, max_bytes, true); },
        py::arg("seed"), py::arg("m"), py::arg("n"), py::arg("max_bytes"));
    mod.def(
        "balance",
        [](const points_in &points, uint32_t radius) {
            return changed_copy(points, [&](float *p, size_t m, size_t n) { return dpc_balance(p, m, n, radius); });
        },
        py::arg("points"), py::arg("radius"));
    mod.def(
        "relax_prefixes",
        [](const points_in &points, uint32_t base, uint32_t steps, uint32_t threads) {
            if (points.ndim() != 2 || points.shape(1) != 2)
                raise_status(DPC_ERROR_INVALID_ARGUMENT, "points must be (m, 2)");
            return changed_copy(
                points, [&](float *p, size_t m, size_t) { return dpc_relax_prefixes(p, m, base, steps, threads); });
        },
        py::arg("points"), py::arg("base"), py::arg("steps"), py::arg("threads"));
    mod.def(
        "order_levels",
        [](const points_in &points, uint32_t base) {
            return changed_copy(points, [&](float *p, size_t m, size_t n) { return dpc_order_levels(p, m, n, base); });
        },
        py::arg("points"), py::arg("base"));
    register_layer_training(mod);
}
