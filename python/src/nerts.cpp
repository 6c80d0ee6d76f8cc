// python/src/nerts.cpp - seed 001's nonlinear filters: the model NLModel
// (dkf/nl_model.h's callback table calling Python), NERTS (dkf/nerts.h:
// NERTSF, NERTSIF, DNERTSF, DNERTSIF), the consensus network DFNERTS
// (dkf/dfnerts.h: DF-DNERTSIF, DF-CKF) and one node of it, DFNERTSNode.
// docs/guide/python.md, "Nonlinear filters"; docs/decisions.md items 69, 73.
#include <nanobind/stl/string.h>
#include <nanobind/stl/vector.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <string>
#include <vector>

#include "common.h"
#include "dkf/dfnerts.h"
#include "dkf/nerts.h"

namespace DKF_PY_NS {

namespace {

// ---- NLModel -----------------------------------------------------------------

// A model x' = f(x, d, u), y = h(x, d, u) of Python callables (optional
// Jacobians f_jac -> (Fx, Fd), h_jac -> (Hx, Hd); the core differences f and
// h where they are None) and the angle channels of y. The C callbacks take
// the GIL (filter() runs without it) and call Python; an exception there, or
// a result of the wrong shape, is kept in `error` and the callback fails,
// so the step fails with DKF_ERR_MODEL and the filter's call raises
// dkf.ModelError from it.
//
// NLModel.native makes the same model of native functions of the core's
// callback types (dkf/nl_model.h, with the caller's ctx): a numba cfunc, a
// cffi or ctypes function, the address of any C function. They run without
// the GIL; a non-zero return is kept (which one, the value) as the Python
// callables' exceptions are (docs/decisions.md item 72).
using NativeFn = int (*)(void *, size_t, const real *, const real *, const real *, real *);
using NativeJac = int (*)(void *, size_t, const real *, const real *, const real *, real *,
                          real *);

class NLModel {
public:
    struct Native {
        NativeFn f = nullptr, h = nullptr;
        NativeJac f_jac = nullptr, h_jac = nullptr;
        void *ctx = nullptr;
    };

    NLModel(nb::object f, nb::object h, size_t n, size_t m, size_t p, size_t q, nb::object f_jac,
            nb::object h_jac, std::vector<size_t> angles)
        : f_(std::move(f)), h_(std::move(h)), f_jac_(std::move(f_jac)), h_jac_(std::move(h_jac)),
          angles_(std::move(angles))
    {
        static const char *call = "NLModel";
        if (!PyCallable_Check(f_.ptr()) || !PyCallable_Check(h_.ptr()))
            throw nb::type_error("NLModel: f and h must be callable");
        for (const nb::object *o : {&f_jac_, &h_jac_})
            if (!o->is_none() && !PyCallable_Check(o->ptr()))
                throw nb::type_error("NLModel: f_jac and h_jac must be callable or None");
        std::memset(&table_, 0, sizeof table_);
        table_.ctx = this;
        table_.n = n, table_.m = m, table_.p = p, table_.q = q;
        table_.f = cb_f;
        table_.h = cb_h;
        table_.f_jac = f_jac_.is_none() ? nullptr : cb_f_jac;
        table_.h_jac = h_jac_.is_none() ? nullptr : cb_h_jac;
        set_angles(m);
        check(call);
    }
    // The native model: the same table, its callbacks calling `nat`'s
    // functions; f, h, f_jac, h_jac are the Python objects given (kept
    // alive: a numba cfunc's code lives as long as its object).
    NLModel(const Native &nat, nb::object f, nb::object h, size_t n, size_t m, size_t p, size_t q,
            nb::object f_jac, nb::object h_jac, std::vector<size_t> angles)
        : f_(std::move(f)), h_(std::move(h)), f_jac_(std::move(f_jac)), h_jac_(std::move(h_jac)),
          angles_(std::move(angles)), nat_(nat)
    {
        std::memset(&table_, 0, sizeof table_);
        table_.ctx = this;
        table_.n = n, table_.m = m, table_.p = p, table_.q = q;
        table_.f = nat_f;
        table_.h = nat_h;
        table_.f_jac = nat.f_jac ? nat_f_jac : nullptr;
        table_.h_jac = nat.h_jac ? nat_h_jac : nullptr;
        set_angles(m);
        check("NLModel.native");
    }

    // NLModel.native's arguments: each function an address (int), or an
    // object with one (a numba cfunc's `address`, a ctypes function).
    static NLModel *native(nb::object f, nb::object h, size_t n, size_t m, size_t p, size_t q,
                           nb::object f_jac, nb::object h_jac, std::vector<size_t> angles,
                           nb::object ctx)
    {
        Native nat;
        nat.f = reinterpret_cast<NativeFn>(address(f, "f", false));
        nat.h = reinterpret_cast<NativeFn>(address(h, "h", false));
        nat.f_jac = reinterpret_cast<NativeJac>(address(f_jac, "f_jac", true));
        nat.h_jac = reinterpret_cast<NativeJac>(address(h_jac, "h_jac", true));
        nat.ctx = address(ctx, "ctx", true);
        return new NLModel(nat, std::move(f), std::move(h), n, m, p, q, std::move(f_jac),
                           std::move(h_jac), std::move(angles));
    }

private:
    void set_angles(size_t m)
    {
        is_angle_.assign(m, 0);
        for (size_t a : angles_) {
            if (a >= m) value_error("NLModel", "angles: index " + std::to_string(a) + " >= m");
            is_angle_[a] = 1;
        }
        table_.y_diff = angles_.empty() ? nullptr : cb_y_diff;
    }
    void check(const char *call)
    {
        dkf_status_t st = dkf_nl_model_check(&table_);
        if (st != DKF_OK) {
            raise_status(st, call, -1, nullptr,
                         "n, m >= 1 and n, m, p, q <= DKF_MAX_DIM = " +
                             std::to_string(DKF_MAX_DIM));
        }
    }

public:
    NLModel(const NLModel &) = delete;
    NLModel &operator=(const NLModel &) = delete;

    const dkf_nl_model_t &table() const { return table_; }
    bool is_native() const { return nat_.f != nullptr; }
    size_t n() const { return table_.n; }
    size_t m() const { return table_.m; }
    size_t p() const { return table_.p; }
    size_t q() const { return table_.q; }
    const std::vector<size_t> &angles() const { return angles_; }
    nb::object f() const { return f_; }
    nb::object h() const { return h_; }
    nb::object f_jac() const { return f_jac_; }
    nb::object h_jac() const { return h_jac_; }

    // What the last failed callback did, "model.f raised ValueError: ..."
    // (its exception in *cause) or, native, "model.f returned 3"; taking it
    // clears it. With the GIL.
    std::string take_failure(nb::object *cause)
    {
        std::string what = "model.";
        if (nat_rc_) {
            what += std::string(nat_which_) + " returned " + std::to_string(nat_rc_);
        } else {
            *cause = std::move(error_);
            what += which_ + " raised";
            if (cause->is_valid()) {
                what += " " + std::string(nb::str(cause->type().attr("__name__")).c_str()) + ": " +
                        std::string(nb::str(*cause).c_str());
            }
        }
        clear_error();
        return what;
    }
    void clear_error() { error_ = nb::object(), nat_rc_ = 0; }
    bool has_error() const { return error_.is_valid() || nat_rc_ != 0; }

    // Garbage collection: the callables may refer back to this model (a
    // lambda's globals holding it), a cycle that only the collector breaks.
    int traverse(visitproc visit, void *arg) const
    {
        for (const nb::object *o : {&f_, &h_, &f_jac_, &h_jac_, &error_}) Py_VISIT(o->ptr());
        return 0;
    }
    void clear()
    {
        for (nb::object *o : {&f_, &h_, &f_jac_, &h_jac_, &error_}) *o = nb::object();
    }

private:
    static NLModel &self(void *ctx) { return *static_cast<NLModel *>(ctx); }

    static nb::object arg(const real *v, size_t len)
    {
        const size_t shape[1] = {len};
        if (!v || !len) return nb::cast(new_array(1, shape));
        return nb::cast(copy_out(v, 1, shape));
    }

    // res (a callable's result) as `rows` x `cols` reals into out; a vector
    // (cols 1) may be (rows,) or (rows, 1).
    static void put(nb::handle res, const char *what, size_t rows, size_t cols, real *out)
    {
        InArray a = as_array(res, what, "the result");
        const bool ok = cols == 1 ? (a.ndim() == 1 && a.shape(0) == rows) ||
                                        (a.ndim() == 2 && a.shape(0) == rows && a.shape(1) == 1)
                                  : a.ndim() == 2 && a.shape(0) == rows && a.shape(1) == cols;
        if (!ok) {
            throw nb::value_error((std::string(what) + " returned shape " + shape_str(a) +
                                   ", expected (" + std::to_string(rows) +
                                   (cols == 1 ? ",)" : ", " + std::to_string(cols) + ")"))
                                      .c_str());
        }
        std::memcpy(out, a.data(), rows * cols * sizeof(real));
    }

    // Calls fn(x, d, u) and stores its result(s) through `store`; 0 on
    // success, 1 (the exception kept) on any failure.
    template <class Store>
    int invoke(const nb::object &fn, const char *which, const real *x, const real *d,
               const real *u, Store store)
    {
        nb::gil_scoped_acquire gil;
        try {
            if (!fn.is_valid()) throw std::runtime_error("the model was cleared");
            nb::object res = fn(arg(x, table_.n), arg(d, table_.p), arg(u, table_.q));
            store(res);
            return 0;
        } catch (nb::python_error &e) {
            error_ = nb::borrow(e.value());
        } catch (const std::exception &e) {
            error_ = nb::steal(PyObject_CallFunction(PyExc_ValueError, "s", e.what()));
        }
        which_ = which;
        return 1;
    }

    static int cb_f(void *ctx, size_t, const real *x, const real *d, const real *u, real *xn)
    {
        NLModel &M = self(ctx);
        return M.invoke(M.f_, "f", x, d, u,
                        [&](nb::handle r) { put(r, "model.f", M.table_.n, 1, xn); });
    }
    static int cb_h(void *ctx, size_t, const real *x, const real *d, const real *u, real *y)
    {
        NLModel &M = self(ctx);
        return M.invoke(M.h_, "h", x, d, u,
                        [&](nb::handle r) { put(r, "model.h", M.table_.m, 1, y); });
    }
    // A Jacobian callable returns the pair (d./dx, d./dd); with p = 0 the
    // second is not read.
    static void put_pair(nb::handle r, const char *what, size_t rows, size_t n, size_t p, real *J,
                         real *Jd)
    {
        nb::tuple t;
        if (!nb::try_cast(r, t) || t.size() != 2)
            throw nb::value_error((std::string(what) + " must return a pair (d/dx, d/dd)").c_str());
        put(t[0], what, rows, n, J);
        if (p) put(t[1], what, rows, p, Jd);
    }
    static int cb_f_jac(void *ctx, size_t, const real *x, const real *d, const real *u, real *Fx,
                        real *Fd)
    {
        NLModel &M = self(ctx);
        const size_t n = M.table_.n, p = M.table_.p;
        return M.invoke(M.f_jac_, "f_jac", x, d, u,
                        [&](nb::handle r) { put_pair(r, "model.f_jac", n, n, p, Fx, Fd); });
    }
    static int cb_h_jac(void *ctx, size_t, const real *x, const real *d, const real *u, real *Hx,
                        real *Hd)
    {
        NLModel &M = self(ctx);
        const size_t n = M.table_.n, p = M.table_.p;
        return M.invoke(M.h_jac_, "h_jac", x, d, u,
                        [&](nb::handle r) { put_pair(r, "model.h_jac", M.table_.m, n, p, Hx, Hd); });
    }
    // The native callbacks: nat_'s function with the caller's ctx; a
    // non-zero return is kept for the error (a failed step is one call's).
    int native_result(int rc, const char *which)
    {
        if (rc) nat_which_ = which, nat_rc_ = rc;
        return rc;
    }
    static int nat_f(void *ctx, size_t k, const real *x, const real *d, const real *u, real *xn)
    {
        NLModel &M = self(ctx);
        return M.native_result(M.nat_.f(M.nat_.ctx, k, x, d, u, xn), "f");
    }
    static int nat_h(void *ctx, size_t k, const real *x, const real *d, const real *u, real *y)
    {
        NLModel &M = self(ctx);
        return M.native_result(M.nat_.h(M.nat_.ctx, k, x, d, u, y), "h");
    }
    static int nat_f_jac(void *ctx, size_t k, const real *x, const real *d, const real *u,
                         real *Fx, real *Fd)
    {
        NLModel &M = self(ctx);
        return M.native_result(M.nat_.f_jac(M.nat_.ctx, k, x, d, u, Fx, Fd), "f_jac");
    }
    static int nat_h_jac(void *ctx, size_t k, const real *x, const real *d, const real *u,
                         real *Hx, real *Hd)
    {
        NLModel &M = self(ctx);
        return M.native_result(M.nat_.h_jac(M.nat_.ctx, k, x, d, u, Hx, Hd), "h_jac");
    }
    // A native function's address: an int, or an object's `address` (a
    // numba cfunc), or a ctypes function pointer's. None: null (optional
    // ones only).
    static void *address(const nb::object &o, const char *name, bool optional)
    {
        const std::string what = std::string("NLModel.native: ") + name;
        if (o.is_none()) {
            if (optional) return nullptr;
            throw nb::type_error((what + " is required").c_str());
        }
        nb::object a = o;
        if (nb::hasattr(o, "address")) {
            a = o.attr("address");
        } else if (!PyLong_Check(o.ptr())) {
            nb::module_ ctypes = nb::module_::import_("ctypes");
            if (!nb::isinstance(o, ctypes.attr("_CFuncPtr")))
                throw nb::type_error((what + ": an address (int), an object with `address` (a "
                                             "numba cfunc) or a ctypes function")
                                         .c_str());
            a = ctypes.attr("cast")(o, ctypes.attr("c_void_p")).attr("value");
        }
        if (!PyLong_Check(a.ptr())) throw nb::type_error((what + ": address is not an int").c_str());
        void *p = PyLong_AsVoidPtr(a.ptr());
        if (PyErr_Occurred()) throw nb::python_error();
        if (!p && !optional)
            throw nb::value_error((what + ": address 0").c_str());
        return p;
    }

    // a - b, the angle channels wrapped into [-pi, pi) (fmod is exact).
    static void cb_y_diff(void *ctx, const real *a, const real *b, real *out)
    {
        const NLModel &M = self(ctx);
        const double pi = 3.14159265358979323846, two_pi = 2 * pi;
        for (size_t i = 0; i < M.table_.m; ++i) {
            double v = static_cast<double>(a[i]) - static_cast<double>(b[i]);
            if (M.is_angle_[i]) {
                v = std::fmod(v, two_pi);
                v = v >= pi ? v - two_pi : (v < -pi ? v + two_pi : v);
            }
            out[i] = static_cast<real>(v);
        }
    }

    nb::object f_, h_, f_jac_, h_jac_;
    std::vector<size_t> angles_;
    std::vector<char> is_angle_;
    dkf_nl_model_t table_;
    nb::object error_;
    std::string which_;
    Native nat_;
    // A native callback's non-zero return (0: none) and its name: atomic,
    // as native callbacks run without the GIL, in any thread.
    std::atomic<int> nat_rc_{0};
    std::atomic<const char *> nat_which_{""};
};

// ---- statuses --------------------------------------------------------------

// What a nerts phase's failure names (z, Q, R, u of the call; null if not
// given), with the model's exception as __cause__ for DKF_ERR_MODEL.
struct PhaseIn {
    const real *z = nullptr, *Q = nullptr, *R = nullptr, *u_prev = nullptr, *u = nullptr;
    size_t n = 0, m = 0, q = 0;
    long node = -1;
};

[[noreturn]] void raise_nerts(dkf_status_t st, const char *call, long step, const PhaseIn &in,
                              NLModel &model)
{
    const char *culprit = nullptr;
    std::string detail;
    nb::object cause;
    if (st == DKF_ERR_MODEL) {
        detail = model.take_failure(&cause);
    } else if (st == DKF_ERR_NONFINITE) {
        culprit = first_nonfinite({{"z", in.z, in.m, false},
                                   {"Q", in.Q, in.n * in.n, false},
                                   {"R", in.R, in.m * in.m, false},
                                   {"u_prev", in.u_prev, in.q, false},
                                   {"u", in.u, in.q, false}});
        detail = culprit ? std::string(culprit) + " not finite"
                         : "a model value not finite, or the step overflowed";
    } else if (st == DKF_ERR_NOT_SPD) {
        detail = "R, R_tilde, P_pred, Rbar or Y is not SPD, or the joint covariance of (x, d) "
                 "is not positive definite";
    } else if (st == DKF_ERR_RANK) {
        culprit = "Hd", detail = "Hd = dh/dd lacks full column rank p";
    } else if (st == DKF_ERR_STATE) {
        detail = "out of order: predict, local, then update or commit_info (information kinds)";
    }
    if (in.node >= 0) detail = "node " + std::to_string(in.node) + ": " + detail;
    model.clear_error();
    try {
        raise_status(st, call, step, culprit, detail, in.node);
    } catch (nb::python_error &e) {
        if (cause.is_valid()) PyException_SetCause(e.value().ptr(), cause.release().ptr());
        throw;
    }
}

dkf_nerts_kind_t nerts_kind(const std::string &kind, const char *call, bool info_only)
{
    if (kind == "NERTSIF") return DKF_NERTS_NERTSIF;
    if (kind == "DNERTSIF") return DKF_NERTS_DNERTSIF;
    if (!info_only && kind == "NERTSF") return DKF_NERTS_NERTSF;
    if (!info_only && kind == "DNERTSF") return DKF_NERTS_DNERTSF;
    value_error(call, std::string("kind must be ") +
                          (info_only ? "\"NERTSIF\" or \"DNERTSIF\""
                                     : "\"NERTSF\", \"NERTSIF\", \"DNERTSF\" or \"DNERTSIF\"") +
                          ", got \"" + kind + "\"");
}

// A known input u (q reals) or None (q = 0).
Mat input_arg(nb::handle u, const char *call, const char *name, size_t q)
{
    if (u.is_none()) {
        if (q) value_error(call, std::string(name) + " is required: the model has q = " +
                                     std::to_string(q));
        return Mat();
    }
    if (!q) value_error(call, std::string(name) + " must be None: the model has q = 0");
    return vector_arg(u, call, name, q);
}

// A prior: x0 (n,), P0 (n, n), d0 (p,), Pd0 (p, p), Pxd0 (n, p; None: 0).
struct NlPrior {
    Mat x, P, d, Pd, Pxd;
    std::vector<real> zero;
    dkf_mat_t xm, Pm, dm, Pdm, Pxdm;
    bool has_d = false;
};

void nl_prior(NlPrior &pr, nb::handle x0, nb::handle P0, nb::handle d0, nb::handle Pd0,
              nb::handle Pxd0, size_t n, size_t p, const char *call)
{
    pr.x = vector_arg(x0, call, "x0", n);
    pr.P = matrix_arg(P0, call, "P0", n, n, false);
    pr.xm = view(n, 1, pr.x.p), pr.Pm = view(n, n, pr.P.p);
    pr.has_d = p > 0;
    if (!p) {
        if (!d0.is_none() || !Pd0.is_none() || !Pxd0.is_none())
            value_error(call, "d0, Pd0, Pxd0 must be None: the model has p = 0");
        return;
    }
    if (d0.is_none() || Pd0.is_none()) value_error(call, "d0 and Pd0 are required (p > 0)");
    pr.d = vector_arg(d0, call, "d0", p);
    pr.Pd = matrix_arg(Pd0, call, "Pd0", p, p, false);
    if (Pxd0.is_none()) {
        pr.zero.assign(n * p, real(0));
        pr.Pxdm = view(n, p, pr.zero.data());
    } else {
        pr.Pxd = matrix_arg(Pxd0, call, "Pxd0", n, p, false);
        pr.Pxdm = view(n, p, pr.Pxd.p);
    }
    pr.dm = view(p, 1, pr.d.p), pr.Pdm = view(p, p, pr.Pd.p);
}

[[noreturn]] void raise_nl_init(dkf_status_t st, const char *call, const NlPrior &pr, size_t n,
                                size_t m, size_t p)
{
    if (st == DKF_ERR_NOT_SPD) {
        raise_status(st, call, -1, "P0",
                     "the joint covariance [[P0, Pxd0], [Pxd0^T, Pd0]] is not positive definite");
    }
    if (st == DKF_ERR_RANK)
        raise_status(st, call, -1, nullptr, "m < p: the input cannot be estimated");
    if (st == DKF_ERR_NONFINITE) {
        const char *c = first_nonfinite({{"x0", pr.x.p, n, false},
                                         {"P0", pr.P.p, n * n, false},
                                         {"d0", pr.d.p, p, false},
                                         {"Pd0", pr.Pd.p, p * p, false},
                                         {"Pxd0", pr.Pxd.p, n * p, false}});
        raise_status(st, call, -1, c, nonfinite_detail(c));
    }
    raise_status(st, call, -1, nullptr,
                 "n = " + std::to_string(n) + ", m = " + std::to_string(m) + ", p = " +
                     std::to_string(p) + ": each at most DKF_MAX_DIM = " +
                     std::to_string(DKF_MAX_DIM));
}

// ---- NERTS -------------------------------------------------------------------

// A filter of one NLModel (NERTS, DFNERTSNode): the model it holds for the
// garbage collector, its kind, and the copies of its dkf_nerts_t views.
class OneModel : protected Guarded {
public:
    OutArray field(const dkf_mat_t &M, const char *what, bool vector) const
    {
        not_busy(what);
        return mat_out(M, vector);
    }
    const std::string &kind() const { return kind_name_; }
    nb::object model() const { return model_obj_; }
    int traverse(visitproc visit, void *arg) const
    {
        Py_VISIT(model_obj_.ptr());
        return 0;
    }
    // (only an unreachable filter is cleared: busy refuses any later call)
    void clear()
    {
        busy_ = true;
        model_obj_ = nb::object();
    }

protected:
    void hold(nb::handle model, const std::string &kind)
    {
        model_obj_ = nb::borrow(model);
        model_ = &nb::cast<NLModel &>(model);
        kind_name_ = kind;
    }
    nb::object model_obj_;
    NLModel *model_ = nullptr;
    std::string kind_name_;
};

class NERTS : public OneModel {
public:
    NERTS(nb::handle model, nb::handle x0, nb::handle P0, const std::string &kind, nb::handle d0,
          nb::handle Pd0, nb::handle Pxd0)
    {
        static const char *call = "NERTS";
        hold(model, kind);
        kind_ = nerts_kind(kind, call, false);
        const size_t n = model_->n(), m = model_->m(), p = model_->p();
        NlPrior pr;
        nl_prior(pr, x0, P0, d0, Pd0, Pxd0, n, p, call);
        storage_.assign(DKF_NERTS_STORAGE_LEN(n, m, p), real(0));
        std::memset(&f_, 0, sizeof f_);
        dkf_status_t st = dkf_nerts_init(&f_, kind_, n, m, p, storage_.data(), storage_.size(),
                                         &pr.xm, &pr.Pm, pr.has_d ? &pr.dm : nullptr,
                                         pr.has_d ? &pr.Pdm : nullptr,
                                         pr.has_d ? &pr.Pxdm : nullptr);
        if (st != DKF_OK) raise_nl_init(st, call, pr, n, m, p);
    }
    NERTS(const NERTS &) = delete;
    NERTS &operator=(const NERTS &) = delete;

    void predict(nb::handle Q, nb::handle u)
    {
        static const char *call = "NERTS.predict";
        not_busy(call);
        Mat q = matrix_arg(Q, call, "Q", f_.n, f_.n, false);
        Mat uu = input_arg(u, call, "u", model_->q());
        dkf_mat_t Qm = view(f_.n, f_.n, q.p);
        model_->clear_error();
        dkf_status_t st = dkf_nerts_predict(&f_, &model_->table(), uu.p, &Qm);
        if (st != DKF_OK) raise_nerts(st, call, -1, in(nullptr, q.p, nullptr, uu.p, nullptr), *model_);
    }

    void local(nb::handle z, nb::handle R, nb::handle u)
    {
        static const char *call = "NERTS.local";
        not_busy(call);
        Mat zz = vector_arg(z, call, "z", f_.m);
        Mat r = matrix_arg(R, call, "R", f_.m, f_.m, false);
        Mat uu = input_arg(u, call, "u", model_->q());
        dkf_mat_t Rm = view(f_.m, f_.m, r.p), zm = view(f_.m, 1, zz.p);
        model_->clear_error();
        dkf_status_t st = dkf_nerts_local(&f_, &model_->table(), uu.p, &Rm, &zm);
        if (st != DKF_OK) raise_nerts(st, call, -1, in(zz.p, nullptr, r.p, nullptr, uu.p), *model_);
    }

    void update()
    {
        static const char *call = "NERTS.update";
        not_busy(call);
        dkf_status_t st = dkf_nerts_update(&f_);
        if (st != DKF_OK) raise_nerts(st, call, -1, PhaseIn(), *model_);
    }

    void commit_info(nb::handle Y, nb::handle y)
    {
        static const char *call = "NERTS.commit_info";
        not_busy(call);
        Mat Ya = matrix_arg(Y, call, "Y", f_.n, f_.n, false);
        Mat ya = vector_arg(y, call, "y", f_.n);
        dkf_mat_t Ym = view(f_.n, f_.n, Ya.p), ym = view(f_.n, 1, ya.p);
        dkf_status_t st = dkf_nerts_commit_info(&f_, &Ym, &ym);
        if (st == DKF_ERR_STATE && (kind_ == DKF_NERTS_NERTSF || kind_ == DKF_NERTS_DNERTSF))
            raise_status(st, call, -1, nullptr, "commit_info is the information kinds'");
        if (st != DKF_OK) raise_nerts(st, call, -1, PhaseIn(), *model_);
    }

    void step(nb::handle z, nb::handle Q, nb::handle R, nb::handle u_prev, nb::handle u)
    {
        static const char *call = "NERTS.step";
        not_busy(call);
        Mat zz = vector_arg(z, call, "z", f_.m);
        Mat q = matrix_arg(Q, call, "Q", f_.n, f_.n, false);
        Mat r = matrix_arg(R, call, "R", f_.m, f_.m, false);
        Mat up = input_arg(u_prev, call, "u_prev", model_->q());
        Mat uu = input_arg(u, call, "u", model_->q());
        model_->clear_error();
        dkf_status_t st = do_step(zz.p, q.p, r.p, up.p, uu.p);
        if (st != DKF_OK) raise_nerts(st, call, -1, in(zz.p, q.p, r.p, up.p, uu.p), *model_);
    }

    nb::tuple filter(nb::handle Z, nb::handle Q, nb::handle R, nb::handle U)
    {
        static const char *call = "NERTS.filter";
        not_busy(call);
        check_unstarted(f_.k, call);
        const size_t n = f_.n, m = f_.m, p = f_.p, nq = model_->q();
        InArray za = as_array(Z, call, "Z");
        if (za.ndim() != 2 || za.shape(1) != m || za.shape(0) < 2) {
            value_error(call, "Z must be (T, " + std::to_string(m) +
                                  ") with T >= 2 (Z[0], z_0, is not read), got shape " +
                                  shape_str(za));
        }
        const size_t T = za.shape(0);
        Mat q = matrix_arg(Q, call, "Q", n, n, true), r = matrix_arg(R, call, "R", m, m, true);
        check_stack(q, T, call, "Q");
        check_stack(r, T, call, "R");
        Mat ua;
        if (nq) {
            if (U.is_none()) value_error(call, "U (T, q) is required: the model has q > 0");
            ua = matrix_arg(U, call, "U", T, nq, false);
        } else if (!U.is_none()) {
            value_error(call, "U must be None: the model has q = 0");
        }
        const size_t S = T - 1, xs[2] = {S, n}, ps[3] = {S, n, n}, ds[2] = {S, p},
                     pds[3] = {S, p, p};
        OutArray X = new_array(2, xs), P = new_array(3, ps), D = new_array(2, ds),
                 Pd = new_array(3, pds);
        Undo<dkf_nerts_t> undo(f_, storage_);
        dkf_status_t st = DKF_OK;
        size_t t = 1;
        model_->clear_error();
        busy_ = true;
        {
            nb::gil_scoped_release unlocked;
            for (t = 1; t < T; ++t) {
                st = do_step(za.data() + t * m, q.at(t - 1), r.at(t),
                             nq ? ua.p + (t - 1) * nq : nullptr, nq ? ua.p + t * nq : nullptr);
                if (st != DKF_OK) break;
                put_row(X.data(), t - 1, f_.x);
                put_row(P.data(), t - 1, f_.Px);
                if (p) {
                    put_row(D.data(), t - 1, f_.d);
                    put_row(Pd.data(), t - 1, f_.Pd);
                }
            }
            if (st != DKF_OK) undo.restore();
        }
        busy_ = false;
        if (st != DKF_OK) {
            raise_nerts(st, call, static_cast<long>(t),
                        in(za.data() + t * m, q.at(t - 1), r.at(t),
                           nq ? ua.p + (t - 1) * nq : nullptr, nq ? ua.p + t * nq : nullptr),
                        *model_);
        }
        return nb::make_tuple(X, P, D, Pd);
    }

    const dkf_nerts_t &state() const { return f_; }

private:
    PhaseIn in(const real *z, const real *Q, const real *R, const real *up, const real *u) const
    {
        PhaseIn p;
        p.z = z, p.Q = Q, p.R = R, p.u_prev = up, p.u = u;
        p.n = f_.n, p.m = f_.m, p.q = model_->q();
        return p;
    }
    // One step; the GIL may be released (the callbacks take it).
    dkf_status_t do_step(const real *z, const real *Q, const real *R, const real *up,
                         const real *u)
    {
        dkf_mat_t Qm = view(f_.n, f_.n, Q), Rm = view(f_.m, f_.m, R), zm = view(f_.m, 1, z);
        return dkf_nerts_step(&f_, &model_->table(), up, &Qm, u, &Rm, &zm);
    }

    dkf_nerts_kind_t kind_ = DKF_NERTS_NERTSF;
    std::vector<real> storage_;
    dkf_nerts_t f_;
};

// The views of dkf_nerts_t: name, member, a vector, depends on m (a
// network's per-node field is then a list).
struct NertsField {
    const char *name;
    dkf_mat_t dkf_nerts_t::*mat;
    bool vector, m_dep;
};

const NertsField nerts_fields[] = {
    {"x", &dkf_nerts_t::x, true, false},
    {"Px", &dkf_nerts_t::Px, false, false},
    {"d", &dkf_nerts_t::d, true, false},
    {"Pd", &dkf_nerts_t::Pd, false, false},
    {"Pxd", &dkf_nerts_t::Pxd, false, false},
    {"x_pred", &dkf_nerts_t::x_pred, true, false},
    {"P_pred", &dkf_nerts_t::P_pred, false, false},
    {"Y_pred", &dkf_nerts_t::Y_pred, false, false},
    {"y_pred", &dkf_nerts_t::y_pred, true, false},
    {"Fx", &dkf_nerts_t::Fx, false, false},
    {"Fd", &dkf_nerts_t::Fd, false, false},
    {"z_hat", &dkf_nerts_t::z_hat, true, true},
    {"nu", &dkf_nerts_t::nu, true, true},
    {"h_c", &dkf_nerts_t::h_c, true, true},
    {"Hx", &dkf_nerts_t::Hx, false, true},
    {"R_tilde", &dkf_nerts_t::R_tilde, false, true},
    {"Pzz", &dkf_nerts_t::Pzz, false, true},
    {"Pxz", &dkf_nerts_t::Pxz, false, true},
    {"Hd", &dkf_nerts_t::Hd, false, true},
    {"C", &dkf_nerts_t::C, false, true},
    {"Rbar", &dkf_nerts_t::Rbar, false, true},
    {"Rbar_inv", &dkf_nerts_t::Rbar_inv, false, true},
    {"M", &dkf_nerts_t::M, false, true},
    {"d_loc", &dkf_nerts_t::d_loc, true, false},
    {"Pd_loc", &dkf_nerts_t::Pd_loc, false, false},
    {"Pxd_loc", &dkf_nerts_t::Pxd_loc, false, false},
    {"i", &dkf_nerts_t::i, true, false},
    {"I", &dkf_nerts_t::I, false, false},
    {"Y", &dkf_nerts_t::Y, false, false},
    {"y", &dkf_nerts_t::y, true, false},
};

// Registers the views of dkf_nerts_t as properties of K (K::state()).
template <class K> void def_nerts_views(nb::class_<K> &c, const char *cls)
{
    for (const NertsField &fd : nerts_fields) {
        const auto mat = fd.mat;
        const bool vec = fd.vector;
        const std::string name = std::string(cls) + "." + fd.name;
        c.def_prop_ro(
            fd.name,
            [mat, vec, name](const K &f) { return f.field(f.state().*mat, name.c_str(), vec); },
            nb::rv_policy::take_ownership);
    }
}

// ---- DFNERTS -----------------------------------------------------------------

// A per-node argument: one value for every node, or a sequence of N.
std::vector<nb::handle> per_node(nb::handle a, size_t N, size_t single_ndim, const char *call,
                                 const char *name)
{
    std::vector<nb::handle> out(N, a);
    if (a.is_none()) return out;
    bool seq = nb::isinstance<nb::list>(a) || nb::isinstance<nb::tuple>(a);
    if (!seq) {
        InArray arr = as_array(a, call, name);
        seq = arr.ndim() == single_ndim + 1;
    }
    if (!seq) return out;
    nb::sequence s = nb::borrow<nb::sequence>(a);
    if (nb::len(s) != N) {
        value_error(call, std::string(name) + " has " + std::to_string(nb::len(s)) +
                              " entries, one per node: " + std::to_string(N));
    }
    for (size_t l = 0; l < N; ++l) out[l] = s[l];
    return out;
}

class DFNERTS : Guarded {
public:
    DFNERTS(nb::handle models, nb::handle x0, nb::handle P0, nb::handle adjacency,
            const std::string &kind, const std::string &variant, nb::handle d0, nb::handle Pd0,
            nb::handle Pxd0)
    {
        static const char *call = "DFNERTS";
        graph_.bind(adjacency, call);
        N_ = graph_.N;
        const dkf_nerts_kind_t k = nerts_kind(kind, call, true);
        kind_name_ = kind;
        if (variant == "paper") {
            variant_ = DKF_DFNERTS_PAPER;
        } else if (variant == "joint") {
            variant_ = DKF_DFNERTS_JOINT;
        } else {
            value_error(call, "variant must be \"paper\" or \"joint\", got \"" + variant + "\"");
        }
        variant_name_ = variant;
        if (!nb::isinstance<nb::sequence>(models) || nb::len(models) != N_)
            value_error(call, "models must be a sequence of N = " + std::to_string(N_) +
                                  " NLModel, one per node");
        nb::sequence ms = nb::borrow<nb::sequence>(models);
        for (size_t l = 0; l < N_; ++l) {
            model_objs_.push_back(nb::borrow(ms[l]));
            models_.push_back(&nb::cast<NLModel &>(ms[l]));
            tables_.push_back(models_[l]->table());
            m_.push_back(models_[l]->m());
            if (models_[l]->n() != models_[0]->n() || models_[l]->p() != models_[0]->p() ||
                models_[l]->q() != models_[0]->q())
                value_error(call, "the nodes' models differ in n, p or q");
        }
        n_ = models_[0]->n(), p_ = models_[0]->p();
        std::vector<nb::handle> xs = per_node(x0, N_, 1, call, "x0"),
                                Ps = per_node(P0, N_, 2, call, "P0"),
                                ds = per_node(d0, N_, 1, call, "d0"),
                                Pds = per_node(Pd0, N_, 2, call, "Pd0"),
                                Pxds = per_node(Pxd0, N_, 2, call, "Pxd0");
        std::vector<NlPrior> pr(N_);
        std::vector<dkf_mat_t> xm(N_), Pm(N_), dm(N_), Pdm(N_), Pxdm(N_);
        for (size_t l = 0; l < N_; ++l) {
            nl_prior(pr[l], xs[l], Ps[l], ds[l], Pds[l], Pxds[l], n_, p_, call);
            xm[l] = pr[l].xm, Pm[l] = pr[l].Pm, dm[l] = pr[l].dm, Pdm[l] = pr[l].Pdm,
            Pxdm[l] = pr[l].Pxdm;
        }
        nodes_.resize(N_);
        std::memset(nodes_.data(), 0, N_ * sizeof(dkf_dfnerts_node_t));
        const size_t len = dkf_dfnerts_net_storage_len(N_, n_, m_.data(), p_);
        if (!len) raise_status(DKF_ERR_CAPACITY, call, -1, nullptr, "a dimension out of range");
        storage_.assign(len, real(0));
        std::memset(&net_, 0, sizeof net_);
        dkf_status_t st = dkf_dfnerts_net_init(
            &net_, &graph_.g, nodes_.data(), k, variant_, n_, m_.data(), p_, storage_.data(),
            storage_.size(), xm.data(), Pm.data(), p_ ? dm.data() : nullptr,
            p_ ? Pdm.data() : nullptr, p_ ? Pxdm.data() : nullptr);
        if (st != DKF_OK) raise_nl_init(st, call, pr[0], n_, largest(m_), p_);
    }
    DFNERTS(const DFNERTS &) = delete;
    DFNERTS &operator=(const DFNERTS &) = delete;

    void step(nb::handle z, nb::handle Q, nb::handle R, nb::handle W, size_t Tp, real scale,
              nb::handle u_prev, nb::handle u)
    {
        static const char *call = "DFNERTS.step";
        not_busy(call);
        Args a = args(z, Q, R, call, false);
        std::vector<real> w = graph_.weights(W, call, "W");
        const size_t nq = models_[0]->q();
        Mat up = input_arg(u_prev, call, "u_prev", nq), uu = input_arg(u, call, "u", nq);
        clear_errors();
        dkf_status_t st = do_step(a, 0, w.data(), Tp, scale, up.p, uu.p);
        if (st != DKF_OK) raise_net(st, call, -1, a, 0, up.p, uu.p);
    }

    nb::tuple filter(nb::handle Z, nb::handle Q, nb::handle R, nb::handle W, size_t Tp,
                     real scale, nb::handle U)
    {
        static const char *call = "DFNERTS.filter";
        not_busy(call);
        check_unstarted(k(), call);
        Args a = args(Z, Q, R, call, true);
        std::vector<real> w = graph_.weights(W, call, "W");
        const size_t T = a.T, nq = models_[0]->q();
        Mat ua;
        if (nq) {
            if (U.is_none()) value_error(call, "U (T, q) is required: the models have q > 0");
            ua = matrix_arg(U, call, "U", T, nq, false);
        } else if (!U.is_none()) {
            value_error(call, "U must be None: the models have q = 0");
        }
        const size_t S = T - 1, xs[3] = {S, N_, n_}, ps[4] = {S, N_, n_, n_},
                     ds[3] = {S, N_, p_}, pds[4] = {S, N_, p_, p_};
        OutArray X = new_array(3, xs), P = new_array(4, ps), D = new_array(3, ds),
                 Pd = new_array(4, pds);
        Undo<dkf_dfnerts_net_t> undo(net_, storage_);
        const std::vector<dkf_dfnerts_node_t> saved_nodes(nodes_);
        dkf_status_t st = DKF_OK;
        size_t t = 1;
        clear_errors();
        busy_ = true;
        {
            nb::gil_scoped_release unlocked;
            for (t = 1; t < T; ++t) {
                st = do_step(a, t, w.data(), Tp, scale, nq ? ua.p + (t - 1) * nq : nullptr,
                             nq ? ua.p + t * nq : nullptr);
                if (st != DKF_OK) break;
                for (size_t l = 0; l < N_; ++l) {
                    const dkf_nerts_t &f = nodes_[l].f;
                    put_row(X.data(), (t - 1) * N_ + l, f.x);
                    put_row(P.data(), (t - 1) * N_ + l, f.Px);
                    if (p_) {
                        put_row(D.data(), (t - 1) * N_ + l, f.d);
                        put_row(Pd.data(), (t - 1) * N_ + l, f.Pd);
                    }
                }
            }
            if (st != DKF_OK) {
                undo.restore();
                std::copy(saved_nodes.begin(), saved_nodes.end(), nodes_.begin());
            }
        }
        busy_ = false;
        if (st != DKF_OK) {
            raise_net(st, call, static_cast<long>(t), a, t, nq ? ua.p + (t - 1) * nq : nullptr,
                      nq ? ua.p + t * nq : nullptr);
        }
        return nb::make_tuple(X, P, D, Pd);
    }

    // A field of every node: stacked (N, ...), or a list where it depends on m.
    nb::object field(const NertsField &fd, const char *what) const
    {
        not_busy(what);
        if (fd.m_dep) {
            nb::list out;
            for (size_t l = 0; l < N_; ++l) out.append(mat_out(nodes_[l].f.*(fd.mat), fd.vector));
            return out;
        }
        const dkf_mat_t &M0 = nodes_[0].f.*(fd.mat);
        const size_t shape[3] = {N_, M0.rows, M0.cols};
        OutArray out = new_array(fd.vector ? 2 : 3, shape);
        for (size_t l = 0; l < N_; ++l) put_row(out.data(), l, nodes_[l].f.*(fd.mat));
        return nb::cast(out);
    }
    const dkf_dfnerts_net_t &net() const { return net_; }
    OutArray adjacency() const { return graph_.adjacency(); }
    size_t k() const { return nodes_[0].f.k; }
    size_t N() const { return N_; }
    size_t n() const { return n_; }
    size_t p() const { return p_; }
    const std::vector<size_t> &m() const { return m_; }
    const std::string &kind() const { return kind_name_; }
    const std::string &variant() const { return variant_name_; }
    int traverse(visitproc visit, void *arg) const
    {
        for (const nb::object &o : model_objs_) Py_VISIT(o.ptr());
        return 0;
    }
    void clear()
    {
        busy_ = true;
        for (nb::object &o : model_objs_) o = nb::object();
    }
    nb::list models() const
    {
        nb::list l;
        for (const nb::object &o : model_objs_) l.append(o);
        return l;
    }

private:
    // z (or Z (T, m_l)), Q, R of every node; Q one matrix (or stack) for all
    // or one per node.
    struct Args {
        std::vector<Mat> z, Q, R;
        size_t T = 1;
    };

    Args args(nb::handle z, nb::handle Q, nb::handle R, const char *call, bool series) const
    {
        Args a;
        if (!nb::isinstance<nb::sequence>(z) || nb::len(z) != N_) {
            value_error(call, std::string(series ? "Z" : "z") + " must be a sequence of N = " +
                                  std::to_string(N_) + " entries, one per node");
        }
        nb::sequence zs = nb::borrow<nb::sequence>(z);
        std::vector<nb::handle> qs = per_node(Q, N_, series ? 3 : 2, call, "Q");
        if (!nb::isinstance<nb::sequence>(R) || nb::len(R) != N_)
            value_error(call, "R must be a sequence of N = " + std::to_string(N_) + " matrices");
        nb::sequence rs = nb::borrow<nb::sequence>(R);
        for (size_t l = 0; l < N_; ++l) {
            const std::string sfx = "[" + std::to_string(l) + "]";
            if (series) {
                Mat v = matrix_arg(zs[l], call, ("Z" + sfx).c_str(), 0, m_[l], false);
                if (l && v.rows != a.z[0].rows)
                    value_error(call, "Z" + sfx + " must have the T of Z[0]");
                if (v.rows < 2) value_error(call, "Z needs T >= 2 rows (Z[l][0] is not read)");
                a.z.push_back(v);
            } else {
                a.z.push_back(vector_arg(zs[l], call, ("z" + sfx).c_str(), m_[l]));
            }
            a.Q.push_back(matrix_arg(qs[l], call, ("Q" + sfx).c_str(), n_, n_, series));
            a.R.push_back(matrix_arg(rs[l], call, ("R" + sfx).c_str(), m_[l], m_[l], series));
        }
        if (series) {
            a.T = a.z[0].rows;
            for (size_t l = 0; l < N_; ++l) {
                check_stack(a.Q[l], a.T, call, "Q");
                check_stack(a.R[l], a.T, call, "R[" + std::to_string(l) + "]");
            }
        }
        return a;
    }

    const real *z_at(const Args &a, size_t l, size_t t) const
    {
        return a.z[l].p + (a.T > 1 ? t * m_[l] : 0);
    }

    // Step t (0 for a single step): z_t, Q of time t - 1, R of time t. The
    // GIL may be released.
    dkf_status_t do_step(const Args &a, size_t t, const real *w, size_t Tp, real scale,
                         const real *up, const real *u)
    {
        std::vector<dkf_mat_t> Qm(N_), Rm(N_), zm(N_);
        for (size_t l = 0; l < N_; ++l) {
            Qm[l] = view(n_, n_, a.Q[l].at(t ? t - 1 : 0));
            Rm[l] = view(m_[l], m_[l], a.R[l].at(t));
            zm[l] = view(m_[l], 1, z_at(a, l, t));
        }
        return dkf_dfnerts_net_step(&net_, tables_.data(), up, Qm.data(), u, Rm.data(), zm.data(),
                                    w, Tp, scale);
    }

    void clear_errors()
    {
        for (NLModel *m : models_) m->clear_error();
    }

    [[noreturn]] void raise_net(dkf_status_t st, const char *call, long step, const Args &a,
                                size_t t, const real *up, const real *u)
    {
        if (st == DKF_ERR_WEIGHTS)
            raise_status(st, call, step, "W", "W must be doubly stochastic and >= 0 on the graph");
        if (st == DKF_ERR_ARG) {
            raise_status(st, call, step, nullptr,
                         "Tp in [1, " + std::to_string(DKF_DFNERTS_MAX_TP) +
                             "] and a finite scale > 0");
        }
        // The node to blame: the one whose model raised, or whose input is not finite.
        PhaseIn in;
        in.n = n_, in.q = models_[0]->q(), in.u_prev = up, in.u = u;
        size_t blame = 0;
        for (size_t l = 0; l < N_; ++l) {
            PhaseIn c = in;
            c.z = z_at(a, l, t), c.Q = a.Q[l].at(t ? t - 1 : 0), c.R = a.R[l].at(t), c.m = m_[l];
            const bool model_failed = st == DKF_ERR_MODEL && models_[l]->has_error();
            const bool bad_input =
                st == DKF_ERR_NONFINITE &&
                first_nonfinite({{"z", c.z, c.m, false}, {"Q", c.Q, n_ * n_, false},
                                 {"R", c.R, c.m * c.m, false}});
            if (model_failed || bad_input) {
                blame = l;
                in = c;
                in.node = static_cast<long>(l);
                break;
            }
        }
        if (in.node < 0) in.z = z_at(a, 0, t), in.m = m_[0];
        NLModel &md = *models_[blame];
        raise_nerts(st, call, step, in, md);
    }

    size_t N_ = 0, n_ = 0, p_ = 0;
    std::vector<size_t> m_;
    std::string kind_name_, variant_name_;
    dkf_dfnerts_variant_t variant_ = DKF_DFNERTS_PAPER;
    std::vector<nb::object> model_objs_;
    std::vector<NLModel *> models_;
    std::vector<dkf_nl_model_t> tables_;
    GraphArg graph_;
    std::vector<dkf_dfnerts_node_t> nodes_;
    std::vector<real> storage_;
    dkf_dfnerts_net_t net_;
};

// tp_traverse and tp_clear of a class T with traverse() and clear().
template <class T> int gc_traverse(PyObject *self, visitproc visit, void *arg)
{
    Py_VISIT(Py_TYPE(self));
    if (!nb::inst_ready(self)) return 0;
    return nb::inst_ptr<T>(self)->traverse(visit, arg);
}
template <class T> int gc_clear(PyObject *self)
{
    if (nb::inst_ready(self)) nb::inst_ptr<T>(self)->clear();
    return 0;
}
template <class T> struct GcSlots {
    static PyType_Slot slots[3];
};
template <class T>
PyType_Slot GcSlots<T>::slots[3] = {{Py_tp_traverse, reinterpret_cast<void *>(gc_traverse<T>)},
                                    {Py_tp_clear, reinterpret_cast<void *>(gc_clear<T>)},
                                    {0, nullptr}};

} // namespace

void register_nerts(nb::module_ &m)
{
    nb::class_<NLModel>(m, "NLModel",
                        "A nonlinear model with unknown inputs (dkf/nl_model.h) of Python "
                        "callables: x' = f(x, d, u), y = h(x, d, u).",
                        nb::type_slots(GcSlots<NLModel>::slots))
        .def(nb::init<nb::object, nb::object, size_t, size_t, size_t, size_t, nb::object,
                      nb::object, std::vector<size_t>>(),
             nb::arg("f"), nb::arg("h"), nb::kw_only(), nb::arg("n"), nb::arg("m"), nb::arg("p"),
             nb::arg("q") = 0, nb::arg("f_jac") = nb::none(), nb::arg("h_jac") = nb::none(),
             nb::arg("angles") = std::vector<size_t>())
        .def_static("native", &NLModel::native, nb::arg("f").none(), nb::arg("h").none(),
                    nb::kw_only(),
                    nb::arg("n"), nb::arg("m"), nb::arg("p"), nb::arg("q") = 0,
                    nb::arg("f_jac") = nb::none(), nb::arg("h_jac") = nb::none(),
                    nb::arg("angles") = std::vector<size_t>(), nb::arg("ctx") = nb::none(),
                    nb::rv_policy::take_ownership,
                    "The model of native functions of the core's callback types "
                    "(dkf/nl_model.h): `int f(void *ctx, size_t k, const real *x, const real *d, "
                    "const real *u, real *x_next)`, h likewise, the Jacobians with two outputs. "
                    "Each an address, a numba cfunc or a ctypes function; they run without the "
                    "GIL. dkf.jit_model makes one from Python functions.")
        .def_prop_ro("native_model", [](const NLModel &md) { return md.is_native(); },
                     "True for a model of native functions (NLModel.native)")
        .def_prop_ro("n", &NLModel::n)
        .def_prop_ro("m", &NLModel::m)
        .def_prop_ro("p", &NLModel::p)
        .def_prop_ro("q", &NLModel::q)
        .def_prop_ro("angles", &NLModel::angles)
        .def_prop_ro("f", &NLModel::f)
        .def_prop_ro("h", &NLModel::h)
        .def_prop_ro("f_jac", &NLModel::f_jac)
        .def_prop_ro("h_jac", &NLModel::h_jac)
        .def("__repr__", [](const NLModel &md) {
            return "<dkf NLModel n=" + std::to_string(md.n()) + " m=" + std::to_string(md.m()) +
                   " p=" + std::to_string(md.p()) + " q=" + std::to_string(md.q()) +
                   " " DKF_PY_DTYPE ">";
        });

    nb::class_<NERTS> c(m, "NERTS",
                        "Seed 001's single-node nonlinear joint state and unknown-input filters "
                        "(dkf/nerts.h): kind NERTSF, NERTSIF (EKF), DNERTSF, DNERTSIF (cubature).",
                        nb::type_slots(GcSlots<NERTS>::slots));
    c.def(nb::init<nb::handle, nb::handle, nb::handle, const std::string &, nb::handle, nb::handle,
                   nb::handle>(),
          nb::arg("model"), nb::arg("x0"), nb::arg("P0"), nb::kw_only(), nb::arg("kind"),
          nb::arg("d0") = nb::none(), nb::arg("Pd0") = nb::none(), nb::arg("Pxd0") = nb::none())
        .def("predict", &NERTS::predict, nb::kw_only(), nb::arg("Q"), nb::arg("u") = nb::none(),
             "Phase 1: the time update k-1 -> k with Q and the known input u_{k-1}.")
        .def("local", &NERTS::local, nb::arg("z"), nb::kw_only(), nb::arg("R"),
             nb::arg("u") = nb::none(), "Phase 2: the local statistics of z_k.")
        .def("update", &NERTS::update, "Phase 3: the filter's own measurement update.")
        .def("commit_info", &NERTS::commit_info, nb::arg("Y"), nb::arg("y"),
             "Phase 3 with a given information pair (information kinds).")
        .def("step", &NERTS::step, nb::arg("z"), nb::kw_only(), nb::arg("Q"), nb::arg("R"),
             nb::arg("u_prev") = nb::none(), nb::arg("u") = nb::none(),
             "The three phases in one call.")
        .def("filter", &NERTS::filter, nb::arg("Z"), nb::kw_only(), nb::arg("Q"), nb::arg("R"),
             nb::arg("U") = nb::none(),
             "Steps 1..T-1 with z_t = Z[t] (Z[0] not read) in one call without the GIL (the "
             "model's callables take it); returns (X, Px, D, Pd), one row per step.")
        .def_prop_ro("k", [](const NERTS &f) { return f.state().k; }, "Steps taken.")
        .def_prop_ro("phase", [](const NERTS &f) { return f.state().phase; },
                     "0 after a commit, 1 after predict, 2 after local.")
        .def_prop_ro("kind", &NERTS::kind)
        .def_prop_ro("model", &NERTS::model)
        .def_prop_ro("n", [](const NERTS &f) { return f.state().n; })
        .def_prop_ro("m", [](const NERTS &f) { return f.state().m; })
        .def_prop_ro("p", [](const NERTS &f) { return f.state().p; })
        .def("__repr__", [](const NERTS &f) {
            return "<dkf NERTS " + f.kind() + " n=" + std::to_string(f.state().n) + " m=" +
                   std::to_string(f.state().m) + " p=" + std::to_string(f.state().p) +
                   " " DKF_PY_DTYPE ">";
        });
    def_nerts_views(c, "NERTS");

    nb::class_<DFNERTS> d(m, "DFNERTS",
                          "Seed 001's consensus network (dkf/dfnerts.h): DF-DNERTSIF, its EKF "
                          "form, and DF-CKF (p = 0), every node with its own model.",
                          nb::type_slots(GcSlots<DFNERTS>::slots));
    d.def(nb::init<nb::handle, nb::handle, nb::handle, nb::handle, const std::string &,
                   const std::string &, nb::handle, nb::handle, nb::handle>(),
          nb::arg("models"), nb::arg("x0"), nb::arg("P0"), nb::kw_only(), nb::arg("adjacency"),
          nb::arg("kind") = "DNERTSIF", nb::arg("variant") = "paper", nb::arg("d0") = nb::none(),
          nb::arg("Pd0") = nb::none(), nb::arg("Pxd0") = nb::none())
        .def("step", &DFNERTS::step, nb::arg("z"), nb::kw_only(), nb::arg("Q"), nb::arg("R"),
             nb::arg("W"), nb::arg("Tp"), nb::arg("scale") = 1.0, nb::arg("u_prev") = nb::none(),
             nb::arg("u") = nb::none(),
             "One step of every node: local, Tp consensus rounds with W, commit.")
        .def("filter", &DFNERTS::filter, nb::arg("Z"), nb::kw_only(), nb::arg("Q"), nb::arg("R"),
             nb::arg("W"), nb::arg("Tp"), nb::arg("scale") = 1.0, nb::arg("U") = nb::none(),
             "Steps 1..T-1 with z_t = Z[l][t] in one call without the GIL; returns (X, Px, D, "
             "Pd) with a node axis after the time.")
        .def_prop_ro("adjacency", &DFNERTS::adjacency, nb::rv_policy::take_ownership)
        .def_prop_ro("k", &DFNERTS::k, "Steps taken.")
        .def_prop_ro("N", &DFNERTS::N)
        .def_prop_ro("n", &DFNERTS::n)
        .def_prop_ro("m", &DFNERTS::m)
        .def_prop_ro("p", &DFNERTS::p)
        .def_prop_ro("kind", &DFNERTS::kind)
        .def_prop_ro("variant", &DFNERTS::variant)
        .def_prop_ro("models", &DFNERTS::models)
        .def_prop_ro("reals_sent", [](const DFNERTS &f) { return f.net().reals_sent; })
        .def_prop_ro("broadcasts", [](const DFNERTS &f) { return f.net().broadcasts; })
        .def("__repr__", [](const DFNERTS &f) {
            return "<dkf DFNERTS " + f.kind() + " " + f.variant() + " N=" + std::to_string(f.N()) +
                   " n=" + std::to_string(f.n()) + " p=" + std::to_string(f.p()) +
                   " " DKF_PY_DTYPE ">";
        });
    for (const NertsField &fd : nerts_fields) {
        const std::string name = std::string("DFNERTS.") + fd.name;
        const NertsField f2 = fd;
        d.def_prop_ro(fd.name, [f2, name](const DFNERTS &f) { return f.field(f2, name.c_str()); });
    }
}

} // namespace DKF_PY_NS

// ---- DFNERTSNode: one node of a DFNERTS network ----------------------------------

namespace DKF_PY_NS {

namespace {

// One node of the consensus network (dkf/dfnerts.h's node API): the caller
// carries its packets to and from the neighbours, as a node of a real
// network does; DFNERTS steps all the nodes in-process with the same calls.
class DFNERTSNode : public OneModel {
public:
    DFNERTSNode(nb::handle model, nb::handle x0, nb::handle P0, const std::string &kind,
                const std::string &variant, nb::handle d0, nb::handle Pd0, nb::handle Pxd0)
    {
        static const char *call = "DFNERTSNode";
        hold(model, kind);
        const dkf_nerts_kind_t k = nerts_kind(kind, call, true);
        if (variant != "paper" && variant != "joint")
            value_error(call, "variant must be \"paper\" or \"joint\", got \"" + variant + "\"");
        variant_name_ = variant;
        const dkf_dfnerts_variant_t v = variant == "joint" ? DKF_DFNERTS_JOINT : DKF_DFNERTS_PAPER;
        const size_t n = model_->n(), m = model_->m(), p = model_->p();
        NlPrior pr;
        nl_prior(pr, x0, P0, d0, Pd0, Pxd0, n, p, call);
        storage_.assign(DKF_DFNERTS_NODE_STORAGE_LEN(n, m, p), real(0));
        std::memset(&nd_, 0, sizeof nd_);
        dkf_status_t st = dkf_dfnerts_node_init(&nd_, k, v, n, m, p, storage_.data(),
                                                storage_.size(), &pr.xm, &pr.Pm,
                                                pr.has_d ? &pr.dm : nullptr,
                                                pr.has_d ? &pr.Pdm : nullptr,
                                                pr.has_d ? &pr.Pxdm : nullptr);
        if (st != DKF_OK) raise_nl_init(st, call, pr, n, m, p);
    }
    DFNERTSNode(const DFNERTSNode &) = delete;
    DFNERTSNode &operator=(const DFNERTSNode &) = delete;

    // Time update and local statistics of z; returns the tau = 0 packet.
    OutArray local(nb::handle z, nb::handle Q, nb::handle R, double scale, nb::handle u_prev,
                   nb::handle u)
    {
        static const char *call = "DFNERTSNode.local";
        not_busy(call);
        const size_t n = nd_.n, m = nd_.m, nq = model_->q();
        Mat zz = vector_arg(z, call, "z", m);
        Mat q = matrix_arg(Q, call, "Q", n, n, false);
        Mat r = matrix_arg(R, call, "R", m, m, false);
        Mat up = input_arg(u_prev, call, "u_prev", nq), uu = input_arg(u, call, "u", nq);
        dkf_mat_t Qm = view(n, n, q.p), Rm = view(m, m, r.p), zm = view(m, 1, zz.p);
        model_->clear_error();
        dkf_status_t st = dkf_dfnerts_node_local(&nd_, &model_->table(), up.p, &Qm, uu.p, &Rm,
                                                 &zm, static_cast<real>(scale), nullptr);
        if (st == DKF_ERR_ARG)
            raise_status(st, call, -1, nullptr, "scale must be finite and > 0");
        if (st != DKF_OK) {
            PhaseIn in;
            in.z = zz.p, in.Q = q.p, in.R = r.p, in.u_prev = up.p, in.u = uu.p;
            in.n = n, in.m = m, in.q = nq;
            raise_nerts(st, call, -1, in, *model_);
        }
        return pkt();
    }

    // One consensus round over the packets of the neighbourhood (its own
    // among them) with the weights w; returns the node's next packet.
    OutArray mix(nb::handle pkts, nb::handle w)
    {
        static const char *call = "DFNERTSNode.mix";
        not_busy(call);
        if (!nb::isinstance<nb::sequence>(pkts) || nb::len(pkts) == 0)
            value_error(call, "pkts must be a non-empty sequence of packets");
        nb::sequence sq = nb::borrow<nb::sequence>(pkts);
        const size_t count = nb::len(sq);
        std::vector<Mat> in(count);
        std::vector<const real *> ptr(count);
        for (size_t e = 0; e < count; ++e) {
            const std::string nm = "pkts[" + std::to_string(e) + "]";
            in[e] = vector_arg(sq[e], call, nm.c_str(), nd_.pkt_len);
            ptr[e] = in[e].p;
        }
        Mat wa = vector_arg(w, call, "w", count);
        dkf_status_t st = dkf_dfnerts_node_mix(&nd_, ptr.data(), wa.p, count, nullptr);
        if (st == DKF_OK) return pkt();
        std::string detail;
        const char *culprit = nullptr;
        if (st == DKF_ERR_STATE) {
            detail = "no pending step: call local() first";
        } else if (st == DKF_ERR_NONFINITE) {
            for (size_t e = 0; e < count && !culprit; ++e)
                if (first_nonfinite({{"pkts", in[e].p, nd_.pkt_len, false}}))
                    culprit = "pkts", detail = "pkts[" + std::to_string(e) + "] not finite";
            if (!culprit && first_nonfinite({{"w", wa.p, count, false}}))
                culprit = "w", detail = "w not finite";
            if (!culprit) detail = "the mixed packet overflowed";
        }
        raise_status(st, call, -1, culprit, detail);
    }

    void commit()
    {
        static const char *call = "DFNERTSNode.commit";
        not_busy(call);
        dkf_status_t st = dkf_dfnerts_node_commit(&nd_);
        if (st == DKF_OK) return;
        std::string detail;
        if (st == DKF_ERR_STATE)
            detail = nd_.pending ? "no round mixed yet: mix() at least once" : "no pending step";
        else if (st == DKF_ERR_NOT_SPD)
            detail = "the agreed information matrix, or the mixed joint covariance of (x, d), is "
                     "not positive definite";
        else if (st == DKF_ERR_NONFINITE)
            detail = "the posterior overflowed";
        raise_status(st, call, -1, nullptr, detail);
    }

    void cancel()
    {
        static const char *call = "DFNERTSNode.cancel";
        not_busy(call);
        dkf_status_t st = dkf_dfnerts_node_cancel(&nd_);
        if (st != DKF_OK) raise_status(st, call, -1, nullptr, "no pending step");
    }

    // A new prior, the posterior at step k (a node that restarts).
    void restart(size_t k, nb::handle x0, nb::handle P0, nb::handle d0, nb::handle Pd0,
                 nb::handle Pxd0)
    {
        static const char *call = "DFNERTSNode.restart";
        not_busy(call);
        NlPrior pr;
        nl_prior(pr, x0, P0, d0, Pd0, Pxd0, nd_.n, nd_.p, call);
        dkf_status_t st = dkf_dfnerts_node_restart(&nd_, k, &pr.xm, &pr.Pm,
                                                   pr.has_d ? &pr.dm : nullptr,
                                                   pr.has_d ? &pr.Pdm : nullptr,
                                                   pr.has_d ? &pr.Pxdm : nullptr);
        if (st != DKF_OK) raise_nl_init(st, call, pr, nd_.n, nd_.m, nd_.p);
    }

    // A prior from a neighbour's packet pkt (variant paper with p > 0: the
    // input's d0, Pd0 too), the posterior at step k.
    void rejoin(size_t k, nb::handle pkt_in, nb::handle d0, nb::handle Pd0)
    {
        static const char *call = "DFNERTSNode.rejoin";
        not_busy(call);
        const size_t p = nd_.p;
        Mat pk = vector_arg(pkt_in, call, "pkt", nd_.pkt_len);
        const bool paper_d = nd_.variant == DKF_DFNERTS_PAPER && p > 0;
        if (!paper_d && (!d0.is_none() || !Pd0.is_none()))
            value_error(call, "d0 and Pd0 must be None: the packet holds the input (joint) or "
                              "p = 0");
        if (paper_d && (d0.is_none() || Pd0.is_none()))
            value_error(call, "d0 and Pd0 are required: variant paper with p > 0");
        Mat d, Pd;
        dkf_mat_t dm, Pdm;
        if (paper_d) {
            d = vector_arg(d0, call, "d0", p);
            Pd = matrix_arg(Pd0, call, "Pd0", p, p, false);
            dm = view(p, 1, d.p), Pdm = view(p, p, Pd.p);
        }
        dkf_status_t st =
            dkf_dfnerts_node_rejoin(&nd_, k, pk.p, paper_d ? &dm : nullptr, paper_d ? &Pdm : nullptr);
        if (st == DKF_OK) return;
        const char *culprit = nullptr;
        std::string detail;
        if (st == DKF_ERR_NONFINITE) {
            culprit = first_nonfinite({{"pkt", pk.p, nd_.pkt_len, false},
                                       {"d0", d.p, paper_d ? p : 0, false},
                                       {"Pd0", Pd.p, paper_d ? p * p : 0, false}});
            detail = nonfinite_detail(culprit);
        } else if (st == DKF_ERR_NOT_SPD) {
            culprit = paper_d ? nullptr : "pkt";
            detail = paper_d ? "the packet's information matrix, or the prior's joint covariance "
                               "with Pd0, is not positive definite"
                             : "the packet's information matrix is not positive definite";
        }
        raise_status(st, call, -1, culprit, detail);
    }

    OutArray pkt() const
    {
        not_busy("DFNERTSNode.pkt");
        const size_t shape[1] = {nd_.pkt_len};
        return copy_out(nd_.pkt, 1, shape);
    }
    const dkf_nerts_t &state() const { return nd_.f; }
    const dkf_dfnerts_node_t &node() const { return nd_; }
    const std::string &variant() const { return variant_name_; }

private:
    std::string variant_name_;
    std::vector<real> storage_;
    dkf_dfnerts_node_t nd_;
};

} // namespace

void register_dfnerts_node(nb::module_ &m)
{
    using N = DFNERTSNode;
    nb::class_<N> c(m, "DFNERTSNode",
                    "One node of seed 001's consensus network (dkf/dfnerts.h's node API): its "
                    "packets in and out as arrays, for a node of a real network.",
                    nb::type_slots(GcSlots<N>::slots));
    c.def(nb::init<nb::handle, nb::handle, nb::handle, const std::string &, const std::string &,
                   nb::handle, nb::handle, nb::handle>(),
          nb::arg("model"), nb::arg("x0"), nb::arg("P0"), nb::kw_only(), nb::arg("kind") = "DNERTSIF",
          nb::arg("variant") = "paper", nb::arg("d0") = nb::none(), nb::arg("Pd0") = nb::none(),
          nb::arg("Pxd0") = nb::none())
        .def("local", &N::local, nb::arg("z"), nb::kw_only(), nb::arg("Q"), nb::arg("R"),
             nb::arg("scale") = 1.0, nb::arg("u_prev") = nb::none(), nb::arg("u") = nb::none(),
             nb::rv_policy::take_ownership,
             "Time update and local statistics of z; the step is pending. Returns the tau = 0 "
             "packet to send.")
        .def("mix", &N::mix, nb::arg("pkts"), nb::arg("w"), nb::rv_policy::take_ownership,
             "One consensus round: sum_e w[e] pkts[e] over the neighbourhood's packets (its own "
             "among them), plus s times its contribution in the first round. Returns the next "
             "packet to send.")
        .def("commit", &N::commit, "The posterior from the current packet (after a round).")
        .def("cancel", &N::cancel, "Drops the pending step: the node as before local().")
        .def("restart", &N::restart, nb::arg("k"), nb::arg("x0"), nb::arg("P0"), nb::kw_only(),
             nb::arg("d0") = nb::none(), nb::arg("Pd0") = nb::none(), nb::arg("Pxd0") = nb::none(),
             "A new prior, the posterior at step k; drops a pending step.")
        .def("rejoin", &N::rejoin, nb::arg("k"), nb::arg("pkt"), nb::kw_only(),
             nb::arg("d0") = nb::none(), nb::arg("Pd0") = nb::none(),
             "The prior from a neighbour's packet, the posterior at step k (variant paper with "
             "p > 0: the input's d0, Pd0).")
        .def_prop_ro("pkt", &N::pkt, nb::rv_policy::take_ownership,
                     "The node's current packet (pkt_len,), a copy: after a commit the "
                     "consensus pair it committed from (after cancel(), the dropped step's).")
        .def_prop_ro("pkt_len", [](const N &f) { return f.node().pkt_len; })
        .def_prop_ro("q", [](const N &f) { return f.node().q; }, "n (paper) or n + p (joint).")
        .def_prop_ro("tau", [](const N &f) { return f.node().tau; }, "Rounds mixed.")
        .def_prop_ro("pending", [](const N &f) { return f.node().pending != 0; })
        .def_prop_ro("scale", [](const N &f) { return static_cast<double>(f.node().scale); })
        .def_prop_ro("k", [](const N &f) { return f.state().k; }, "Steps committed.")
        .def_prop_ro("n", [](const N &f) { return f.node().n; })
        .def_prop_ro("m", [](const N &f) { return f.node().m; })
        .def_prop_ro("p", [](const N &f) { return f.node().p; })
        .def_prop_ro("kind", &N::kind)
        .def_prop_ro("variant", &N::variant)
        .def_prop_ro("model", &N::model)
        .def("__repr__", [](const N &f) {
            return "<dkf DFNERTSNode " + f.kind() + " " + f.variant() + " n=" +
                   std::to_string(f.node().n) + " m=" + std::to_string(f.node().m) + " p=" +
                   std::to_string(f.node().p) + " k=" + std::to_string(f.state().k) +
                   " " DKF_PY_DTYPE ">";
        });
    def_nerts_views(c, "DFNERTSNode");
}

} // namespace DKF_PY_NS
