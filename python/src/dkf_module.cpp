// python/src/dkf_module.cpp - the extension module dkf._dkf_double or
// dkf._dkf_float (DKF_PY_MODULE), over the core built in that real type
// (python/CMakeLists.txt). The filters are the core's: this file checks
// and converts arguments, calls dkf_*, and turns a status into a dkf.Error
// (python/dkf/_errors.py). docs/guide/python.md is the user's guide.
#include <nanobind/nanobind.h>
#include <nanobind/ndarray.h>
#include <nanobind/stl/string.h>

#include <cmath>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include "dkf/kf.h"
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

// ---- errors -------------------------------------------------------------

// Raises the dkf.Error subclass of status st. call: "KalmanFilter.update";
// step: the step of filter() or -1; matrix: the input the status concerns
// or nullptr; detail: what failed, in the model's words.
[[noreturn]] void raise_status(dkf_status_t st, const char *call, long step, const char *matrix,
                               const std::string &detail)
{
    nb::object make = nb::module_::import_("dkf._errors").attr("_make");
    nb::object exc = make(static_cast<int>(st), dkf_status_str(st), call,
                          step < 0 ? nb::object(nb::none()) : nb::object(nb::int_(step)),
                          matrix ? nb::object(nb::str(matrix)) : nb::object(nb::none()), detail);
    PyErr_SetObject(reinterpret_cast<PyObject *>(Py_TYPE(exc.ptr())), exc.ptr());
    throw nb::python_error();
}

[[noreturn]] void value_error(const char *call, const std::string &what)
{
    throw nb::value_error((std::string(call) + ": " + what).c_str());
}

std::string shape_str(const InArray &a)
{
    std::string s = "(";
    for (size_t i = 0; i < a.ndim(); ++i) {
        if (i) s += ", ";
        s += std::to_string(a.shape(i));
    }
    return s + (a.ndim() == 1 ? ",)" : ")");
}

// ---- arguments ------------------------------------------------------------

// obj as a C-contiguous array of real: as it is when it already is one,
// else through dkf._convert.as_real (other real dtypes, sequences; TypeError
// for anything else).
InArray as_array(nb::handle obj, const char *call, const char *name)
{
    InArray out;
    if (nb::try_cast(obj, out, false)) return out;
    nb::object conv =
        nb::module_::import_("dkf._convert").attr("as_real")(obj, call, name, DKF_PY_DTYPE);
    if (!nb::try_cast(conv, out, false))
        throw nb::type_error((std::string(call) + ": " + name + ": not convertible").c_str());
    return out;
}

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

Mat matrix_arg(nb::handle obj, const char *call, const char *name, size_t rows, size_t cols,
               bool stack_ok)
{
    Mat m;
    m.keep = as_array(obj, call, name);
    const size_t nd = m.keep.ndim();
    if (nd != 2 && !(stack_ok && nd == 3)) {
        value_error(call, std::string(name) + " must be " + (stack_ok ? "2-D or 3-D" : "2-D") +
                              ", got shape " + shape_str(m.keep));
    }
    m.stacked = nd == 3;
    m.count = m.stacked ? m.keep.shape(0) : 1;
    m.rows = m.keep.shape(nd - 2);
    m.cols = m.keep.shape(nd - 1);
    if ((rows && m.rows != rows) || (cols && m.cols != cols) || m.rows == 0 || m.cols == 0) {
        value_error(call, std::string(name) + " must be (" + (rows ? std::to_string(rows) : "m") +
                              ", " + (cols ? std::to_string(cols) : "n") + ")" +
                              (stack_ok ? " or a stack (T, ., .)" : "") + ", got shape " +
                              shape_str(m.keep));
    }
    m.p = m.keep.data();
    return m;
}

// A vector argument of length n (0: any): shape (n,) or (n, 1).
Mat vector_arg(nb::handle obj, const char *call, const char *name, size_t n)
{
    Mat v;
    v.keep = as_array(obj, call, name);
    const size_t nd = v.keep.ndim();
    const bool ok = (nd == 1 || (nd == 2 && v.keep.shape(1) == 1)) && v.keep.shape(0) > 0 &&
                    (n == 0 || v.keep.shape(0) == n);
    if (!ok) {
        value_error(call, std::string(name) + " must be (" + (n ? std::to_string(n) : "n") +
                              ",) or (" + (n ? std::to_string(n) : "n") + ", 1), got shape " +
                              shape_str(v.keep));
    }
    v.count = 1;
    v.rows = v.keep.shape(0);
    v.cols = 1;
    v.p = v.keep.data();
    return v;
}

bool all_finite(const real *p, size_t len)
{
    for (size_t i = 0; i < len; ++i)
        if (!std::isfinite(p[i])) return false;
    return true;
}

dkf_mat_t view(size_t rows, size_t cols, const real *p)
{
    // The core takes inputs as const dkf_mat_t * and never writes them.
    dkf_mat_t m = {rows, cols, const_cast<real *>(p)};
    return m;
}

OutArray new_array(size_t ndim, const size_t *shape)
{
    size_t len = 1;
    for (size_t i = 0; i < ndim; ++i) len *= shape[i];
    std::unique_ptr<real[]> buf(new real[len ? len : 1]);
    nb::capsule owner(buf.get(), [](void *p) noexcept { delete[] static_cast<real *>(p); });
    OutArray a(buf.release(), ndim, shape, owner);
    return a;
}

// ---- KalmanFilter ---------------------------------------------------------

// The inputs of one step and what a failure names (messages of raise_status).
struct StepIn {
    const real *F, *Q, *u, *H, *R, *y;
    size_t m;
};

class KalmanFilter {
public:
    KalmanFilter(nb::handle F, nb::handle Q, nb::handle H, nb::handle R, nb::handle x0,
                 nb::handle P0, nb::handle m_max)
    {
        static const char *call = "KalmanFilter";
        Mat x = vector_arg(x0, call, "x0", 0);
        n_ = x.rows;
        Mat P = matrix_arg(P0, call, "P0", n_, n_, false);
        F_ = store(matrix_arg(F, call, "F", n_, n_, true));
        Q_ = store(matrix_arg(Q, call, "Q", n_, n_, true));
        Mat h = matrix_arg(H, call, "H", 0, n_, true);
        H_ = store(h);
        R_ = store(matrix_arg(R, call, "R", h.rows, h.rows, true));
        T_ = 0;
        for (const Stored *s : {&F_, &Q_, &H_, &R_}) {
            if (!s->stacked) continue;
            if (T_ && s->count != T_)
                value_error(call, "the stacked model matrices differ in length T");
            T_ = s->count;
        }
        m_max_ = h.rows;
        if (!m_max.is_none()) {
            long mm = nb::cast<long>(m_max);
            if (mm < static_cast<long>(h.rows))
                value_error(call, "m_max must be at least H's rows, " + std::to_string(h.rows));
            m_max_ = static_cast<size_t>(mm);
        }
        storage_.assign(DKF_KF_STORAGE_LEN(n_, m_max_), real(0));
        Hs_.assign(m_max_ * n_, real(0));
        Rs_.assign(m_max_ * m_max_, real(0));
        ys_.assign(m_max_, real(0));
        std::memset(&kf_, 0, sizeof kf_);
        dkf_mat_t xm = view(n_, 1, x.p), Pm = view(n_, n_, P.p);
        dkf_status_t st = dkf_kf_init(&kf_, n_, m_max_, storage_.data(), storage_.size(), &xm, &Pm);
        if (st != DKF_OK) {
            const char *culprit = nullptr;
            std::string detail;
            if (st == DKF_ERR_NOT_SPD) {
                culprit = "P0", detail = "P0 not SPD";
            } else if (st == DKF_ERR_NONFINITE) {
                culprit = !all_finite(x.p, n_) ? "x0" : "P0";
                detail = std::string(culprit) + " not finite";
            } else if (st == DKF_ERR_CAPACITY) {
                detail = "n = " + std::to_string(n_) + ", m_max = " + std::to_string(m_max_) +
                         ": each must be at most DKF_MAX_DIM = " + std::to_string(DKF_MAX_DIM);
            }
            raise_status(st, call, -1, culprit, detail);
        }
    }
    KalmanFilter(const KalmanFilter &) = delete;
    KalmanFilter &operator=(const KalmanFilter &) = delete;

    void predict(nb::handle F, nb::handle Q, nb::handle u)
    {
        static const char *call = "KalmanFilter.predict";
        not_busy(call);
        Mat f = F.is_none() ? constant(F_, call, "F") : matrix_arg(F, call, "F", n_, n_, false);
        Mat q = Q.is_none() ? constant(Q_, call, "Q") : matrix_arg(Q, call, "Q", n_, n_, false);
        Mat uu;
        if (!u.is_none()) uu = vector_arg(u, call, "u", n_);
        StepIn in = {f.p, q.p, uu.p, nullptr, nullptr, nullptr, 0};
        dkf_status_t st = step_predict(in);
        if (st != DKF_OK) raise_step(st, call, -1, in, true);
    }

    void update(nb::handle y, nb::handle H, nb::handle R)
    {
        static const char *call = "KalmanFilter.update";
        not_busy(call);
        Mat h = H.is_none() ? constant(H_, call, "H") : matrix_arg(H, call, "H", 0, n_, false);
        if (h.rows > m_max_) {
            value_error(call, "H has " + std::to_string(h.rows) + " rows, above m_max = " +
                                  std::to_string(m_max_));
        }
        Mat r = R.is_none() ? constant(R_, call, "R")
                            : matrix_arg(R, call, "R", h.rows, h.rows, false);
        if (r.rows != h.rows) value_error(call, "R must be (m, m) with m = H's rows");
        Mat yy = vector_arg(y, call, "y", h.rows);
        StepIn in = {nullptr, nullptr, nullptr, h.p, r.p, yy.p, h.rows};
        dkf_status_t st = step_update(in);
        if (st != DKF_OK) raise_step(st, call, -1, in, false);
    }

    nb::tuple filter(nb::handle Y, nb::handle F, nb::handle Q, nb::handle H, nb::handle R)
    {
        static const char *call = "KalmanFilter.filter";
        not_busy(call);
        Mat f = F.is_none() ? stored(F_) : matrix_arg(F, call, "F", n_, n_, true);
        Mat q = Q.is_none() ? stored(Q_) : matrix_arg(Q, call, "Q", n_, n_, true);
        Mat h = H.is_none() ? stored(H_) : matrix_arg(H, call, "H", 0, n_, true);
        if (h.rows > m_max_) {
            value_error(call, "H has " + std::to_string(h.rows) + " rows, above m_max = " +
                                  std::to_string(m_max_));
        }
        Mat r = R.is_none() ? stored(R_) : matrix_arg(R, call, "R", h.rows, h.rows, true);
        if (r.rows != h.rows) value_error(call, "R must be (m, m) with m = H's rows");
        InArray ya = as_array(Y, call, "Y");
        if (ya.ndim() != 2 || ya.shape(1) != h.rows) {
            value_error(call, "Y must be (T, " + std::to_string(h.rows) + "), got shape " +
                                  shape_str(ya));
        }
        const size_t T = ya.shape(0);
        const Mat *ms[4] = {&f, &q, &h, &r};
        static const char *names[4] = {"F", "Q", "H", "R"};
        for (int i = 0; i < 4; ++i) {
            if (ms[i]->stacked && ms[i]->count != T) {
                value_error(call, std::string(names[i]) + " is a stack of " +
                                      std::to_string(ms[i]->count) + ", Y has T = " +
                                      std::to_string(T) + " rows");
            }
        }
        const size_t xs[2] = {T, n_}, ps[3] = {T, n_, n_};
        OutArray X = new_array(2, xs), P = new_array(3, ps);
        real *Xo = X.data(), *Po = P.data();
        const real *yp = ya.data();

        // Run on the live filter; a failure at step t restores it as it was
        // before the call (the struct and all of its storage, byte for byte).
        dkf_kf_t saved_kf = kf_;
        std::vector<real> saved(storage_);
        dkf_status_t st = DKF_OK;
        size_t t = 0;
        bool in_predict = true;
        StepIn in = {};
        busy_ = true;
        {
            nb::gil_scoped_release unlocked;
            for (t = 0; t < T; ++t) {
                in = {f.at(t), q.at(t), nullptr, h.at(t), r.at(t), yp + t * h.rows, h.rows};
                in_predict = true;
                st = step_predict(in);
                if (st != DKF_OK) break;
                in_predict = false;
                st = step_update(in);
                if (st != DKF_OK) break;
                std::memcpy(Xo + t * n_, kf_.x.data, n_ * sizeof(real));
                std::memcpy(Po + t * n_ * n_, kf_.P.data, n_ * n_ * sizeof(real));
            }
            if (st != DKF_OK) {
                kf_ = saved_kf;
                std::memcpy(storage_.data(), saved.data(), saved.size() * sizeof(real));
            }
        }
        busy_ = false;
        if (st != DKF_OK) raise_step(st, call, static_cast<long>(t), in, in_predict);
        return nb::make_tuple(X, P);
    }

    OutArray x() const
    {
        not_busy("KalmanFilter.x");
        const size_t shape[1] = {n_};
        OutArray a = new_array(1, shape);
        std::memcpy(a.data(), kf_.x.data, n_ * sizeof(real));
        return a;
    }

    OutArray P() const
    {
        not_busy("KalmanFilter.P");
        const size_t shape[2] = {n_, n_};
        OutArray a = new_array(2, shape);
        std::memcpy(a.data(), kf_.P.data, n_ * n_ * sizeof(real));
        return a;
    }

    size_t n() const { return n_; }
    size_t m_max() const { return m_max_; }

private:
    struct Stored {
        std::vector<real> data;
        size_t count = 0, rows = 0, cols = 0;
        bool stacked = false;
    };

    static Stored store(const Mat &m)
    {
        Stored s;
        s.data.assign(m.p, m.p + m.count * m.rows * m.cols);
        s.count = m.count;
        s.rows = m.rows;
        s.cols = m.cols;
        s.stacked = m.stacked;
        return s;
    }

    static Mat stored(const Stored &s)
    {
        Mat m;
        m.p = s.data.data();
        m.count = s.count;
        m.stacked = s.stacked;
        m.rows = s.rows;
        m.cols = s.cols;
        return m;
    }

    // The constructor's matrix for a single step: refused when it is a stack.
    static Mat constant(const Stored &s, const char *call, const char *name)
    {
        if (s.stacked) {
            value_error(call, std::string(name) + " was given as a stack (T, ., .): pass " +
                                  name + "= to this call, or run filter()");
        }
        return stored(s);
    }

    void not_busy(const char *call) const
    {
        if (busy_) {
            throw std::runtime_error(std::string(call) +
                                     ": the filter is running filter() in another thread");
        }
    }

    // One time update; no Python (filter() runs it without the GIL).
    dkf_status_t step_predict(const StepIn &in)
    {
        dkf_mat_t F = view(n_, n_, in.F), Q = view(n_, n_, in.Q), u = view(n_, 1, in.u);
        dkf_kf_dyn_t dyn = {&F, &Q};
        return dkf_kf_predict(&kf_, &dyn, in.u ? &u : nullptr);
    }

    // One measurement update. A NaN in y marks that component missing: the
    // update uses the other rows of y, H and the rows and columns of R (the
    // marginal of the measurement noise); a y of NaN only is no update
    // (docs/decisions.md item 57). No Python.
    dkf_status_t step_update(const StepIn &in)
    {
        const size_t m = in.m;
        size_t k = 0;
        for (size_t i = 0; i < m; ++i) k += std::isnan(in.y[i]) ? 0 : 1;
        if (k == 0) return DKF_OK;
        const real *H = in.H, *R = in.R, *y = in.y;
        if (k < m) {
            size_t a = 0;
            for (size_t i = 0; i < m; ++i) {
                if (std::isnan(in.y[i])) continue;
                ys_[a] = in.y[i];
                std::memcpy(&Hs_[a * n_], in.H + i * n_, n_ * sizeof(real));
                size_t b = 0;
                for (size_t j = 0; j < m; ++j) {
                    if (!std::isnan(in.y[j])) Rs_[a * k + b++] = in.R[i * m + j];
                }
                ++a;
            }
            H = Hs_.data(), R = Rs_.data(), y = ys_.data();
        }
        dkf_mat_t Hm = view(k, n_, H), Rm = view(k, k, R), ym = view(k, 1, y);
        dkf_kf_meas_t meas = {&Hm, &Rm};
        return dkf_kf_update(&kf_, &meas, &ym);
    }

    // The dkf.Error of a failed step, naming the matrix where one is to blame.
    [[noreturn]] void raise_step(dkf_status_t st, const char *call, long step, const StepIn &in,
                                 bool predict) const
    {
        const char *culprit = nullptr;
        std::string detail;
        if (st == DKF_ERR_NONFINITE) {
            if (predict) {
                culprit = !all_finite(in.F, n_ * n_) ? "F"
                          : !all_finite(in.Q, n_ * n_) ? "Q"
                          : (in.u && !all_finite(in.u, n_)) ? "u"
                                                             : nullptr;
            } else {
                bool y_inf = false;
                for (size_t i = 0; i < in.m; ++i) y_inf = y_inf || std::isinf(in.y[i]);
                culprit = y_inf ? "y"
                          : !all_finite(in.H, in.m * n_) ? "H"
                          : !all_finite(in.R, in.m * in.m) ? "R"
                                                           : nullptr;
            }
            detail = culprit ? std::string(culprit) + " not finite" +
                                   (culprit[0] == 'y' ? " (a NaN is a missing value, an "
                                                        "infinity is refused)"
                                                      : "")
                             : std::string("the step overflowed");
        } else if (st == DKF_ERR_NOT_SPD) {
            culprit = predict ? "Q" : "R";
            detail = predict ? "the new P = F P F^T + Q is not PSD (Q indefinite?)"
                             : "S = H P H^T + R is not SPD, or the new P is not PSD "
                               "(R indefinite?)";
        }
        std::string where = std::string(predict ? "predict" : "update");
        if (step >= 0) detail = where + ": " + detail;
        raise_status(st, call, step, culprit, detail);
    }

    size_t n_ = 0, m_max_ = 0, T_ = 0;
    std::vector<real> storage_, Hs_, Rs_, ys_;
    dkf_kf_t kf_;
    Stored F_, Q_, H_, R_;
    bool busy_ = false;
};

} // namespace DKF_PY_NS

NB_MODULE(DKF_PY_MODULE, m)
{
    using namespace DKF_PY_NS;
    m.doc() = "dkf's filters over the core built in " DKF_PY_DTYPE " (docs/guide/python.md)";
    m.attr("dtype") = DKF_PY_DTYPE;
    m.attr("MAX_DIM") = DKF_MAX_DIM;
    m.attr("JOSEPH") = DKF_JOSEPH;
    m.def("_status_str", [](int st) { return dkf_status_str(static_cast<dkf_status_t>(st)); });

    nb::class_<KalmanFilter>(m, "KalmanFilter",
                             "Linear Kalman filter, covariance form (dkf/kf.h).")
        .def(nb::init<nb::handle, nb::handle, nb::handle, nb::handle, nb::handle, nb::handle,
                      nb::handle>(),
             nb::arg("F"), nb::arg("Q"), nb::arg("H"), nb::arg("R"), nb::arg("x0"), nb::arg("P0"),
             nb::kw_only(), nb::arg("m_max") = nb::none())
        .def("predict", &KalmanFilter::predict, nb::arg("F") = nb::none(),
             nb::arg("Q") = nb::none(), nb::arg("u") = nb::none(),
             "Time update x = F x + u, P = F P F^T + Q.")
        .def("update", &KalmanFilter::update, nb::arg("y"), nb::arg("H") = nb::none(),
             nb::arg("R") = nb::none(),
             "Measurement update with y; NaN components of y are missing.")
        .def("filter", &KalmanFilter::filter, nb::arg("Y"), nb::kw_only(),
             nb::arg("F") = nb::none(), nb::arg("Q") = nb::none(), nb::arg("H") = nb::none(),
             nb::arg("R") = nb::none(),
             "Runs a predict and an update per row of Y (T, m) in one call without the GIL; "
             "returns (X (T, n), P (T, n, n)), the filtered estimates.")
        .def_prop_ro("x", &KalmanFilter::x, nb::rv_policy::take_ownership,
                     "The state estimate (n,), a copy.")
        .def_prop_ro("P", &KalmanFilter::P, nb::rv_policy::take_ownership,
                     "Its error covariance (n, n), a copy.")
        .def_prop_ro("n", &KalmanFilter::n)
        .def_prop_ro("m_max", &KalmanFilter::m_max)
        .def("__repr__", [](const KalmanFilter &k) {
            return "<dkf KalmanFilter n=" + std::to_string(k.n()) +
                   " m_max=" + std::to_string(k.m_max()) + " " DKF_PY_DTYPE ">";
        });
}
