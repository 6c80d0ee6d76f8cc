// python/src/common.h - what the binding files of the extension module
// share (python/src/dkf_module.cpp defines the functions): argument
// conversion, errors, the undo of a failed filter() run. Each file's code is
// in the namespace DKF_PY_NS of its real type.
#ifndef DKF_PY_COMMON_H
#define DKF_PY_COMMON_H

#include <nanobind/nanobind.h>
#include <nanobind/ndarray.h>

#include <cstring>
#include <initializer_list>
#include <stdexcept>
#include <string>
#include <vector>

#include "dkf/graph.h"
#include "dkf/mat.h"
#include "dkf/status.h"

namespace nb = nanobind;

#if DKF_USE_FLOAT
#define DKF_PY_NS dkf_py_float
#define DKF_PY_DTYPE "float32"
#else
#define DKF_PY_NS dkf_py_double
#define DKF_PY_DTYPE "float64"
#endif

namespace DKF_PY_NS {

using real = dkf_real_t;
using InArray = nb::ndarray<const real, nb::c_contig, nb::device::cpu>;
using OutArray = nb::ndarray<nb::numpy, real>;

// A matrix argument: one (rows, cols) matrix, or a stack (T, rows, cols)
// of one per step (count = T). rows or cols 0: any (taken from the array).
struct Mat {
    InArray keep;      // holds the data alive (empty for stored models)
    const real *p = nullptr;
    size_t count = 0;  // 1 for one matrix, T for a stack
    bool stacked = false;
    size_t rows = 0, cols = 0;
    const real *at(size_t t) const { return p + (stacked ? t : 0) * rows * cols; }
};

// An input named in an error message, if it is not finite.
struct Named {
    const char *name;
    const real *p;
    size_t len;
    bool nan_missing; // a measurement: its NaNs are missing values, not errors
};

// A model matrix the constructor was given: one, or a stack of one per step.
struct Stored {
    std::vector<real> data;
    size_t count = 0, rows = 0, cols = 0;
    bool stacked = false;
};

// A filter struct and its storage as they were before a filter() run, put
// back when a step fails (the struct and every real, byte for byte).
template <class S> class Undo {
public:
    Undo(S &obj, std::vector<real> &storage)
        : obj_(obj), storage_(storage), saved_obj_(obj), saved_(storage)
    {
    }
    void restore()
    {
        obj_ = saved_obj_;
        std::memcpy(storage_.data(), saved_.data(), saved_.size() * sizeof(real));
    }

private:
    S &obj_;
    std::vector<real> &storage_;
    const S saved_obj_;
    const std::vector<real> saved_;
};

// An object one thread uses at a time: filter() marks it busy while it
// runs without the GIL, and every other call then raises RuntimeError.
class Guarded {
protected:
    bool busy_ = false;
    void not_busy(const char *call) const
    {
        if (busy_) {
            throw std::runtime_error(std::string(call) +
                                     ": the filter is running filter() in another thread");
        }
    }
};

// A read-only property per matrix of a filter's C struct S: a copy.
template <class S> struct Field {
    const char *name;
    dkf_mat_t S::*mat;
    bool vector;
    const char *doc;
};

template <class K, class S, size_t N>
void def_fields(nb::class_<K> &cls, const char *cls_name, const Field<S> (&fields)[N])
{
    for (const Field<S> &fd : fields) {
        const auto mat = fd.mat;
        const bool vec = fd.vector;
        const std::string call = std::string(cls_name) + "." + fd.name;
        cls.def_prop_ro(
            fd.name,
            [mat, vec, call](const K &f) { return f.field(f.state().*mat, call.c_str(), vec); },
            nb::rv_policy::take_ownership, fd.doc);
    }
}

[[noreturn]] void raise_status(dkf_status_t st, const char *call, long step, const char *matrix,
                               const std::string &detail, long node = -1);
[[noreturn]] void value_error(const char *call, const std::string &what);
std::string shape_str(const InArray &a);
InArray as_array(nb::handle obj, const char *call, const char *name);
Mat matrix_arg(nb::handle obj, const char *call, const char *name, size_t rows, size_t cols,
               bool stack_ok);
Mat vector_arg(nb::handle obj, const char *call, const char *name, size_t n);
dkf_mat_t view(size_t rows, size_t cols, const real *p);
OutArray new_array(size_t ndim, const size_t *shape);
const char *first_nonfinite(std::initializer_list<Named> inputs);
std::string nonfinite_detail(const char *culprit);
[[noreturn]] void raise_init(dkf_status_t st, const char *call, const Mat &x, const Mat &P,
                             const std::string &sizes);
Stored store(const Mat &m);
Mat stored(const Stored &s);
Mat constant(const Stored &s, const char *call, const char *name);
size_t stack_length(std::initializer_list<const Stored *> ms, const char *call);
void check_stack(const Mat &m, size_t T, const char *call, const std::string &name);
OutArray copy_out(const real *p, size_t ndim, const size_t *shape);
size_t select_measured(const real **y, const real **H, const real **R, size_t m, size_t n,
                       real *ys, real *Hs, real *Rs);
void put_row(real *out, size_t t, const dkf_mat_t &M);
std::vector<Mat> sensor_mats(nb::handle seq, const char *call, const char *name, size_t L,
                             const std::vector<size_t> &rows, size_t n);
size_t largest(const std::vector<size_t> &v);
OutArray mat_out(const dkf_mat_t &M, bool vector);

// A graph given as an adjacency array (N, N), nonzero for a link, as the
// adjacency lists of dkf/graph.h (python/src/tw.cpp); weights as dense (N, N)
// arrays, zero off the graph. Not to be copied once bound (g points into it).
struct GraphArg {
    std::vector<size_t> start, nbr;
    dkf_graph_t g;
    size_t N = 0;
    void bind(nb::handle adjacency, const char *call);
    std::vector<real> weights(nb::handle w, const char *call, const char *name) const;
    OutArray adjacency() const;
};

// filter() of a filter indexed by the time runs only from its start (its
// stacks' index is the time): dkf.StateError after k steps (tw.cpp).
void check_unstarted(size_t k, const char *call);

// The registration of the bindings each further file defines.
void register_tw(nb::module_ &m);
void register_nerts(nb::module_ &m);
void register_dfnerts_node(nb::module_ &m);
void register_nlm_builtin(nb::module_ &m);

} // namespace DKF_PY_NS

#endif // DKF_PY_COMMON_H
