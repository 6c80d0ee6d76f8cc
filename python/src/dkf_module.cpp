// python/src/dkf_module.cpp - the extension module dkf._dkf_double or
// dkf._dkf_float (DKF_PY_MODULE), over the core built in that real type
// (python/CMakeLists.txt). The filters are the core's: this file checks
// and converts arguments, calls dkf_*, and turns a status into a dkf.Error
// (python/dkf/_errors.py). docs/guide/python.md is the user's guide.
#include <nanobind/nanobind.h>
#include <nanobind/ndarray.h>
#include <nanobind/stl/string.h>
#include <nanobind/stl/vector.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <initializer_list>
#include <memory>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "dkf/askf.h"
#include "dkf/diffkf.h"
#include "dkf/diffkf_fusion.h"
#include "dkf/info.h"
#include "dkf/kf.h"
#include "dkf/mat_riccati.h"
#include "dkf/otskf.h"
#include "dkf/selftune.h"
#include "dkf/status.h"
#include "dkf/uif.h"
#include "dkf/wfusion.h"

#include "common.h"

namespace DKF_PY_NS {

// ---- errors -------------------------------------------------------------

// Raises the dkf.Error subclass of status st. call: "KalmanFilter.update";
// step: the step of filter() or -1; matrix: the input the status concerns
// or nullptr; detail: what failed, in the model's words; node: the sensor a
// fusion centre's fault names, or -1.
[[noreturn]] void raise_status(dkf_status_t st, const char *call, long step, const char *matrix,
                               const std::string &detail, long node)
{
    nb::object make = nb::module_::import_("dkf._errors").attr("_make");
    nb::object exc = make(static_cast<int>(st), dkf_status_str(st), call,
                          step < 0 ? nb::object(nb::none()) : nb::object(nb::int_(step)),
                          matrix ? nb::object(nb::str(matrix)) : nb::object(nb::none()), detail,
                          node < 0 ? nb::object(nb::none()) : nb::object(nb::int_(node)));
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

// ---- pieces the filters share ---------------------------------------------

// The first of the inputs with a NaN or an infinity (a measurement: with an
// infinity), or nullptr.
const char *first_nonfinite(std::initializer_list<Named> inputs)
{
    for (const Named &in : inputs) {
        if (!in.p) continue;
        for (size_t i = 0; i < in.len; ++i) {
            if (in.nan_missing ? std::isinf(in.p[i]) : !std::isfinite(in.p[i])) return in.name;
        }
    }
    return nullptr;
}

// A NONFINITE status's detail: the input to blame, or an overflow.
std::string nonfinite_detail(const char *culprit)
{
    if (!culprit) return "the step overflowed";
    return std::string(culprit) + " not finite" +
           (culprit[0] == 'y' || culprit[0] == 'z'
                ? " (a NaN is a missing value, an infinity is refused)"
                : "");
}

// A failed init: the status with the matrix it concerns.
[[noreturn]] void raise_init(dkf_status_t st, const char *call, const Mat &x, const Mat &P,
                             const std::string &sizes)
{
    const char *culprit = nullptr;
    std::string detail;
    if (st == DKF_ERR_NOT_SPD) {
        culprit = "P0", detail = "P0 not SPD";
    } else if (st == DKF_ERR_NONFINITE) {
        culprit = first_nonfinite({{"x0", x.p, x.rows, false}, {"P0", P.p, P.rows * P.cols, false}});
        detail = nonfinite_detail(culprit);
    } else if (st == DKF_ERR_CAPACITY) {
        detail = sizes + ": each must be at most DKF_MAX_DIM = " + std::to_string(DKF_MAX_DIM);
    }
    raise_status(st, call, -1, culprit, detail);
}

Stored store(const Mat &m)
{
    Stored s;
    s.data.assign(m.p, m.p + m.count * m.rows * m.cols);
    s.count = m.count;
    s.rows = m.rows;
    s.cols = m.cols;
    s.stacked = m.stacked;
    return s;
}

Mat stored(const Stored &s)
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
Mat constant(const Stored &s, const char *call, const char *name)
{
    if (s.stacked) {
        value_error(call, std::string(name) + " was given as a stack (T, ., .): pass " + name +
                              "= to this call, or run filter()");
    }
    return stored(s);
}

// T of the stacks among ms (0 if none), ValueError if they differ.
size_t stack_length(std::initializer_list<const Stored *> ms, const char *call)
{
    size_t T = 0;
    for (const Stored *s : ms) {
        if (!s->stacked) continue;
        if (T && s->count != T) value_error(call, "the stacked model matrices differ in length T");
        T = s->count;
    }
    return T;
}

// A stack given to filter() must have one entry per row of Y.
void check_stack(const Mat &m, size_t T, const char *call, const std::string &name)
{
    if (m.stacked && m.count != T) {
        value_error(call, name + " is a stack of " + std::to_string(m.count) + ", Y has T = " +
                              std::to_string(T) + " rows");
    }
}

OutArray copy_out(const real *p, size_t ndim, const size_t *shape)
{
    OutArray a = new_array(ndim, shape);
    size_t len = 1;
    for (size_t i = 0; i < ndim; ++i) len *= shape[i];
    std::memcpy(a.data(), p, len * sizeof(real));
    return a;
}

// The measured components of (y, H, R) (docs/decisions.md item 57): a NaN
// in y marks that component missing. Returns how many are measured, k; when
// 0 < k < m, ys, Hs, Rs (m_max, m_max n, m_max^2 reals) hold y, the rows of
// H and the rows and columns of R of the measured components, and *y, *H,
// *R point there. No Python.
size_t select_measured(const real **y, const real **H, const real **R, size_t m, size_t n,
                       real *ys, real *Hs, real *Rs)
{
    const real *y0 = *y, *H0 = *H, *R0 = *R;
    size_t k = 0;
    for (size_t i = 0; i < m; ++i) k += std::isnan(y0[i]) ? 0 : 1;
    if (k == 0 || k == m) return k;
    size_t a = 0;
    for (size_t i = 0; i < m; ++i) {
        if (std::isnan(y0[i])) continue;
        ys[a] = y0[i];
        std::memcpy(Hs + a * n, H0 + i * n, n * sizeof(real));
        size_t b = 0;
        for (size_t j = 0; j < m; ++j)
            if (!std::isnan(y0[j])) Rs[a * k + b++] = R0[i * m + j];
        ++a;
    }
    *y = ys, *H = Hs, *R = Rs;
    return k;
}

// Row t of an output array of matrices shaped like M: M's reals.
void put_row(real *out, size_t t, const dkf_mat_t &M)
{
    const size_t len = M.rows * M.cols;
    std::memcpy(out + t * len, M.data, len * sizeof(real));
}

// ---- KalmanFilter ---------------------------------------------------------

// The inputs of one step (the messages of a failure name them).
struct StepIn {
    const real *F, *Q, *u, *H, *R, *y;
    size_t m;
};

class KalmanFilter : Guarded {
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
        stack_length({&F_, &Q_, &H_, &R_}, call);
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
            raise_init(st, call, x, P,
                       "n = " + std::to_string(n_) + ", m_max = " + std::to_string(m_max_));
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
        check_m(h, call);
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
        check_m(h, call);
        Mat r = R.is_none() ? stored(R_) : matrix_arg(R, call, "R", h.rows, h.rows, true);
        if (r.rows != h.rows) value_error(call, "R must be (m, m) with m = H's rows");
        InArray ya = as_array(Y, call, "Y");
        if (ya.ndim() != 2 || ya.shape(1) != h.rows) {
            value_error(call, "Y must be (T, " + std::to_string(h.rows) + "), got shape " +
                                  shape_str(ya));
        }
        const size_t T = ya.shape(0);
        check_stack(f, T, call, "F");
        check_stack(q, T, call, "Q");
        check_stack(h, T, call, "H");
        check_stack(r, T, call, "R");
        const size_t xs[2] = {T, n_}, ps[3] = {T, n_, n_};
        OutArray X = new_array(2, xs), P = new_array(3, ps);
        real *Xo = X.data(), *Po = P.data();
        const real *yp = ya.data();

        // Run on the live filter; a failure at step t puts it back as it was.
        Undo<dkf_kf_t> undo(kf_, storage_);
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
                put_row(Xo, t, kf_.x);
                put_row(Po, t, kf_.P);
            }
            if (st != DKF_OK) undo.restore();
        }
        busy_ = false;
        if (st != DKF_OK) raise_step(st, call, static_cast<long>(t), in, in_predict);
        return nb::make_tuple(X, P);
    }

    OutArray x() const
    {
        not_busy("KalmanFilter.x");
        const size_t shape[1] = {n_};
        return copy_out(kf_.x.data, 1, shape);
    }

    OutArray P() const
    {
        not_busy("KalmanFilter.P");
        const size_t shape[2] = {n_, n_};
        return copy_out(kf_.P.data, 2, shape);
    }

    size_t n() const { return n_; }
    size_t m_max() const { return m_max_; }

private:
    void check_m(const Mat &h, const char *call) const
    {
        if (h.rows > m_max_) {
            value_error(call, "H has " + std::to_string(h.rows) + " rows, above m_max = " +
                                  std::to_string(m_max_));
        }
    }

    // One time update; no Python (filter() runs it without the GIL).
    dkf_status_t step_predict(const StepIn &in)
    {
        dkf_mat_t F = view(n_, n_, in.F), Q = view(n_, n_, in.Q), u = view(n_, 1, in.u);
        dkf_kf_dyn_t dyn = {&F, &Q};
        return dkf_kf_predict(&kf_, &dyn, in.u ? &u : nullptr);
    }

    // One measurement update of the measured components; none measured:
    // no update. No Python.
    dkf_status_t step_update(const StepIn &in)
    {
        const real *H = in.H, *R = in.R, *y = in.y;
        const size_t k = select_measured(&y, &H, &R, in.m, n_, ys_.data(), Hs_.data(), Rs_.data());
        if (k == 0) return DKF_OK;
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
            culprit = predict ? first_nonfinite({{"F", in.F, n_ * n_, false},
                                                 {"Q", in.Q, n_ * n_, false},
                                                 {"u", in.u, n_, false}})
                              : first_nonfinite({{"y", in.y, in.m, true},
                                                 {"H", in.H, in.m * n_, false},
                                                 {"R", in.R, in.m * in.m, false}});
            detail = nonfinite_detail(culprit);
        } else if (st == DKF_ERR_NOT_SPD) {
            culprit = predict ? "Q" : "R";
            detail = predict ? "the new P = F P F^T + Q is not PSD (Q indefinite?)"
                             : "S = H P H^T + R is not SPD, or the new P is not PSD "
                               "(R indefinite?)";
        }
        if (step >= 0) detail = std::string(predict ? "predict: " : "update: ") + detail;
        raise_status(st, call, step, culprit, detail);
    }

    size_t n_ = 0, m_max_ = 0;
    std::vector<real> storage_, Hs_, Rs_, ys_;
    dkf_kf_t kf_;
    Stored F_, Q_, H_, R_;
};

// ---- InformationFilter ----------------------------------------------------

// A sensor's measurement model and data for one step.
struct Sensor {
    const real *H, *R, *z;
    size_t m;
};

// A sequence argument of L per-sensor matrices (each one, or a stack).
std::vector<Mat> sensor_mats(nb::handle seq, const char *call, const char *name, size_t L,
                             const std::vector<size_t> &rows, size_t n)
{
    if (!nb::isinstance<nb::sequence>(seq) || nb::isinstance<nb::str>(seq))
        throw nb::type_error((std::string(call) + ": " + name + " must be a sequence of arrays, "
                              "one per sensor").c_str());
    nb::sequence sq = nb::borrow<nb::sequence>(seq);
    if (nb::len(sq) != L) {
        value_error(call, std::string(name) + " has " + std::to_string(nb::len(sq)) +
                              " entries, one per sensor: " + std::to_string(L));
    }
    std::vector<Mat> out;
    for (size_t j = 0; j < L; ++j) {
        const std::string nm = std::string(name) + "[" + std::to_string(j) + "]";
        out.push_back(matrix_arg(sq[j], call, nm.c_str(), rows.empty() ? 0 : rows[j],
                                 n ? n : rows[j], true));
    }
    return out;
}

// (i, I) of one sensor, computed by dkf_info_contribution on the measured
// components of z (none: i = 0, I = 0, and *measured = false). No Python.
struct Contributor {
    std::vector<real> work, zs, Hs, Rs;
    size_t n = 0;
    explicit Contributor(size_t n_, size_t m_max)
        : work(DKF_INFO_CONTRIB_WORK(n_, m_max)), zs(m_max), Hs(m_max * n_), Rs(m_max * m_max),
          n(n_)
    {
    }
    dkf_status_t operator()(real *i, real *I, const Sensor &s, bool *measured)
    {
        const real *z = s.z, *H = s.H, *R = s.R;
        const size_t k = select_measured(&z, &H, &R, s.m, n, zs.data(), Hs.data(), Rs.data());
        *measured = k > 0;
        if (k == 0) {
            std::fill(i, i + n, real(0));
            std::fill(I, I + n * n, real(0));
            return DKF_OK;
        }
        dkf_mat_t im = view(n, 1, i), Im = view(n, n, I);
        dkf_mat_t Hm = view(k, n, H), Rm = view(k, k, R), zm = view(k, 1, z);
        dkf_kf_meas_t meas = {&Hm, &Rm};
        return dkf_info_contribution(&im, &Im, &meas, &zm, work.data());
    }
};

// What a failed contribution names.
[[noreturn]] void raise_contribution(dkf_status_t st, const char *call, long step, long sensor,
                                     const Sensor &s, size_t n)
{
    const char *culprit = nullptr;
    std::string detail;
    if (st == DKF_ERR_NONFINITE) {
        culprit = first_nonfinite(
            {{"z", s.z, s.m, true}, {"H", s.H, s.m * n, false}, {"R", s.R, s.m * s.m, false}});
        detail = nonfinite_detail(culprit);
    } else if (st == DKF_ERR_NOT_SPD) {
        culprit = "R", detail = "R not SPD";
    }
    if (sensor >= 0) detail = "sensor " + std::to_string(sensor) + ": " + detail;
    raise_status(st, call, step, culprit, detail);
}

size_t largest(const std::vector<size_t> &v)
{
    size_t a = 1;
    for (size_t x : v) a = x > a ? x : a;
    return a;
}

nb::tuple info_contribution(nb::handle z, nb::handle H, nb::handle R)
{
    static const char *call = "info_contribution";
    Mat h = matrix_arg(H, call, "H", 0, 0, false);
    Mat r = matrix_arg(R, call, "R", h.rows, h.rows, false);
    Mat zz = vector_arg(z, call, "z", h.rows);
    const size_t n = h.cols, is[1] = {n}, Is[2] = {n, n};
    OutArray i = new_array(1, is), I = new_array(2, Is);
    Contributor contribute(n, h.rows);
    Sensor s = {h.p, r.p, zz.p, h.rows};
    bool measured;
    dkf_status_t st = contribute(i.data(), I.data(), s, &measured);
    if (st != DKF_OK) raise_contribution(st, call, -1, -1, s, n);
    return nb::make_tuple(i, I);
}

class InformationFilter : Guarded {
public:
    InformationFilter(nb::handle F, nb::handle Q, nb::handle x0, nb::handle P0)
    {
        static const char *call = "InformationFilter";
        Mat x = vector_arg(x0, call, "x0", 0);
        n_ = x.rows;
        Mat P = matrix_arg(P0, call, "P0", n_, n_, false);
        F_ = store(matrix_arg(F, call, "F", n_, n_, true));
        Q_ = store(matrix_arg(Q, call, "Q", n_, n_, true));
        stack_length({&F_, &Q_}, call);
        storage_.assign(DKF_INFO_STORAGE_LEN(n_), real(0));
        std::memset(&f_, 0, sizeof f_);
        dkf_mat_t xm = view(n_, 1, x.p), Pm = view(n_, n_, P.p);
        dkf_status_t st = dkf_info_init(&f_, n_, storage_.data(), storage_.size(), &xm, &Pm);
        if (st != DKF_OK) raise_init(st, call, x, P, "n = " + std::to_string(n_));
    }
    InformationFilter(const InformationFilter &) = delete;
    InformationFilter &operator=(const InformationFilter &) = delete;

    void predict(nb::handle F, nb::handle Q)
    {
        static const char *call = "InformationFilter.predict";
        not_busy(call);
        Mat f = F.is_none() ? constant(F_, call, "F") : matrix_arg(F, call, "F", n_, n_, false);
        Mat q = Q.is_none() ? constant(Q_, call, "Q") : matrix_arg(Q, call, "Q", n_, n_, false);
        dkf_status_t st = step_predict(f.p, q.p);
        if (st != DKF_OK) raise_predict(st, call, -1, f.p, q.p);
    }

    void update(nb::handle z, nb::handle H, nb::handle R)
    {
        static const char *call = "InformationFilter.update";
        not_busy(call);
        Mat h = matrix_arg(H, call, "H", 0, n_, false);
        Mat r = matrix_arg(R, call, "R", h.rows, h.rows, false);
        Mat zz = vector_arg(z, call, "z", h.rows);
        Contributor contribute(n_, h.rows);
        std::vector<real> i(n_), I(n_ * n_);
        Sensor s = {h.p, r.p, zz.p, h.rows};
        bool measured;
        dkf_status_t st = contribute(i.data(), I.data(), s, &measured);
        if (st != DKF_OK) raise_contribution(st, call, -1, -1, s, n_);
        if (!measured) return;
        st = step_fuse(i.data(), I.data(), 1);
        if (st != DKF_OK) raise_fuse(st, call, -1, i.data(), I.data(), 1);
    }

    void fuse(nb::handle i, nb::handle I)
    {
        static const char *call = "InformationFilter.fuse";
        not_busy(call);
        InArray ia = as_array(i, call, "i"), Ia = as_array(I, call, "I");
        const bool one = ia.ndim() == 1;
        const size_t L = one ? 1 : (ia.ndim() == 2 ? ia.shape(0) : 0);
        const bool ok = (one && ia.shape(0) == n_ && Ia.ndim() == 2 && Ia.shape(0) == n_ &&
                         Ia.shape(1) == n_) ||
                        (!one && ia.ndim() == 2 && ia.shape(1) == n_ && Ia.ndim() == 3 &&
                         Ia.shape(0) == L && Ia.shape(1) == n_ && Ia.shape(2) == n_);
        if (!ok) {
            value_error(call, "i, I must be (n,), (n, n) or (L, n), (L, n, n) with n = " +
                                  std::to_string(n_) + ", got " + shape_str(ia) + ", " +
                                  shape_str(Ia));
        }
        if (L == 0) return;
        dkf_status_t st = step_fuse(ia.data(), Ia.data(), L);
        if (st != DKF_OK) raise_fuse(st, call, -1, ia.data(), Ia.data(), L);
    }

    nb::tuple filter(nb::handle Z, nb::handle H, nb::handle R, nb::handle F, nb::handle Q)
    {
        static const char *call = "InformationFilter.filter";
        not_busy(call);
        if (!nb::isinstance<nb::sequence>(Z) || nb::isinstance<nb::str>(Z))
            throw nb::type_error("InformationFilter.filter: Z must be a sequence of arrays "
                                 "(T, m_j), one per sensor");
        nb::sequence zs = nb::borrow<nb::sequence>(Z);
        const size_t L = nb::len(zs);
        std::vector<InArray> za;
        for (size_t j = 0; j < L; ++j) {
            const std::string nm = "Z[" + std::to_string(j) + "]";
            za.push_back(as_array(zs[j], call, nm.c_str()));
            if (za[j].ndim() != 2 || (j && za[j].shape(0) != za[0].shape(0))) {
                value_error(call, nm + " must be (T, m_j) with the T of Z[0], got shape " +
                                      shape_str(za[j]));
            }
        }
        const size_t T = L ? za[0].shape(0) : 0;
        std::vector<size_t> m;
        for (size_t j = 0; j < L; ++j) m.push_back(za[j].shape(1));
        std::vector<Mat> h = sensor_mats(H, call, "H", L, m, n_);
        std::vector<Mat> r = sensor_mats(R, call, "R", L, m, 0);
        Mat f = F.is_none() ? stored(F_) : matrix_arg(F, call, "F", n_, n_, true);
        Mat q = Q.is_none() ? stored(Q_) : matrix_arg(Q, call, "Q", n_, n_, true);
        check_stack(f, T, call, "F");
        check_stack(q, T, call, "Q");
        for (size_t j = 0; j < L; ++j) {
            check_stack(h[j], T, call, "H[" + std::to_string(j) + "]");
            check_stack(r[j], T, call, "R[" + std::to_string(j) + "]");
        }
        const size_t xs[2] = {T, n_}, ps[3] = {T, n_, n_};
        OutArray X = new_array(2, xs), P = new_array(3, ps);
        real *Xo = X.data(), *Po = P.data();
        Contributor contribute(n_, largest(m));
        std::vector<real> i(L * n_ + 1), I(L * n_ * n_ + 1);

        Undo<dkf_info_t> undo(f_, storage_);
        dkf_status_t st = DKF_OK;
        size_t t = 0;
        long failed_sensor = -1;
        int phase = 0; // 0 predict, 1 contribution, 2 fuse
        size_t used = 0;
        busy_ = true;
        {
            nb::gil_scoped_release unlocked;
            for (t = 0; t < T && st == DKF_OK; ++t) {
                phase = 0;
                st = step_predict(f.at(t), q.at(t));
                if (st != DKF_OK) break;
                phase = 1;
                used = 0;
                for (size_t j = 0; j < L; ++j) {
                    Sensor s = {h[j].at(t), r[j].at(t), za[j].data() + t * m[j], m[j]};
                    bool measured;
                    st = contribute(&i[used * n_], &I[used * n_ * n_], s, &measured);
                    if (st != DKF_OK) {
                        failed_sensor = static_cast<long>(j);
                        break;
                    }
                    used += measured ? 1 : 0;
                }
                if (st != DKF_OK) break;
                phase = 2;
                if (used) st = step_fuse(i.data(), I.data(), used);
                if (st != DKF_OK) break;
                put_row(Xo, t, f_.x);
                put_row(Po, t, f_.P);
            }
            if (st != DKF_OK) undo.restore();
        }
        busy_ = false;
        if (st != DKF_OK) {
            const long step = static_cast<long>(t);
            if (phase == 0) raise_predict(st, call, step, f.at(t), q.at(t));
            if (phase == 1) {
                const size_t j = static_cast<size_t>(failed_sensor);
                Sensor s = {h[j].at(t), r[j].at(t), za[j].data() + t * m[j], m[j]};
                raise_contribution(st, call, step, failed_sensor, s, n_);
            }
            raise_fuse(st, call, step, i.data(), I.data(), used);
        }
        return nb::make_tuple(X, P);
    }

    OutArray get(const dkf_mat_t &M, const char *call) const
    {
        not_busy(call);
        const size_t shape[2] = {M.rows, M.cols};
        return copy_out(M.data, M.cols == 1 ? 1 : 2, shape);
    }
    OutArray x() const { return get(f_.x, "InformationFilter.x"); }
    OutArray P() const { return get(f_.P, "InformationFilter.P"); }
    OutArray y() const { return get(f_.y, "InformationFilter.y"); }
    OutArray Y() const { return get(f_.Y, "InformationFilter.Y"); }
    size_t n() const { return n_; }

private:
    dkf_status_t step_predict(const real *F, const real *Q)
    {
        dkf_mat_t Fm = view(n_, n_, F), Qm = view(n_, n_, Q);
        dkf_kf_dyn_t dyn = {&Fm, &Qm};
        return dkf_info_predict(&f_, &dyn);
    }

    // L contributions, i (L n reals) and I (L n^2 reals). No Python.
    dkf_status_t step_fuse(const real *i, const real *I, size_t L)
    {
        std::vector<dkf_mat_t> iv(L), Iv(L);
        for (size_t j = 0; j < L; ++j) {
            iv[j] = view(n_, 1, i + j * n_);
            Iv[j] = view(n_, n_, I + j * n_ * n_);
        }
        return dkf_info_fuse(&f_, iv.data(), Iv.data(), L);
    }

    [[noreturn]] void raise_predict(dkf_status_t st, const char *call, long step, const real *F,
                                    const real *Q) const
    {
        const char *culprit = nullptr;
        std::string detail;
        if (st == DKF_ERR_NONFINITE) {
            culprit = first_nonfinite({{"F", F, n_ * n_, false}, {"Q", Q, n_ * n_, false}});
            detail = nonfinite_detail(culprit);
        } else if (st == DKF_ERR_NOT_SPD) {
            culprit = "Q", detail = "the new P = F P F^T + Q is not SPD (Q indefinite?)";
        }
        if (step >= 0) detail = "predict: " + detail;
        raise_status(st, call, step, culprit, detail);
    }

    [[noreturn]] void raise_fuse(dkf_status_t st, const char *call, long step, const real *i,
                                 const real *I, size_t L) const
    {
        const char *culprit = nullptr;
        std::string detail;
        if (st == DKF_ERR_NONFINITE) {
            culprit = first_nonfinite({{"i", i, L * n_, false}, {"I", I, L * n_ * n_, false}});
            detail = nonfinite_detail(culprit);
        } else if (st == DKF_ERR_NOT_SPD) {
            culprit = "I", detail = "Y + sum I is not SPD (an indefinite contribution?)";
        }
        if (step >= 0) detail = "fuse: " + detail;
        raise_status(st, call, step, culprit, detail);
    }

    size_t n_ = 0;
    std::vector<real> storage_;
    dkf_info_t f_;
    Stored F_, Q_;
};

// ---- DifferenceKF ---------------------------------------------------------

// The model of one step of a filter with a modelled unknown input
// (dkf/ui_model.h's dkf_ui_dyn_t and dkf_ui_meas_t) and its measurement:
// the DKF's dynamics at k and model at k + 1; the ASKF's and the OTSKF's
// predict and update. A null pointer is an input the call does not take.
struct DkfStep {
    const real *F, *Q, *B, *Rd, *H, *D, *R, *y;
};

// The core's views of a DkfStep (n states, m measurements, p inputs).
struct UiViews {
    dkf_mat_t F, Q, B, Rd, H, D, R, y;
    dkf_ui_dyn_t dyn;
    dkf_ui_meas_t meas;
    UiViews(const DkfStep &in, size_t n, size_t m, size_t p)
        : F(view(n, n, in.F)), Q(view(n, n, in.Q)), B(view(p, p, in.B)), Rd(view(p, p, in.Rd)),
          H(view(m, n, in.H)), D(view(m, p, in.D)), R(view(m, m, in.R)), y(view(m, 1, in.y)),
          dyn{&F, &Q, &B, &Rd}, meas{&H, &D, &R}
    {
    }
    UiViews(const UiViews &) = delete;
    UiViews &operator=(const UiViews &) = delete;
};

// The first input of a DkfStep that is not finite, or nullptr.
const char *ui_culprit(const DkfStep &in, size_t n, size_t m, size_t p)
{
    return first_nonfinite({{"y", in.y, m, false},
                            {"F", in.F, n * n, false},
                            {"Q", in.Q, n * n, false},
                            {"B", in.B, p * p, false},
                            {"Rd", in.Rd, p * p, false},
                            {"H", in.H, m * n, false},
                            {"D", in.D, m * p, false},
                            {"R", in.R, m * m, false}});
}

// filter()'s model arguments of a filter indexed by time: each one matrix
// or a stack of `len` (one per time), ValueError otherwise.
void check_time_stacks(std::initializer_list<std::pair<const char *, const Mat *>> ms, size_t len,
                       const char *call, const char *times)
{
    for (const auto &nm : ms) {
        if (nm.second->stacked && nm.second->count != len) {
            value_error(call, std::string(nm.first) + " is a stack of " +
                                  std::to_string(nm.second->count) + ": a stack has one matrix per time " +
                                  times + ", " + std::to_string(len));
        }
    }
}

// filter()'s model of a filter with a modelled unknown input: F, Q, B, Rd,
// H, D, R, each one matrix or a stack of one per time 0..T (`times`
// entries, the golden vectors' per_k).
struct UiModel {
    Mat F, Q, B, Rd, H, D, R;
    UiModel(nb::handle F_, nb::handle Q_, nb::handle B_, nb::handle Rd_, nb::handle H_,
            nb::handle D_, nb::handle R_, const char *call, size_t n, size_t m, size_t p,
            size_t times)
        : F(matrix_arg(F_, call, "F", n, n, true)), Q(matrix_arg(Q_, call, "Q", n, n, true)),
          B(matrix_arg(B_, call, "B", p, p, true)), Rd(matrix_arg(Rd_, call, "Rd", p, p, true)),
          H(matrix_arg(H_, call, "H", m, n, true)), D(matrix_arg(D_, call, "D", m, p, true)),
          R(matrix_arg(R_, call, "R", m, m, true))
    {
        check_time_stacks({{"F", &F}, {"Q", &Q}, {"B", &B}, {"Rd", &Rd}, {"H", &H}, {"D", &D},
                           {"R", &R}},
                          times, call, "0..T, T + 1 =");
    }
    // The dynamics at time k and the measurement model at time j, with y.
    DkfStep at(size_t k, size_t j, const real *y) const
    {
        return {F.at(k), Q.at(k), B.at(k), Rd.at(k), H.at(j), D.at(j), R.at(j), y};
    }
};

// A matrix of the core as a new array: (rows,) for a vector, else (rows, cols).
OutArray mat_out(const dkf_mat_t &M, bool vector)
{
    const size_t shape[2] = {M.rows, M.cols};
    return copy_out(M.data, vector ? 1 : 2, shape);
}

// ---- checkpoints -------------------------------------------------------------

// A checkpoint argument: save()'s array, 1-D, of the module's dtype. Another
// dtype is refused, not converted: a checkpoint holds a filter's reals bit
// for bit, and its header does not say the real type (docs/decisions.md
// item 73).
Mat checkpoint_arg(nb::handle buf, const char *call)
{
    std::string dt;
    if (!nb::hasattr(buf, "dtype") || !nb::try_cast(buf.attr("dtype").attr("name"), dt) ||
        dt != DKF_PY_DTYPE) {
        throw nb::type_error((std::string(call) + ": buf must be an array of " DKF_PY_DTYPE
                                                  ", as save() gives, got " +
                              (dt.empty() ? nb::cast<std::string>(buf.type().attr("__name__"))
                                          : "dtype " + dt))
                                 .c_str());
    }
    Mat b;
    b.keep = as_array(buf, call, "buf");
    if (b.keep.ndim() != 1 || b.keep.shape(0) == 0)
        value_error(call, "buf must be 1-D and not empty, got shape " + shape_str(b.keep));
    b.p = b.keep.data();
    b.rows = b.keep.shape(0);
    b.cols = b.count = 1;
    return b;
}

// A refused restore: the buffer's fault (the object is unchanged).
[[noreturn]] void raise_restore(dkf_status_t st, const char *call, size_t len, size_t need)
{
    std::string detail;
    switch (st) {
    case DKF_ERR_CAPACITY:
        detail = "buf has " + std::to_string(len) + " reals, a checkpoint of this object " +
                 std::to_string(need);
        break;
    case DKF_ERR_ARG: detail = "buf is not a checkpoint of this class (tag or header)"; break;
    case DKF_ERR_DIM: detail = "buf is a checkpoint of other dimensions"; break;
    case DKF_ERR_NONFINITE: detail = "buf holds a NaN or an infinity"; break;
    default: break;
    }
    raise_status(st, call, -1, "buf", detail);
}

// A new array of len reals that save(buf, len) fills.
template <class Save> OutArray checkpoint_out(size_t len, const char *call, Save save)
{
    const size_t shape[1] = {len};
    OutArray a = new_array(1, shape);
    const dkf_status_t st = save(a.data(), len);
    if (st != DKF_OK) raise_status(st, call, -1, nullptr, "");
    return a;
}

class DifferenceKF : Guarded {
public:
    DifferenceKF(nb::handle x0, nb::handle P0, size_t m, size_t p)
    {
        static const char *call = "DifferenceKF";
        Mat x = vector_arg(x0, call, "x0", 0);
        n_ = x.rows, m_ = m, p_ = p;
        Mat P = matrix_arg(P0, call, "P0", n_, n_, false);
        if (m == 0 || p == 0) value_error(call, "m and p must be positive");
        storage_.assign(DKF_DIFFKF_STORAGE_LEN(n_, m_, p_), real(0));
        std::memset(&f_, 0, sizeof f_);
        dkf_mat_t xm = view(n_, 1, x.p), Pm = view(n_, n_, P.p);
        dkf_status_t st =
            dkf_diffkf_init(&f_, n_, m_, p_, storage_.data(), storage_.size(), &xm, &Pm);
        if (st != DKF_OK) {
            raise_init(st, call, x, P,
                       "n = " + std::to_string(n_) + ", m = " + std::to_string(m_) +
                           ", p = " + std::to_string(p_));
        }
    }
    DifferenceKF(const DifferenceKF &) = delete;
    DifferenceKF &operator=(const DifferenceKF &) = delete;

    void start(nb::handle y1, nb::handle H, nb::handle D, nb::handle R, nb::handle F0,
               nb::handle Q0)
    {
        static const char *call = "DifferenceKF.start";
        not_busy(call);
        Mat h = matrix_arg(H, call, "H", m_, n_, false), d = matrix_arg(D, call, "D", m_, p_, false),
            r = matrix_arg(R, call, "R", m_, m_, false);
        Mat y = vector_arg(y1, call, "y1", m_);
        if (F0.is_none() != Q0.is_none()) value_error(call, "give both F0 and Q0, or neither");
        Mat f, q;
        if (!F0.is_none()) {
            f = matrix_arg(F0, call, "F0", n_, n_, false);
            q = matrix_arg(Q0, call, "Q0", n_, n_, false);
        }
        DkfStep in = {f.p, q.p, nullptr, nullptr, h.p, d.p, r.p, y.p};
        dkf_status_t st = do_start(in);
        if (st != DKF_OK) raise_step(st, call, -1, in, true);
    }

    void step(nb::handle y_next, nb::handle F, nb::handle Q, nb::handle B, nb::handle Rd,
              nb::handle H, nb::handle D, nb::handle R)
    {
        static const char *call = "DifferenceKF.step";
        not_busy(call);
        Mat f = matrix_arg(F, call, "F", n_, n_, false), q = matrix_arg(Q, call, "Q", n_, n_, false),
            b = matrix_arg(B, call, "B", p_, p_, false),
            rd = matrix_arg(Rd, call, "Rd", p_, p_, false),
            h = matrix_arg(H, call, "H", m_, n_, false), d = matrix_arg(D, call, "D", m_, p_, false),
            r = matrix_arg(R, call, "R", m_, m_, false);
        Mat y = vector_arg(y_next, call, "y_next", m_);
        DkfStep in = {f.p, q.p, b.p, rd.p, h.p, d.p, r.p, y.p};
        dkf_status_t st = do_step(in);
        if (st != DKF_OK) raise_step(st, call, -1, in, false);
    }

    nb::tuple filter(nb::handle Y, nb::handle F, nb::handle Q, nb::handle B, nb::handle Rd,
                     nb::handle H, nb::handle D, nb::handle R, bool prior)
    {
        static const char *call = "DifferenceKF.filter";
        not_busy(call);
        if (f_.priv.started) {
            raise_status(DKF_ERR_STATE, call, -1, nullptr,
                         "filter() runs a filter from its start: this one has started");
        }
        InArray ya = as_array(Y, call, "Y");
        if (ya.ndim() != 2 || ya.shape(1) != m_ || ya.shape(0) < 1) {
            value_error(call, "Y must be (T, " + std::to_string(m_) + ") with T >= 1, got shape " +
                                  shape_str(ya));
        }
        const size_t T = ya.shape(0);
        const UiModel md(F, Q, B, Rd, H, D, R, call, n_, m_, p_, T + 1);
        const size_t S = T - 1, xs[2] = {S, n_}, ps[3] = {S, n_, n_};
        OutArray XF = new_array(2, xs), PF = new_array(3, ps), XN = new_array(2, xs),
                 PN = new_array(3, ps);
        real *xf = XF.data(), *pf = PF.data(), *xn = XN.data(), *pn = PN.data();
        const real *yp = ya.data();

        Undo<dkf_diffkf_t> undo(f_, storage_);
        dkf_status_t st;
        size_t t = 0;
        DkfStep in = md.at(0, 1, yp);
        in.B = in.Rd = nullptr;
        if (prior) in.F = in.Q = nullptr;
        busy_ = true;
        {
            nb::gil_scoped_release unlocked;
            st = do_start(in);
            for (t = st == DKF_OK ? 1 : 0; st == DKF_OK && t < T; ++t) {
                in = md.at(t, t + 1, yp + t * m_);
                st = do_step(in);
                if (st != DKF_OK) break;
                put_row(xf, t - 1, f_.xf);
                put_row(pf, t - 1, f_.Pf);
                put_row(xn, t - 1, f_.xn);
                put_row(pn, t - 1, f_.Pn);
            }
            if (st != DKF_OK) undo.restore();
        }
        busy_ = false;
        // t = 0: the start failed; t >= 1: the step of time k = t (y_next = Y[t])
        if (st != DKF_OK) raise_step(st, call, static_cast<long>(t), in, t == 0);
        return nb::make_tuple(XF, PF, XN, PN);
    }

    OutArray get(const dkf_mat_t &M, const char *call) const
    {
        not_busy(call);
        const size_t shape[2] = {M.rows, M.cols};
        return copy_out(M.data, M.cols == 1 ? 1 : 2, shape);
    }
    // The node message {k, x_{k|k}, x_{k|k-1}} of dkf/diffkf_fusion.h.
    nb::tuple message() const
    {
        static const char *call = "DifferenceKF.message";
        not_busy(call);
        dkf_diffkf_msg_t msg;
        dkf_status_t st = dkf_diffkf_msg_fill(&msg, 0, &f_);
        if (st != DKF_OK) {
            raise_status(st, call, -1, nullptr,
                         st == DKF_ERR_STATE ? "no step yet: the first message follows step 1"
                                             : "");
        }
        const size_t shape[1] = {n_};
        return nb::make_tuple(static_cast<size_t>(msg.k), copy_out(msg.xf, 1, shape),
                              copy_out(msg.xp, 1, shape));
    }
    // The steady gain (dkf_diffkf_set_steady): tol in [0, 1), 0 off.
    void set_steady(double tol)
    {
        static const char *call = "DifferenceKF.set_steady";
        not_busy(call);
        dkf_status_t st = dkf_diffkf_set_steady(&f_, static_cast<real>(tol));
        if (st != DKF_OK) raise_status(st, call, -1, nullptr, "tol must be in [0, 1)");
    }
    // The time k of xf (dkf_diffkf_set_time): a filter restarted at k_start
    // takes set_time(k_start - 1) after its start.
    void set_time(size_t k)
    {
        static const char *call = "DifferenceKF.set_time";
        not_busy(call);
        dkf_status_t st = dkf_diffkf_set_time(&f_, k);
        if (st != DKF_OK) raise_status(st, call, -1, nullptr, "");
    }
    OutArray save() const
    {
        static const char *call = "DifferenceKF.save";
        not_busy(call);
        return checkpoint_out(dkf_diffkf_checkpoint_len(&f_), call, [this](real *b, size_t len) {
            return dkf_diffkf_save(&f_, b, len);
        });
    }
    void restore(nb::handle buf)
    {
        static const char *call = "DifferenceKF.restore";
        not_busy(call);
        Mat b = checkpoint_arg(buf, call);
        dkf_status_t st = dkf_diffkf_restore(&f_, b.p, b.rows);
        if (st != DKF_OK) raise_restore(st, call, b.rows, dkf_diffkf_checkpoint_len(&f_));
    }
    bool steady() const { return f_.steady != 0; }
    size_t n() const { return n_; }
    size_t m() const { return m_; }
    size_t p() const { return p_; }
    size_t k() const { return f_.k; }
    bool started() const { return f_.priv.started != 0; }
    const dkf_diffkf_t &state() const { return f_; }

private:
    // No Python in either (filter() runs them without the GIL).
    dkf_status_t do_start(const DkfStep &in)
    {
        UiViews v(in, n_, m_, p_);
        return dkf_diffkf_start(&f_, in.F ? &v.F : nullptr, in.Q ? &v.Q : nullptr, &v.meas, &v.y);
    }

    dkf_status_t do_step(const DkfStep &in)
    {
        UiViews v(in, n_, m_, p_);
        return dkf_diffkf_step(&f_, &v.dyn, &v.meas, &v.y);
    }

    [[noreturn]] void raise_step(dkf_status_t st, const char *call, long step, const DkfStep &in,
                                 bool start) const
    {
        const char *culprit = nullptr;
        std::string detail;
        if (st == DKF_ERR_NONFINITE) {
            culprit = ui_culprit(in, n_, m_, p_);
            detail = culprit ? std::string(culprit) + " not finite" : "the step overflowed";
        } else if (st == DKF_ERR_RANK) {
            culprit = "D", detail = "D lacks full column rank";
        } else if (st == DKF_ERR_SINGULAR) {
            culprit = "B", detail = "B is singular";
        } else if (st == DKF_ERR_NOT_SPD) {
            detail = start ? "the prior P = F0 P0 F0^T + Q0 is not SPD (Q0 indefinite?)"
                           : "L_k is not SPD, or P_{k|k} or P_{k+1|k} is not PSD (Q, R or Rd "
                             "indefinite?)";
        } else if (st == DKF_ERR_STATE) {
            detail = "call start() before step()";
        }
        if (step >= 0) detail = std::string(start ? "start: " : "step: ") + detail;
        raise_status(st, call, step, culprit, detail);
    }

    size_t n_ = 0, m_ = 0, p_ = 0;
    std::vector<real> storage_;
    dkf_diffkf_t f_;
};

// ---- DiffKFFusionCentre ----------------------------------------------------

// A fusion centre's failure: the status, the condition and the node.
[[noreturn]] void raise_fc(dkf_status_t st, const char *call, const dkf_diffkf_fc_fault_t &fault)
{
    const long node =
        fault.node == DKF_DIFFKF_FC_NO_NODE ? -1 : static_cast<long>(fault.node);
    const char *matrix = nullptr;
    switch (fault.which) {
    case DKF_DIFFKF_FC_D_RANK: matrix = "D"; break;
    case DKF_DIFFKF_FC_B_SINGULAR: matrix = "B"; break;
    case DKF_DIFFKF_FC_PRIOR: matrix = node < 0 ? "P0" : "P0_local"; break;
    case DKF_DIFFKF_FC_MSG_NODE:
    case DKF_DIFFKF_FC_MSG_STEP:
    case DKF_DIFFKF_FC_MSG_DIM:
    case DKF_DIFFKF_FC_MSG_NONFINITE: matrix = "messages"; break;
    default: break;
    }
    std::string detail = dkf_diffkf_fc_cond_str(fault.which);
    if (node >= 0) detail = "node " + std::to_string(node) + ": " + detail;
    raise_status(st, call, -1, matrix, detail, node);
}

class DiffKFFusionCentre : Guarded {
public:
    DiffKFFusionCentre(nb::handle x0, nb::handle P0, std::vector<size_t> m, std::vector<size_t> p,
                       nb::handle P0_local)
        : m_(std::move(m)), p_(std::move(p))
    {
        static const char *call = "DiffKFFusionCentre";
        Mat x = vector_arg(x0, call, "x0", 0);
        n_ = x.rows;
        Mat P = matrix_arg(P0, call, "P0", n_, n_, false);
        l_ = m_.size();
        if (l_ == 0 || p_.size() != l_)
            value_error(call, "m and p must list the same number (>= 1) of sensors");
        std::vector<Mat> locals(l_);
        std::vector<dkf_mat_t> Pl(l_);
        std::vector<const dkf_mat_t *> Plp(l_, nullptr);
        if (!P0_local.is_none()) {
            std::vector<Mat> given = sequence_of(P0_local, call, "P0_local");
            for (size_t i = 0; i < l_; ++i) {
                if (!given[i].p) continue;
                Pl[i] = view(n_, n_, given[i].p);
                Plp[i] = &Pl[i];
            }
            locals = std::move(given);
        }
        // 0 for dimensions the centre refuses: its init then names the fault.
        const size_t len = dkf_diffkf_fc_storage_len(n_, l_, m_.data(), p_.data());
        nodes_.assign(l_, dkf_diffkf_fc_node_t());
        storage_.assign(len ? len : 1, real(0));
        std::memset(&fc_, 0, sizeof fc_);
        dkf_mat_t xm = view(n_, 1, x.p), Pm = view(n_, n_, P.p);
        dkf_diffkf_fc_fault_t fault;
        dkf_status_t st = dkf_diffkf_fc_init(&fc_, nodes_.data(), l_, n_, m_.data(), p_.data(),
                                             storage_.data(), len ? len : 1, &xm, &Pm, Plp.data(),
                                             &fault);
        if (st != DKF_OK) raise_fc(st, call, fault);
        if (len == 0) { // not reached: init refuses what the sizing refuses
            raise_status(DKF_ERR_CAPACITY, call, -1, nullptr, "dimensions the centre refuses");
        }
    }
    DiffKFFusionCentre(const DiffKFFusionCentre &) = delete;
    DiffKFFusionCentre &operator=(const DiffKFFusionCentre &) = delete;

    void start(nb::handle F0, nb::handle Q0, nb::handle sensors)
    {
        static const char *call = "DiffKFFusionCentre.start";
        not_busy(call);
        Mat f = matrix_arg(F0, call, "F0", n_, n_, false), q = matrix_arg(Q0, call, "Q0", n_, n_, false);
        Sensors s = sensor_args(sensors, call, false);
        dkf_mat_t Fm = view(n_, n_, f.p), Qm = view(n_, n_, q.p);
        dkf_diffkf_fc_fault_t fault;
        dkf_status_t st = dkf_diffkf_fc_start(&fc_, &Fm, &Qm, s.c.data(), &fault);
        if (st != DKF_OK) raise_fc(st, call, fault);
    }

    void step(nb::handle F, nb::handle Q, nb::handle sensors, nb::handle messages)
    {
        static const char *call = "DiffKFFusionCentre.step";
        not_busy(call);
        Mat f = matrix_arg(F, call, "F", n_, n_, false), q = matrix_arg(Q, call, "Q", n_, n_, false);
        Sensors s = sensor_args(sensors, call, true);
        std::vector<dkf_diffkf_msg_t> msgs = message_args(messages, call);
        dkf_mat_t Fm = view(n_, n_, f.p), Qm = view(n_, n_, q.p);
        dkf_diffkf_fc_fault_t fault;
        dkf_status_t st = dkf_diffkf_fc_step(&fc_, &Fm, &Qm, s.c.data(), msgs.data(), &fault);
        if (st != DKF_OK) raise_fc(st, call, fault);
    }

    // A step with some messages absent (None): dkf_diffkf_fc_step_partial.
    // Returns contributed: node i's z entered the fused estimate.
    std::vector<bool> step_partial(nb::handle F, nb::handle Q, nb::handle sensors,
                                   nb::handle messages)
    {
        static const char *call = "DiffKFFusionCentre.step_partial";
        not_busy(call);
        Mat f = matrix_arg(F, call, "F", n_, n_, false), q = matrix_arg(Q, call, "Q", n_, n_, false);
        Sensors s = sensor_args(sensors, call, true);
        std::vector<unsigned char> present(l_, 0), contributed(l_, 0);
        std::vector<dkf_diffkf_msg_t> msgs = message_args(messages, call, present.data());
        dkf_mat_t Fm = view(n_, n_, f.p), Qm = view(n_, n_, q.p);
        dkf_diffkf_fc_fault_t fault;
        dkf_status_t st = dkf_diffkf_fc_step_partial(&fc_, &Fm, &Qm, s.c.data(), msgs.data(),
                                                     present.data(), contributed.data(), &fault);
        if (st != DKF_OK) raise_fc(st, call, fault);
        return std::vector<bool>(contributed.begin(), contributed.end());
    }

    // Node `node` restarted its filter at k_start = self.k + 1 from the prior
    // covariance P_prior, with its model at k_start: dkf_diffkf_fc_restart_node.
    void restart_node(size_t node, size_t k_start, nb::handle P_prior, nb::handle sensor)
    {
        static const char *call = "DiffKFFusionCentre.restart_node";
        not_busy(call);
        if (node >= l_) {
            raise_status(DKF_ERR_ARG, call, -1, nullptr,
                         "node " + std::to_string(node) + ": the centre has " +
                             std::to_string(l_) + " nodes", static_cast<long>(node));
        }
        Mat P = matrix_arg(P_prior, call, "P_prior", n_, n_, false);
        Sensors s;
        s.mats.reserve(5);
        s.v.resize(5);
        s.c.resize(1);
        sensor_into(s, 0, sensor, node, "sensor", call, false);
        dkf_mat_t Pm = view(n_, n_, P.p);
        dkf_diffkf_fc_fault_t fault;
        dkf_status_t st = dkf_diffkf_fc_restart_node(&fc_, node, k_start, &Pm, s.c.data(), &fault);
        if (st == DKF_OK) return;
        if (fault.which == DKF_DIFFKF_FC_SEQUENCE) {
            raise_status(st, call, -1, nullptr,
                         "node " + std::to_string(node) + ": k_start must be self.k + 1 = " +
                             std::to_string(fc_.k + 1) + (fc_.priv.started ? "" : ", after start()"),
                         static_cast<long>(node));
        }
        if (fault.which == DKF_DIFFKF_FC_PRIOR) {
            raise_status(st, call, -1, "P_prior",
                         "node " + std::to_string(node) + ": " + dkf_diffkf_fc_cond_str(fault.which),
                         static_cast<long>(node));
        }
        raise_fc(st, call, fault);
    }

    void set_steady(double tol)
    {
        static const char *call = "DiffKFFusionCentre.set_steady";
        not_busy(call);
        dkf_status_t st = dkf_diffkf_fc_set_steady(&fc_, static_cast<real>(tol));
        if (st != DKF_OK) raise_status(st, call, -1, nullptr, "tol must be in [0, 1)");
    }

    OutArray save() const
    {
        static const char *call = "DiffKFFusionCentre.save";
        not_busy(call);
        return checkpoint_out(dkf_diffkf_fc_checkpoint_len(&fc_), call,
                              [this](real *b, size_t len) { return dkf_diffkf_fc_save(&fc_, b, len); });
    }

    void restore(nb::handle buf)
    {
        static const char *call = "DiffKFFusionCentre.restore";
        not_busy(call);
        Mat b = checkpoint_arg(buf, call);
        dkf_status_t st = dkf_diffkf_fc_restore(&fc_, b.p, b.rows);
        if (st != DKF_OK) raise_restore(st, call, b.rows, dkf_diffkf_fc_checkpoint_len(&fc_));
    }

    // Each node's replica carries its true dz: its next message is recovered.
    std::vector<bool> synced() const
    {
        not_busy("DiffKFFusionCentre.synced");
        std::vector<bool> out(l_);
        for (size_t i = 0; i < l_; ++i) out[i] = nodes_[i].sync != 0;
        return out;
    }
    bool steady() const { return fc_.central.steady != 0; }

    nb::tuple recovered(size_t i) const
    {
        static const char *call = "DiffKFFusionCentre.recovered";
        not_busy(call);
        if (i >= l_) value_error(call, "node " + std::to_string(i) + " of " + std::to_string(l_));
        const size_t shape[1] = {p_[i]};
        return nb::make_tuple(copy_out(nodes_[i].z.data, 1, shape),
                              copy_out(nodes_[i].dz.data, 1, shape));
    }

    OutArray get(const dkf_mat_t &M, const char *call) const
    {
        not_busy(call);
        const size_t shape[2] = {M.rows, M.cols};
        return copy_out(M.data, M.cols == 1 ? 1 : 2, shape);
    }
    const dkf_diffkf_t &central() const { return fc_.central; }
    size_t k() const { return fc_.k; }
    size_t n() const { return n_; }
    size_t l() const { return l_; }
    std::vector<size_t> m() const { return m_; }
    std::vector<size_t> p() const { return p_; }

private:
    // The views of every sensor's matrices (kept alive by the Mats).
    struct Sensors {
        std::vector<Mat> mats;
        std::vector<dkf_mat_t> v;
        std::vector<dkf_diffkf_sensor_t> c;
    };

    // A sequence of l matrices (n, n) or None.
    std::vector<Mat> sequence_of(nb::handle seq, const char *call, const char *name) const
    {
        if (!nb::isinstance<nb::sequence>(seq) || nb::len(seq) != l_) {
            value_error(call, std::string(name) + " must be a sequence of " + std::to_string(l_) +
                                  " matrices (or None)");
        }
        std::vector<Mat> out(l_);
        nb::sequence sq = nb::borrow<nb::sequence>(seq);
        for (size_t i = 0; i < l_; ++i) {
            if (sq[i].is_none()) continue;
            const std::string nm = std::string(name) + "[" + std::to_string(i) + "]";
            out[i] = matrix_arg(sq[i], call, nm.c_str(), n_, n_, false);
        }
        return out;
    }

    // sensors: a sequence of l mappings with B, H, D, R (and Rd in a step).
    Sensors sensor_args(nb::handle sensors, const char *call, bool with_Rd) const
    {
        if (!nb::isinstance<nb::sequence>(sensors) || nb::len(sensors) != l_) {
            value_error(call, "sensors must be a sequence of " + std::to_string(l_) +
                                  " dicts with B, Rd, H, D, R");
        }
        nb::sequence sq = nb::borrow<nb::sequence>(sensors);
        Sensors s;
        s.mats.reserve(5 * l_);
        s.v.resize(5 * l_);
        s.c.resize(l_);
        for (size_t i = 0; i < l_; ++i) {
            const std::string nm = "sensors[" + std::to_string(i) + "]";
            sensor_into(s, i, sq[i], i, nm, call, true, with_Rd);
        }
        return s;
    }

    // Entry j of s: sensor i's dict (named `name`) of B, Rd, H, D, R; B
    // (with_B) and Rd (with_Rd) optional where the call does not use them.
    void sensor_into(Sensors &s, size_t j, nb::handle item, size_t i, const std::string &name,
                     const char *call, bool with_B, bool with_Rd = false) const
    {
        static const char *keys[5] = {"B", "Rd", "H", "D", "R"};
        if (!nb::isinstance<nb::dict>(item))
            throw nb::type_error((std::string(call) + ": " + name + " must be a dict").c_str());
        nb::dict d = nb::borrow<nb::dict>(item);
        const size_t rows[5] = {p_[i], p_[i], m_[i], m_[i], m_[i]};
        const size_t cols[5] = {p_[i], p_[i], n_, p_[i], m_[i]};
        const bool needed[5] = {with_B, with_Rd, true, true, true};
        for (size_t e = 0; e < 5; ++e) {
            const std::string nm = name + "[\"" + keys[e] + "\"]";
            if (!d.contains(keys[e])) {
                if (needed[e]) value_error(call, nm + " is missing");
                s.mats.emplace_back();
                continue;
            }
            s.mats.push_back(matrix_arg(d[keys[e]], call, nm.c_str(), rows[e], cols[e], false));
            s.v[5 * j + e] = view(rows[e], cols[e], s.mats.back().p);
        }
        dkf_mat_t *v = &s.v[5 * j];
        s.c[j].B = s.mats[5 * j].p ? &v[0] : nullptr;
        s.c[j].Rd = s.mats[5 * j + 1].p ? &v[1] : nullptr;
        s.c[j].meas.H = &v[2];
        s.c[j].meas.D = &v[3];
        s.c[j].meas.R = &v[4];
    }

    // messages: a sequence of l tuples (k, xf, xp), DifferenceKF.message()'s;
    // with present (step_partial), None for an absent message (present[i] = 0).
    std::vector<dkf_diffkf_msg_t> message_args(nb::handle messages, const char *call,
                                               unsigned char *present = nullptr) const
    {
        if (!nb::isinstance<nb::sequence>(messages) || nb::len(messages) != l_) {
            value_error(call, "messages must be a sequence of " + std::to_string(l_) +
                                  " tuples (k, xf, xp)" + (present ? " or None" : ""));
        }
        nb::sequence sq = nb::borrow<nb::sequence>(messages);
        std::vector<dkf_diffkf_msg_t> out(l_);
        for (size_t i = 0; i < l_; ++i) {
            const std::string nm = "messages[" + std::to_string(i) + "]";
            nb::object item = sq[i];
            std::memset(&out[i], 0, sizeof out[i]);
            out[i].node = static_cast<uint16_t>(i);
            if (present && item.is_none()) continue;
            if (present) present[i] = 1;
            if (!nb::isinstance<nb::sequence>(item) || nb::len(item) != 3)
                value_error(call, nm + " must be a tuple (k, xf, xp)" + (present ? " or None" : ""));
            nb::sequence t = nb::borrow<nb::sequence>(item);
            long k = nb::cast<long>(t[0]);
            if (k < 0 || static_cast<unsigned long>(k) > 0xffffffffUL)
                value_error(call, nm + ": k must be in [0, 2^32)");
            Mat xf = vector_arg(t[1], call, (nm + " xf").c_str(), n_);
            Mat xp = vector_arg(t[2], call, (nm + " xp").c_str(), n_);
            out[i].k = static_cast<uint32_t>(k);
            out[i].n = static_cast<uint16_t>(n_);
            std::memcpy(out[i].xf, xf.p, n_ * sizeof(real));
            std::memcpy(out[i].xp, xp.p, n_ * sizeof(real));
        }
        return out;
    }

    size_t n_ = 0, l_ = 0;
    std::vector<size_t> m_, p_;
    std::vector<dkf_diffkf_fc_node_t> nodes_;
    std::vector<real> storage_;
    dkf_diffkf_fc_t fc_;
};

// ---- ASKF and OTSKF ---------------------------------------------------------

// What differs between the ASKF (dkf/askf.h) and the OTSKF (dkf/otskf.h):
// both predict with dkf_ui_dyn_t and update with dkf_ui_meas_t.
struct AskfOps {
    using S = dkf_askf_t;
    static constexpr const char *name = "ASKF";
    static size_t storage_len(size_t n, size_t m, size_t p) { return DKF_ASKF_STORAGE_LEN(n, m, p); }
    static dkf_status_t init(S *f, size_t n, size_t m, size_t p, real *st, size_t len,
                             const dkf_mat_t *x0, const dkf_mat_t *P0, const dkf_mat_t *d0,
                             const dkf_mat_t *Pd0, const dkf_mat_t *Pxd0)
    {
        return dkf_askf_init(f, n, m, p, st, len, x0, P0, d0, Pd0, Pxd0);
    }
    static dkf_status_t predict(S *f, const dkf_ui_dyn_t *dyn) { return dkf_askf_predict(f, dyn); }
    static dkf_status_t update(S *f, const dkf_ui_meas_t *meas, const dkf_mat_t *y)
    {
        return dkf_askf_update(f, meas, y);
    }
    // x (n), its covariance (n n), d (p), its covariance (p p): the blocks of X, P^a.
    static void read(const S &f, real *x, real *P, real *d, real *Pd)
    {
        dkf_mat_t xv, dv, Pm = view(f.n, f.n, P), Pdm = view(f.p, f.p, Pd);
        (void)dkf_askf_state(&f, &xv, &Pm);
        (void)dkf_askf_input(&f, &dv, &Pdm);
        std::memcpy(x, xv.data, f.n * sizeof(real));
        std::memcpy(d, dv.data, f.p * sizeof(real));
    }
};

struct OtskfOps {
    using S = dkf_otskf_t;
    static constexpr const char *name = "OTSKF";
    static size_t storage_len(size_t n, size_t m, size_t p) { return DKF_OTSKF_STORAGE_LEN(n, m, p); }
    static dkf_status_t init(S *f, size_t n, size_t m, size_t p, real *st, size_t len,
                             const dkf_mat_t *x0, const dkf_mat_t *P0, const dkf_mat_t *d0,
                             const dkf_mat_t *Pd0, const dkf_mat_t *)
    {
        return dkf_otskf_init(f, n, m, p, st, len, x0, P0, d0, Pd0);
    }
    static dkf_status_t predict(S *f, const dkf_ui_dyn_t *dyn) { return dkf_otskf_predict(f, dyn); }
    static dkf_status_t update(S *f, const dkf_ui_meas_t *meas, const dkf_mat_t *y)
    {
        return dkf_otskf_update(f, meas, y);
    }
    static void read(const S &f, real *x, real *P, real *d, real *Pd)
    {
        std::memcpy(x, f.x.data, f.n * sizeof(real));
        std::memcpy(P, f.P.data, f.n * f.n * sizeof(real));
        std::memcpy(d, f.d.data, f.p * sizeof(real));
        std::memcpy(Pd, f.Pd.data, f.p * f.p * sizeof(real));
    }
};

// True when every component of y (m reals) is NaN: a missing measurement.
bool all_nan(const real *y, size_t m)
{
    for (size_t i = 0; i < m; ++i)
        if (!std::isnan(y[i])) return false;
    return true;
}

// The ASKF or the OTSKF: a predict with the dynamics at k - 1 (F, Q, B, Rd)
// and an update with y_k and the model at k (H, D, R), as the C API's.
template <class Ops> class UiKF : Guarded {
public:
    using S = typename Ops::S;

    UiKF(nb::handle x0, nb::handle P0, nb::handle d0, nb::handle Pd0, size_t m, nb::handle Pxd0)
    {
        const char *call = Ops::name;
        Mat x = vector_arg(x0, call, "x0", 0);
        n_ = x.rows, m_ = m;
        Mat P = matrix_arg(P0, call, "P0", n_, n_, false);
        Mat d = vector_arg(d0, call, "d0", 0);
        p_ = d.rows;
        Mat Pd = matrix_arg(Pd0, call, "Pd0", p_, p_, false);
        Mat Pxd;
        if (!Pxd0.is_none()) Pxd = matrix_arg(Pxd0, call, "Pxd0", n_, p_, false);
        if (m == 0) value_error(call, "m must be positive");
        storage_.assign(Ops::storage_len(n_, m_, p_), real(0));
        std::memset(&f_, 0, sizeof f_);
        dkf_mat_t xm = view(n_, 1, x.p), Pm = view(n_, n_, P.p), dm = view(p_, 1, d.p),
                  Pdm = view(p_, p_, Pd.p), Pxdm = view(n_, p_, Pxd.p);
        dkf_status_t st = Ops::init(&f_, n_, m_, p_, storage_.data(), storage_.size(), &xm, &Pm,
                                    &dm, &Pdm, Pxd.p ? &Pxdm : nullptr);
        if (st == DKF_OK) return;
        const char *culprit = nullptr;
        std::string detail;
        if (st == DKF_ERR_NOT_SPD) {
            culprit = "P0", detail = "the prior covariance of [x; d] (P0, Pd0, Pxd0) is not SPD";
        } else if (st == DKF_ERR_NONFINITE) {
            culprit = first_nonfinite({{"x0", x.p, n_, false}, {"P0", P.p, n_ * n_, false},
                                       {"d0", d.p, p_, false}, {"Pd0", Pd.p, p_ * p_, false},
                                       {"Pxd0", Pxd.p, n_ * p_, false}});
            detail = nonfinite_detail(culprit);
        } else if (st == DKF_ERR_CAPACITY) {
            detail = "n = " + std::to_string(n_) + ", m = " + std::to_string(m_) + ", p = " +
                     std::to_string(p_) + ": n + p and m must be at most DKF_MAX_DIM = " +
                     std::to_string(DKF_MAX_DIM);
        }
        raise_status(st, call, -1, culprit, detail);
    }
    UiKF(const UiKF &) = delete;
    UiKF &operator=(const UiKF &) = delete;

    void predict(nb::handle F, nb::handle Q, nb::handle B, nb::handle Rd)
    {
        const std::string call = std::string(Ops::name) + ".predict";
        not_busy(call.c_str());
        Mat f = matrix_arg(F, call.c_str(), "F", n_, n_, false),
            q = matrix_arg(Q, call.c_str(), "Q", n_, n_, false),
            b = matrix_arg(B, call.c_str(), "B", p_, p_, false),
            rd = matrix_arg(Rd, call.c_str(), "Rd", p_, p_, false);
        DkfStep in = {f.p, q.p, b.p, rd.p, nullptr, nullptr, nullptr, nullptr};
        dkf_status_t st = do_predict(in);
        if (st != DKF_OK) raise_step(st, call.c_str(), -1, in, true);
    }

    void update(nb::handle y, nb::handle H, nb::handle D, nb::handle R)
    {
        const std::string call = std::string(Ops::name) + ".update";
        not_busy(call.c_str());
        Mat h = matrix_arg(H, call.c_str(), "H", m_, n_, false),
            d = matrix_arg(D, call.c_str(), "D", m_, p_, false),
            r = matrix_arg(R, call.c_str(), "R", m_, m_, false);
        Mat yy = vector_arg(y, call.c_str(), "y", m_);
        DkfStep in = {nullptr, nullptr, nullptr, nullptr, h.p, d.p, r.p, yy.p};
        dkf_status_t st = do_update(in);
        if (st != DKF_OK) raise_step(st, call.c_str(), -1, in, false);
    }

    nb::tuple filter(nb::handle Y, nb::handle F, nb::handle Q, nb::handle B, nb::handle Rd,
                     nb::handle H, nb::handle D, nb::handle R)
    {
        const std::string name = std::string(Ops::name) + ".filter";
        const char *call = name.c_str();
        not_busy(call);
        InArray ya = as_array(Y, call, "Y");
        if (ya.ndim() != 2 || ya.shape(1) != m_) {
            value_error(call, "Y must be (T, " + std::to_string(m_) + "), got shape " +
                                  shape_str(ya));
        }
        const size_t T = ya.shape(0);
        const UiModel md(F, Q, B, Rd, H, D, R, call, n_, m_, p_, T + 1);
        const size_t xs[2] = {T, n_}, ps[3] = {T, n_, n_}, ds[2] = {T, p_}, pds[3] = {T, p_, p_};
        OutArray X = new_array(2, xs), P = new_array(3, ps), Dd = new_array(2, ds),
                 Pd = new_array(3, pds);
        real *xo = X.data(), *po = P.data(), *dout = Dd.data(), *pdo = Pd.data();
        const real *yp = ya.data();

        Undo<S> undo(f_, storage_);
        dkf_status_t st = DKF_OK;
        size_t t = 0;
        bool in_predict = true;
        DkfStep in = {};
        busy_ = true;
        {
            nb::gil_scoped_release unlocked;
            // step t: y_{t+1} = Y[t], the dynamics at t, the model at t + 1
            for (t = 0; t < T; ++t) {
                in = md.at(t, t + 1, yp + t * m_);
                in_predict = true;
                st = do_predict(in);
                if (st != DKF_OK) break;
                in_predict = false;
                st = do_update(in);
                if (st != DKF_OK) break;
                Ops::read(f_, xo + t * n_, po + t * n_ * n_, dout + t * p_, pdo + t * p_ * p_);
            }
            if (st != DKF_OK) undo.restore();
        }
        busy_ = false;
        if (st != DKF_OK) raise_step(st, call, static_cast<long>(t), in, in_predict);
        return nb::make_tuple(X, P, Dd, Pd);
    }

    // The estimates x, P (of x), d, Pd (of d) as new arrays.
    nb::tuple estimate(const char *what) const
    {
        not_busy(what);
        const size_t xs[1] = {n_}, ps[2] = {n_, n_}, ds[1] = {p_}, pds[2] = {p_, p_};
        OutArray x = new_array(1, xs), P = new_array(2, ps), d = new_array(1, ds),
                 Pd = new_array(2, pds);
        Ops::read(f_, x.data(), P.data(), d.data(), Pd.data());
        return nb::make_tuple(x, P, d, Pd);
    }
    OutArray field(const dkf_mat_t &M, const char *what, bool vector) const
    {
        not_busy(what);
        return mat_out(M, vector);
    }
    const S &state() const { return f_; }
    size_t n() const { return n_; }
    size_t m() const { return m_; }
    size_t p() const { return p_; }

private:
    // No Python in either (filter() runs them without the GIL).
    dkf_status_t do_predict(const DkfStep &in)
    {
        UiViews v(in, n_, m_, p_);
        return Ops::predict(&f_, &v.dyn);
    }

    // An all-NaN y is a missing measurement: no update.
    dkf_status_t do_update(const DkfStep &in)
    {
        if (all_nan(in.y, m_)) return DKF_OK;
        UiViews v(in, n_, m_, p_);
        return Ops::update(&f_, &v.meas, &v.y);
    }

    [[noreturn]] void raise_step(dkf_status_t st, const char *call, long step, const DkfStep &in,
                                 bool predict) const
    {
        const char *culprit = nullptr;
        std::string detail;
        if (st == DKF_ERR_NONFINITE) {
            culprit = ui_culprit(in, n_, m_, p_);
            detail = culprit ? std::string(culprit) + " not finite" : "the step overflowed";
            if (culprit && culprit[0] == 'y') {
                detail += " (an all-NaN y is a missing measurement; a partly missing one is "
                          "refused: the filter's m is fixed)";
            }
        } else if (st == DKF_ERR_RANK) {
            culprit = "D", detail = "D lacks full column rank";
        } else if (st == DKF_ERR_SINGULAR) {
            culprit = "B", detail = "B is singular";
        } else if (st == DKF_ERR_NOT_SPD) {
            detail = predict ? "the predicted covariance is not PSD (Q or Rd indefinite?)"
                             : "the innovation covariance is not SPD, or the updated covariance "
                               "not PSD (R indefinite?)";
        }
        if (step >= 0) detail = std::string(predict ? "predict: " : "update: ") + detail;
        raise_status(st, call, step, culprit, detail);
    }

    size_t n_ = 0, m_ = 0, p_ = 0;
    std::vector<real> storage_;
    S f_;
};

using ASKF = UiKF<AskfOps>;
using OTSKF = UiKF<OtskfOps>;

// ---- UIF: RTSF, NRTSF-DF, NRTSF ---------------------------------------------

// The model of one dkf_uif_step: the dynamics from k - 1 (F, G, Q; null at
// an RTSF / NRTSF-DF filter's first step), the model at k (H, D, R; D null
// for the NRTSF) and y_k.
struct UifStep {
    const real *F, *G, *Q, *H, *D, *R, *y;
};

class UIF : Guarded {
public:
    UIF(nb::handle x0, nb::handle P0, size_t m, size_t p, const std::string &kind)
    {
        static const char *call = "UIF";
        if (kind == "RTSF") {
            kind_ = DKF_UIF_RTSF;
        } else if (kind == "NRTSF_DF") {
            kind_ = DKF_UIF_NRTSF_DF;
        } else if (kind == "NRTSF") {
            kind_ = DKF_UIF_NRTSF;
        } else {
            value_error(call, "kind must be \"RTSF\", \"NRTSF_DF\" or \"NRTSF\", got \"" + kind + "\"");
        }
        kind_name_ = kind;
        Mat x = vector_arg(x0, call, "x0", 0);
        n_ = x.rows, m_ = m, p_ = p;
        Mat P = matrix_arg(P0, call, "P0", n_, n_, false);
        if (m == 0 || p == 0) value_error(call, "m and p must be positive");
        storage_.assign(DKF_UIF_STORAGE_LEN(n_, m_, p_), real(0));
        std::memset(&f_, 0, sizeof f_);
        dkf_mat_t xm = view(n_, 1, x.p), Pm = view(n_, n_, P.p);
        dkf_status_t st =
            dkf_uif_init(&f_, kind_, n_, m_, p_, storage_.data(), storage_.size(), &xm, &Pm);
        if (st == DKF_ERR_RANK) {
            raise_status(st, call, -1, "D",
                         "the RTSF needs rank D = p, impossible with m = " + std::to_string(m_) +
                             " < p = " + std::to_string(p_) + " (NRTSF_DF takes any D)");
        }
        if (st != DKF_OK) {
            raise_init(st, call, x, P,
                       "n = " + std::to_string(n_) + ", m = " + std::to_string(m_) +
                           ", p = " + std::to_string(p_));
        }
    }
    UIF(const UIF &) = delete;
    UIF &operator=(const UIF &) = delete;

    void step(nb::handle y, nb::handle H, nb::handle R, nb::handle D, nb::handle F, nb::handle G,
              nb::handle Q)
    {
        static const char *call = "UIF.step";
        not_busy(call);
        const bool nf = F.is_none(), ng = G.is_none(), nq = Q.is_none();
        if (nf != ng || nf != nq) value_error(call, "give all of F, G, Q, or none");
        check_D(D.is_none(), call);
        Mat h = matrix_arg(H, call, "H", m_, n_, false), r = matrix_arg(R, call, "R", m_, m_, false);
        Mat d, f, g, q;
        if (!D.is_none()) d = matrix_arg(D, call, "D", m_, p_, false);
        if (!nf) {
            f = matrix_arg(F, call, "F", n_, n_, false);
            g = matrix_arg(G, call, "G", n_, p_, false);
            q = matrix_arg(Q, call, "Q", n_, n_, false);
        }
        Mat yy = vector_arg(y, call, "y", m_);
        UifStep in = {f.p, g.p, q.p, h.p, d.p, r.p, yy.p};
        dkf_status_t st = do_step(in);
        if (st != DKF_OK) raise_step(st, call, -1, in);
    }

    nb::tuple filter(nb::handle Y, nb::handle F, nb::handle G, nb::handle Q, nb::handle H,
                     nb::handle R, nb::handle D)
    {
        static const char *call = "UIF.filter";
        not_busy(call);
        if (f_.k != 0) {
            raise_status(DKF_ERR_STATE, call, -1, nullptr,
                         "filter() runs a filter from its start: this one has taken " +
                             std::to_string(f_.k) + " steps");
        }
        check_D(D.is_none(), call);
        const size_t first = kind_ == DKF_UIF_NRTSF ? 1 : 0;
        InArray ya = as_array(Y, call, "Y");
        if (ya.ndim() != 2 || ya.shape(1) != m_ || ya.shape(0) < first + 1) {
            value_error(call, "Y must be (T, " + std::to_string(m_) + ") with T >= " +
                                  std::to_string(first + 1) + ", got shape " + shape_str(ya));
        }
        const size_t T = ya.shape(0);
        Mat f = matrix_arg(F, call, "F", n_, n_, true), g = matrix_arg(G, call, "G", n_, p_, true),
            q = matrix_arg(Q, call, "Q", n_, n_, true), h = matrix_arg(H, call, "H", m_, n_, true),
            r = matrix_arg(R, call, "R", m_, m_, true), d;
        if (!D.is_none()) d = matrix_arg(D, call, "D", m_, p_, true);
        check_time_stacks({{"F", &f}, {"G", &g}, {"Q", &q}, {"H", &h}, {"R", &r}, {"D", &d}}, T,
                          call, "0..T-1, T =");
        const size_t S = T - first, xs[2] = {S, n_}, ps[3] = {S, n_, n_}, ds[2] = {S, p_},
                     pds[3] = {S, p_, p_};
        OutArray X = new_array(2, xs), P = new_array(3, ps), Dd = new_array(2, ds),
                 Pd = new_array(3, pds);
        real *xo = X.data(), *po = P.data(), *dout = Dd.data(), *pdo = Pd.data();
        const real *yp = ya.data();

        Undo<dkf_uif_t> undo(f_, storage_);
        dkf_status_t st = DKF_OK;
        size_t t = first;
        UifStep in = {};
        busy_ = true;
        {
            nb::gil_scoped_release unlocked;
            // step t: y_t = Y[t], the dynamics at t - 1 (none at t = 0), the model at t
            for (t = first; t < T; ++t) {
                in = {t ? f.at(t - 1) : nullptr, t ? g.at(t - 1) : nullptr,
                      t ? q.at(t - 1) : nullptr, h.at(t), d.p ? d.at(t) : nullptr, r.at(t),
                      yp + t * m_};
                st = do_step(in);
                if (st != DKF_OK) break;
                const size_t row = t - first;
                put_row(xo, row, f_.x);
                put_row(po, row, f_.Px);
                put_row(dout, row, f_.d);
                put_row(pdo, row, f_.Pd);
            }
            if (st != DKF_OK) undo.restore();
        }
        busy_ = false;
        if (st != DKF_OK) raise_step(st, call, static_cast<long>(t), in);
        return nb::make_tuple(X, P, Dd, Pd);
    }

    OutArray field(const dkf_mat_t &M, const char *what, bool vector) const
    {
        not_busy(what);
        return mat_out(M, vector);
    }
    std::vector<int> estimable() const
    {
        not_busy("UIF.estimable");
        return std::vector<int>(f_.estimable, f_.estimable + p_);
    }
    const dkf_uif_t &state() const { return f_; }
    const std::string &kind() const { return kind_name_; }
    size_t n() const { return n_; }
    size_t m() const { return m_; }
    size_t p() const { return p_; }

private:
    void check_D(bool none, const char *call) const
    {
        if (kind_ == DKF_UIF_NRTSF && !none)
            value_error(call, "the NRTSF has no feedthrough: D must be None");
        if (kind_ != DKF_UIF_NRTSF && none)
            value_error(call, "D is required (" + kind_name_ + ")");
    }

    // No Python (filter() runs it without the GIL).
    dkf_status_t do_step(const UifStep &in)
    {
        dkf_mat_t F = view(n_, n_, in.F), G = view(n_, p_, in.G), Q = view(n_, n_, in.Q),
                  H = view(m_, n_, in.H), D = view(m_, p_, in.D), R = view(m_, m_, in.R),
                  y = view(m_, 1, in.y);
        dkf_uif_dyn_t dyn = {&F, &G, &Q};
        dkf_ui_meas_t meas = {&H, in.D ? &D : nullptr, &R};
        return dkf_uif_step(&f_, in.F ? &dyn : nullptr, &meas, &y);
    }

    [[noreturn]] void raise_step(dkf_status_t st, const char *call, long step,
                                 const UifStep &in) const
    {
        const char *culprit = nullptr;
        std::string detail;
        if (st == DKF_ERR_NONFINITE) {
            culprit = first_nonfinite({{"y", in.y, m_, false},
                                       {"F", in.F, n_ * n_, false},
                                       {"G", in.G, n_ * p_, false},
                                       {"Q", in.Q, n_ * n_, false},
                                       {"H", in.H, m_ * n_, false},
                                       {"D", in.D, m_ * p_, false},
                                       {"R", in.R, m_ * m_, false}});
            detail = culprit ? std::string(culprit) + " not finite" : "the step overflowed";
        } else if (st == DKF_ERR_RANK) {
            if (kind_ == DKF_UIF_RTSF) {
                culprit = "D", detail = "D lacks full column rank p (NRTSF_DF takes any D)";
            } else if (kind_ == DKF_UIF_NRTSF_DF) {
                culprit = "D", detail = "Dbar^T R~^-1 Dbar is numerically singular";
            } else {
                culprit = "G", detail = "rank(H Gbar) < rank G: the input is not seen";
            }
        } else if (st == DKF_ERR_NOT_SPD) {
            detail = "R~ = H P H^T + R is not SPD, or the new P is not PSD (Q or R indefinite?)";
        } else if (st == DKF_ERR_STATE) {
            detail = f_.k == 0 && kind_ != DKF_UIF_NRTSF
                         ? "the first step takes no F, G, Q (x0, P0 are the prior of x_0)"
                         : "this step needs F, G, Q";
        }
        if (step >= 0) detail = "step: " + detail;
        raise_status(st, call, step, culprit, detail);
    }

    dkf_uif_kind_t kind_ = DKF_UIF_RTSF;
    std::string kind_name_;
    size_t n_ = 0, m_ = 0, p_ = 0;
    std::vector<real> storage_;
    dkf_uif_t f_;
};

// ---- WeightedFusion ----------------------------------------------------------

// A sequence of l optional vectors (n,) (None: that sensor absent), or None.
struct OptVectors {
    std::vector<Mat> keep;
    std::vector<dkf_mat_t> v;
    std::vector<const dkf_mat_t *> p;
    bool given = false;
};

OptVectors opt_vectors(nb::handle seq, const char *call, const char *name,
                       const std::vector<size_t> &len, bool none_ok)
{
    OptVectors o;
    if (seq.is_none()) return o;
    const size_t l = len.size();
    if (!nb::isinstance<nb::sequence>(seq) || nb::isinstance<nb::str>(seq) || nb::len(seq) != l) {
        value_error(call, std::string(name) + " must be a sequence of " + std::to_string(l) +
                              " vectors, one per sensor");
    }
    nb::sequence sq = nb::borrow<nb::sequence>(seq);
    o.given = true;
    o.keep.resize(l);
    o.v.resize(l);
    o.p.assign(l, nullptr);
    for (size_t i = 0; i < l; ++i) {
        nb::object item = sq[i];
        if (item.is_none() && none_ok) continue;
        const std::string nm = std::string(name) + "[" + std::to_string(i) + "]";
        o.keep[i] = vector_arg(item, call, nm.c_str(), len[i]);
        o.v[i] = view(len[i], 1, o.keep[i].p);
        o.p[i] = &o.v[i];
    }
    return o;
}

class WeightedFusion : Guarded {
public:
    WeightedFusion(nb::handle x0, nb::handle P0, nb::handle Hs, std::vector<size_t> m)
        : m_(std::move(m))
    {
        static const char *call = "WeightedFusion";
        Mat x = vector_arg(x0, call, "x0", 0);
        n_ = x.rows;
        Mat P = matrix_arg(P0, call, "P0", n_, n_, false);
        Mat hs = vector_arg(Hs, call, "Hs", n_);
        l_ = m_.size();
        if (l_ == 0) value_error(call, "m must list at least one sensor");
        const size_t len = dkf_wfusion_storage_len(n_, l_, m_.data());
        if (len == 0) {
            raise_status(DKF_ERR_CAPACITY, call, -1, nullptr,
                         "n = " + std::to_string(n_) + ", l = " + std::to_string(l_) +
                             ": n l + n and each m_i must be at most DKF_MAX_DIM = " +
                             std::to_string(DKF_MAX_DIM) + ", each m_i positive");
        }
        nodes_.assign(l_, dkf_wfusion_local_t());
        storage_.assign(len, real(0));
        std::memset(&fu_, 0, sizeof fu_);
        dkf_mat_t xm = view(n_, 1, x.p), Pm = view(n_, n_, P.p), Hm = view(1, n_, hs.p);
        dkf_status_t st = dkf_wfusion_init(&fu_, n_, l_, m_.data(), nodes_.data(), storage_.data(),
                                           len, &Hm, &xm, &Pm);
        if (st != DKF_OK) raise_init(st, call, x, P, "n = " + std::to_string(n_));
    }
    WeightedFusion(const WeightedFusion &) = delete;
    WeightedFusion &operator=(const WeightedFusion &) = delete;

    void step(nb::handle F, nb::handle Q, nb::handle H, nb::handle R, nb::handle y)
    {
        static const char *call = "WeightedFusion.step";
        not_busy(call);
        Model md(*this, F, Q, H, R, call, false);
        OptVectors yv = opt_vectors(y, call, "y", m_, false);
        dkf_status_t st = md.step(*this, 0, yv.given ? yv.v.data() : nullptr);
        if (st != DKF_OK) raise_model(st, call, -1, md, 0, yv.given ? yv.v.data() : nullptr);
    }

    void steady(nb::handle F, nb::handle Q, nb::handle H, nb::handle R)
    {
        static const char *call = "WeightedFusion.steady";
        not_busy(call);
        Model md(*this, F, Q, H, R, call, false);
        md.bind(0);
        Undo undo(*this);
        dkf_status_t st = dkf_wfusion_steady(&fu_, &md.dyn, md.meas.data());
        if (st != DKF_OK) {
            undo.restore(); // the local filters are switched one by one
            raise_model(st, call, -1, md, 0, nullptr);
        }
    }

    nb::tuple fuse_scalar(nb::handle x)
    {
        static const char *call = "WeightedFusion.fuse_scalar";
        not_busy(call);
        OptVectors xv = opt_vectors(x, call, "x", std::vector<size_t>(l_, n_), true);
        dkf_status_t st = dkf_wfusion_fuse_scalar(&fu_, xv.given ? xv.p.data() : nullptr);
        if (st != DKF_OK) raise_fuse(st, call, -1);
        return nb::make_tuple(static_cast<double>(fu_.s0), static_cast<double>(fu_.PS0));
    }

    nb::tuple fuse_matrix(nb::handle x)
    {
        static const char *call = "WeightedFusion.fuse_matrix";
        not_busy(call);
        OptVectors xv = opt_vectors(x, call, "x", std::vector<size_t>(l_, n_), true);
        dkf_status_t st = dkf_wfusion_fuse_matrix(&fu_, xv.given ? xv.p.data() : nullptr);
        if (st != DKF_OK) raise_fuse(st, call, -1);
        return nb::make_tuple(mat_out(fu_.xf, true), mat_out(fu_.Pf, false));
    }

    nb::tuple filter(nb::handle Y, nb::handle F, nb::handle Q, nb::handle H, nb::handle R)
    {
        static const char *call = "WeightedFusion.filter";
        not_busy(call);
        if (!nb::isinstance<nb::sequence>(Y) || nb::isinstance<nb::str>(Y) || nb::len(Y) != l_) {
            value_error(call, "Y must be a sequence of " + std::to_string(l_) +
                                  " arrays (T, m_i), one per sensor");
        }
        nb::sequence ys = nb::borrow<nb::sequence>(Y);
        std::vector<InArray> ya;
        for (size_t i = 0; i < l_; ++i) {
            const std::string nm = "Y[" + std::to_string(i) + "]";
            ya.push_back(as_array(ys[i], call, nm.c_str()));
            if (ya[i].ndim() != 2 || ya[i].shape(1) != m_[i] || ya[i].shape(0) != ya[0].shape(0)) {
                value_error(call, nm + " must be (T, " + std::to_string(m_[i]) +
                                      ") with the T of Y[0], got shape " + shape_str(ya[i]));
            }
        }
        const size_t T = ya[0].shape(0);
        Model md(*this, F, Q, H, R, call, true);
        md.check(T, call);
        const size_t xs[2] = {T, n_}, ps[3] = {T, n_, n_}, ss[1] = {T};
        OutArray X = new_array(2, xs), P = new_array(3, ps), S0 = new_array(1, ss),
                 PS0 = new_array(1, ss);
        real *xo = X.data(), *po = P.data(), *so = S0.data(), *pso = PS0.data();
        std::vector<dkf_mat_t> yv(l_);

        Undo undo(*this);
        dkf_status_t st = DKF_OK;
        size_t t = 0;
        int phase = 0; // 0 the step, 1 the fusions
        busy_ = true;
        {
            nb::gil_scoped_release unlocked;
            for (t = 0; t < T; ++t) {
                for (size_t i = 0; i < l_; ++i) yv[i] = view(m_[i], 1, ya[i].data() + t * m_[i]);
                phase = 0;
                st = md.step(*this, t, yv.data());
                if (st != DKF_OK) break;
                phase = 1;
                st = dkf_wfusion_fuse_scalar(&fu_, nullptr);
                if (st == DKF_OK) st = dkf_wfusion_fuse_matrix(&fu_, nullptr);
                if (st != DKF_OK) break;
                put_row(xo, t, fu_.xf);
                put_row(po, t, fu_.Pf);
                so[t] = fu_.s0;
                pso[t] = fu_.PS0;
            }
            if (st != DKF_OK) undo.restore();
        }
        busy_ = false;
        if (st != DKF_OK) {
            if (phase == 1) raise_fuse(st, call, static_cast<long>(t));
            raise_model(st, call, static_cast<long>(t), md, t, yv.data());
        }
        return nb::make_tuple(X, P, S0, PS0);
    }

    OutArray field(const dkf_mat_t &M, const char *what, bool vector) const
    {
        not_busy(what);
        return mat_out(M, vector);
    }
    // The local filters' matrices `mat`, stacked (l, rows[, cols]).
    OutArray locals(dkf_mat_t dkf_wfusion_local_t::*mat, bool vector, const char *what) const
    {
        not_busy(what);
        const dkf_mat_t &M0 = nodes_[0].*mat;
        const size_t shape[3] = {l_, M0.rows, M0.cols};
        OutArray a = new_array(vector ? 2 : 3, shape);
        for (size_t i = 0; i < l_; ++i) put_row(a.data(), i, nodes_[i].*mat);
        return a;
    }
    nb::list gains() const
    {
        not_busy("WeightedFusion.K");
        nb::list out;
        for (size_t i = 0; i < l_; ++i) out.append(mat_out(nodes_[i].K, false));
        return out;
    }
    const dkf_wfusion_t &state() const { return fu_; }
    size_t n() const { return n_; }
    size_t l() const { return l_; }
    const std::vector<size_t> &m() const { return m_; }

private:
    // The object's state, put back when a call fails part way.
    class Undo {
    public:
        explicit Undo(WeightedFusion &w)
            : w_(w), fu_(w.fu_), nodes_(w.nodes_), storage_(w.storage_)
        {
        }
        void restore()
        {
            w_.fu_ = fu_;
            std::copy(nodes_.begin(), nodes_.end(), w_.nodes_.begin());
            std::copy(storage_.begin(), storage_.end(), w_.storage_.begin());
        }

    private:
        WeightedFusion &w_;
        const dkf_wfusion_t fu_;
        const std::vector<dkf_wfusion_local_t> nodes_;
        const std::vector<real> storage_;
    };

    // The model of the calls: F, Q and each sensor's H_i, R_i (one matrix
    // or, for filter(), a stack of one per step).
    struct Model {
        Mat F, Q;
        std::vector<Mat> H, R;
        dkf_mat_t Fm, Qm;
        std::vector<dkf_mat_t> Hm, Rm;
        dkf_kf_dyn_t dyn;
        std::vector<dkf_kf_meas_t> meas;
        Model(const WeightedFusion &w, nb::handle F_, nb::handle Q_, nb::handle H_, nb::handle R_,
              const char *call, bool stack_ok)
            : F(matrix_arg(F_, call, "F", w.n_, w.n_, stack_ok)),
              Q(matrix_arg(Q_, call, "Q", w.n_, w.n_, stack_ok)),
              H(sensor_mats(H_, call, "H", w.l_, w.m_, w.n_)),
              R(sensor_mats(R_, call, "R", w.l_, w.m_, 0)), Hm(w.l_), Rm(w.l_), meas(w.l_)
        {
            for (size_t i = 0; i < w.l_ && !stack_ok; ++i) {
                if (H[i].stacked || R[i].stacked)
                    value_error(call, "H[i] and R[i] must be one matrix each (stacks: filter())");
            }
        }
        void check(size_t T, const char *call) const
        {
            check_stack(F, T, call, "F");
            check_stack(Q, T, call, "Q");
            for (size_t i = 0; i < H.size(); ++i) {
                check_stack(H[i], T, call, "H[" + std::to_string(i) + "]");
                check_stack(R[i], T, call, "R[" + std::to_string(i) + "]");
            }
        }
        // The views of step t. No Python.
        void bind(size_t t)
        {
            const size_t n = F.rows;
            Fm = view(n, n, F.at(t)), Qm = view(n, n, Q.at(t));
            dyn = {&Fm, &Qm};
            for (size_t i = 0; i < H.size(); ++i) {
                Hm[i] = view(H[i].rows, n, H[i].at(t));
                Rm[i] = view(R[i].rows, R[i].rows, R[i].at(t));
                meas[i] = {&Hm[i], &Rm[i]};
            }
        }
        dkf_status_t step(WeightedFusion &w, size_t t, const dkf_mat_t *y)
        {
            bind(t);
            return dkf_wfusion_step(&w.fu_, &dyn, meas.data(), y);
        }
    };

    [[noreturn]] void raise_model(dkf_status_t st, const char *call, long step, const Model &md,
                                  size_t t, const dkf_mat_t *y) const
    {
        const char *culprit = nullptr;
        std::string detail;
        long node = -1;
        if (st == DKF_ERR_NONFINITE) {
            culprit = first_nonfinite({{"F", md.F.at(t), n_ * n_, false},
                                       {"Q", md.Q.at(t), n_ * n_, false}});
            for (size_t i = 0; i < l_ && !culprit; ++i) {
                culprit = first_nonfinite({{"y", y ? y[i].data : nullptr, m_[i], false},
                                           {"H", md.H[i].at(t), m_[i] * n_, false},
                                           {"R", md.R[i].at(t), m_[i] * m_[i], false}});
                if (culprit) node = static_cast<long>(i);
            }
            detail = culprit ? std::string(culprit) + " not finite" : "the step overflowed";
        } else if (st == DKF_ERR_NOT_SPD) {
            detail = "H Sigma H^T + R is not SPD, or a covariance is not PSD (Q or R indefinite?)";
        } else if (st == DKF_ERR_UNSTABLE) {
            detail = "no stabilising DARE solution ((F, H_i) not detectable?) or the cross "
                     "covariances' Stein equation does not contract";
        } else if (st == DKF_ERR_NO_CONVERGENCE) {
            detail = "the doubling did not converge";
        }
        if (node >= 0) detail = "sensor " + std::to_string(node) + ": " + detail;
        raise_status(st, call, step, culprit, detail, node);
    }

    [[noreturn]] void raise_fuse(dkf_status_t st, const char *call, long step) const
    {
        const char *culprit = nullptr;
        std::string detail;
        if (st == DKF_ERR_ARG) {
            culprit = "x", detail = "no sensor present";
        } else if (st == DKF_ERR_NOT_SPD) {
            detail = "the joint covariance of the present sensors is indefinite";
        } else if (st == DKF_ERR_NONFINITE) {
            culprit = "x", detail = "x not finite";
        }
        if (step >= 0) detail = "fuse: " + detail;
        raise_status(st, call, step, culprit, detail);
    }

    size_t n_ = 0, l_ = 0;
    std::vector<size_t> m_;
    std::vector<dkf_wfusion_local_t> nodes_;
    std::vector<real> storage_;
    dkf_wfusion_t fu_;
};

// ---- SelfTuning ----------------------------------------------------------------

class SelfTuning : Guarded {
public:
    SelfTuning(size_t L, nb::handle sigma_v2, nb::handle p, double sigma_xi2, size_t na, size_t nc,
               size_t lags, size_t t_min, double root_max, double rho_max, double sigma_w2_min,
               nb::handle a0, double c0, double sigma_w2_0)
    {
        static const char *call = "SelfTuning";
        dkf_selftune_cfg_t cfg;
        (void)dkf_selftune_config_default(&cfg);
        Mat sv = vector_arg(sigma_v2, call, "sigma_v2", L);
        sv2_.assign(sv.p, sv.p + L);
        if (!p.is_none()) {
            Mat pv = vector_arg(p, call, "p", 0);
            p_.assign(pv.p, pv.p + pv.rows);
        }
        cfg.na = na, cfg.np = p_.size(), cfg.nc = nc, cfg.lags = lags, cfg.t_min = t_min;
        cfg.L = L;
        cfg.p = p_.empty() ? nullptr : p_.data();
        cfg.sigma_xi2 = static_cast<real>(sigma_xi2);
        cfg.sigma_v2 = sv2_.data();
        cfg.root_max = static_cast<real>(root_max);
        cfg.rho_max = static_cast<real>(rho_max);
        cfg.sigma_w2_min = static_cast<real>(sigma_w2_min);
        if (!a0.is_none()) {
            Mat av = vector_arg(a0, call, "a0", na);
            if (na > DKF_SELFTUNE_MAX_NA) value_error(call, "na above DKF_SELFTUNE_MAX_NA");
            std::copy(av.p, av.p + na, cfg.a0);
        }
        cfg.c0 = static_cast<real>(c0);
        cfg.sigma_w2_0 = static_cast<real>(sigma_w2_0);
        const size_t len = dkf_selftune_storage_len(na, cfg.np, nc, lags);
        storage_.assign(len ? len : 1, real(0));
        std::memset(&id_, 0, sizeof id_);
        dkf_status_t st = dkf_selftune_init(&id_, &cfg, storage_.data(), len);
        if (st != DKF_OK) {
            raise_status(st, call, -1, nullptr,
                         "a configuration outside the limits of dkf/selftune.h (na 1..4, np 0..4, "
                         "nc 0 or 1 below na, lags na + nc..32, L >= 1, a stable P, variances "
                         ">= 0, root_max in (0, 1], rho_max in (0, 0.5), sigma_w2_min > 0)");
        }
        L_ = L, lags_ = lags;
        (void)dkf_selftune_model_dim(&id_, &nx_);
    }
    SelfTuning(const SelfTuning &) = delete;
    SelfTuning &operator=(const SelfTuning &) = delete;

    void update(nb::handle y)
    {
        static const char *call = "SelfTuning.update";
        not_busy(call);
        Mat yv = vector_arg(y, call, "y", L_);
        dkf_status_t st = dkf_selftune_update(&id_, yv.p);
        if (st != DKF_OK) raise_update(st, call, -1, yv.p);
    }

    // Per row of Y (T, L): an update; the accepted a (T, na), c_1 (T,),
    // sigma_w^2 (T,) after each.
    nb::tuple filter(nb::handle Y)
    {
        static const char *call = "SelfTuning.filter";
        not_busy(call);
        InArray ya = as_array(Y, call, "Y");
        if (ya.ndim() != 2 || ya.shape(1) != L_) {
            value_error(call, "Y must be (T, " + std::to_string(L_) + "), got shape " +
                                  shape_str(ya));
        }
        const size_t T = ya.shape(0), na = id_.priv.na, as[2] = {T, na}, ss[1] = {T};
        OutArray A = new_array(2, as), C = new_array(1, ss), S = new_array(1, ss);
        real *ao = A.data(), *co = C.data(), *so = S.data();
        const real *yp = ya.data();
        Undo<dkf_selftune_t> undo(id_, storage_);
        dkf_status_t st = DKF_OK;
        size_t t = 0;
        busy_ = true;
        {
            nb::gil_scoped_release unlocked;
            for (t = 0; t < T; ++t) {
                st = dkf_selftune_update(&id_, yp + t * L_);
                if (st != DKF_OK) break;
                dkf_selftune_est_t e;
                (void)dkf_selftune_estimate(&id_, &e);
                std::copy(e.a, e.a + na, ao + t * na);
                co[t] = e.c1;
                so[t] = e.sigma_w2;
            }
            if (st != DKF_OK) undo.restore();
        }
        busy_ = false;
        if (st != DKF_OK) raise_update(st, call, static_cast<long>(t), yp + t * L_);
        return nb::make_tuple(A, C, S);
    }

    nb::dict estimate() const
    {
        not_busy("SelfTuning.estimate");
        dkf_selftune_est_t e;
        (void)dkf_selftune_estimate(&id_, &e);
        const size_t na[1] = {e.na};
        nb::dict d;
        d["a"] = copy_out(e.a, 1, na);
        d["c1"] = static_cast<double>(e.c1);
        d["sigma_w2"] = static_cast<double>(e.sigma_w2);
        d["ready"] = e.ready != 0;
        d["guard"] = static_cast<int>(e.guard);
        d["t"] = e.t;
        d["t_accepted"] = e.t_accepted;
        d["a_raw"] = copy_out(e.a_raw, 1, na);
        d["c1_raw"] = static_cast<double>(e.c1_raw);
        d["sigma_w2_raw"] = static_cast<double>(e.sigma_w2_raw);
        d["rho_raw"] = static_cast<double>(e.rho_raw);
        return d;
    }

    OutArray autocov(bool noise) const
    {
        not_busy(noise ? "SelfTuning.noise_autocov" : "SelfTuning.autocov");
        const size_t shape[1] = {lags_ + 1};
        OutArray r = new_array(1, shape);
        if (noise)
            (void)dkf_selftune_noise_autocov(&id_, r.data(), lags_ + 1);
        else
            (void)dkf_selftune_autocov(&id_, r.data(), lags_ + 1);
        return r;
    }

    // The observer-form (F, Q) of the accepted estimate.
    nb::tuple model() const
    {
        not_busy("SelfTuning.model");
        dkf_selftune_est_t e;
        (void)dkf_selftune_estimate(&id_, &e);
        const size_t shape[2] = {nx_, nx_};
        OutArray F = new_array(2, shape), Q = new_array(2, shape);
        dkf_mat_t Fm = view(nx_, nx_, F.data()), Qm = view(nx_, nx_, Q.data());
        (void)dkf_selftune_model(&id_, &e, &Fm, &Qm);
        return nb::make_tuple(F, Q);
    }
    size_t L() const { return L_; }
    size_t n() const { return nx_; }

private:
    [[noreturn]] void raise_update(dkf_status_t st, const char *call, long step,
                                   const real *y) const
    {
        const char *culprit = first_nonfinite({{"y", y, L_, false}});
        raise_status(st, call, step, culprit,
                     culprit ? "y not finite" : "the statistics overflowed");
    }

    size_t L_ = 0, lags_ = 0, nx_ = 0;
    std::vector<real> sv2_, p_, storage_;
    dkf_selftune_t id_;
};

// ---- dare, stein -------------------------------------------------------------------

OutArray dare(nb::handle F, nb::handle H, nb::handle Q, nb::handle R)
{
    static const char *call = "dare";
    Mat f = matrix_arg(F, call, "F", 0, 0, false);
    const size_t n = f.rows;
    if (f.cols != n) value_error(call, "F must be square, got shape " + shape_str(f.keep));
    Mat h = matrix_arg(H, call, "H", 0, n, false);
    Mat q = matrix_arg(Q, call, "Q", n, n, false), r = matrix_arg(R, call, "R", h.rows, h.rows, false);
    const size_t m = h.rows, shape[2] = {n, n};
    if (n > DKF_MAX_DIM || m > DKF_MAX_DIM) {
        raise_status(DKF_ERR_CAPACITY, call, -1, nullptr,
                     "n and m must be at most DKF_MAX_DIM = " + std::to_string(DKF_MAX_DIM));
    }
    OutArray X = new_array(2, shape);
    std::vector<real> work(DKF_MAT_DARE_WORK(n, m));
    dkf_mat_t Xm = view(n, n, X.data()), Fm = view(n, n, f.p), Hm = view(m, n, h.p),
              Qm = view(n, n, q.p), Rm = view(m, m, r.p);
    dkf_status_t st = dkf_mat_dare(&Xm, &Fm, &Hm, &Qm, &Rm, work.data());
    if (st != DKF_OK) {
        const char *culprit = nullptr;
        std::string detail;
        if (st == DKF_ERR_NONFINITE) {
            culprit = first_nonfinite({{"F", f.p, n * n, false}, {"H", h.p, m * n, false},
                                       {"Q", q.p, n * n, false}, {"R", r.p, m * m, false}});
            detail = nonfinite_detail(culprit);
        } else if (st == DKF_ERR_NOT_SPD) {
            detail = "R not SPD, or Q not symmetric PSD";
        } else if (st == DKF_ERR_UNSTABLE) {
            detail = "no stabilising solution: (F, H) not detectable, or a mode on the unit "
                     "circle that Q does not reach or H does not see";
        } else if (st == DKF_ERR_NO_CONVERGENCE) {
            detail = "no convergence within DKF_MAT_DOUBLING_MAX_ITER doublings";
        }
        raise_status(st, call, -1, culprit, detail);
    }
    return X;
}

OutArray stein(nb::handle A, nb::handle B, nb::handle C)
{
    static const char *call = "stein";
    Mat c = matrix_arg(C, call, "C", 0, 0, false);
    const size_t r = c.rows, k = c.cols, shape[2] = {r, k};
    Mat a = matrix_arg(A, call, "A", r, r, false), b = matrix_arg(B, call, "B", k, k, false);
    if (r > DKF_MAX_DIM || k > DKF_MAX_DIM) {
        raise_status(DKF_ERR_CAPACITY, call, -1, nullptr,
                     "C's dimensions must be at most DKF_MAX_DIM = " + std::to_string(DKF_MAX_DIM));
    }
    OutArray X = new_array(2, shape);
    std::vector<real> work(DKF_MAT_STEIN_WORK(r, k));
    dkf_mat_t Xm = view(r, k, X.data()), Am = view(r, r, a.p), Bm = view(k, k, b.p),
              Cm = view(r, k, c.p);
    dkf_status_t st = dkf_mat_stein(&Xm, &Am, &Bm, &Cm, work.data());
    if (st != DKF_OK) {
        const char *culprit = nullptr;
        std::string detail;
        if (st == DKF_ERR_NONFINITE) {
            culprit = first_nonfinite({{"A", a.p, r * r, false}, {"B", b.p, k * k, false},
                                       {"C", c.p, r * k, false}});
            detail = nonfinite_detail(culprit);
        } else if (st == DKF_ERR_UNSTABLE) {
            detail = "rho(A) rho(B) >= 1: the series does not contract";
        } else if (st == DKF_ERR_NO_CONVERGENCE) {
            detail = "no convergence within DKF_MAT_DOUBLING_MAX_ITER doublings";
        }
        raise_status(st, call, -1, culprit, detail);
    }
    return X;
}

} // namespace DKF_PY_NS

NB_MODULE(DKF_PY_MODULE, m)
{
    using namespace DKF_PY_NS;
    m.doc() = "dkf's filters over the core built in " DKF_PY_DTYPE " (docs/guide/python.md)";
    m.attr("dtype") = DKF_PY_DTYPE;
    m.attr("MAX_DIM") = DKF_MAX_DIM;
    m.attr("JOSEPH") = DKF_JOSEPH;
    // What dkf and dkf.float32 export of this module.
    m.attr("__all__") = nb::make_tuple("KalmanFilter", "InformationFilter", "info_contribution",
                                       "DifferenceKF", "DiffKFFusionCentre", "ASKF", "OTSKF", "UIF",
                                       "WeightedFusion", "SelfTuning", "dare", "stein", "TWCentral",
                                       "TWNetwork", "graph_weights_uniform",
                                       "graph_weights_metropolis", "graph_weights_max_degree",
                                       "NLModel", "NERTS", "DFNERTS", "DFNERTSNode", "dtype",
                                       "MAX_DIM");
    m.def("_status_str", [](int st) { return dkf_status_str(static_cast<dkf_status_t>(st)); });
    register_tw(m);
    register_nerts(m);
    register_dfnerts_node(m);
    register_nlm_builtin(m);

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

    m.def("info_contribution", &info_contribution, nb::arg("z"), nb::arg("H"), nb::arg("R"),
          "A sensor's information contribution (i, I) = (H^T R^-1 z, H^T R^-1 H) "
          "(dkf_info_contribution); NaN components of z are missing.");

    nb::class_<InformationFilter>(m, "InformationFilter",
                                  "Linear information filter with exact multi-sensor fusion "
                                  "(dkf/info.h).")
        .def(nb::init<nb::handle, nb::handle, nb::handle, nb::handle>(), nb::arg("F"),
             nb::arg("Q"), nb::arg("x0"), nb::arg("P0"))
        .def("predict", &InformationFilter::predict, nb::arg("F") = nb::none(),
             nb::arg("Q") = nb::none(), "Time update P = F P F^T + Q, x = F x; Y = P^-1, y = Y x.")
        .def("update", &InformationFilter::update, nb::arg("z"), nb::arg("H"), nb::arg("R"),
             "One sensor's measurement: its contribution, fused.")
        .def("fuse", &InformationFilter::fuse, nb::arg("i"), nb::arg("I"),
             "Y += sum I[j], y += sum i[j]; then P = Y^-1, x = P y.")
        .def("filter", &InformationFilter::filter, nb::arg("Z"), nb::arg("H"), nb::arg("R"),
             nb::kw_only(), nb::arg("F") = nb::none(), nb::arg("Q") = nb::none(),
             "Per step t: a predict, each sensor's contribution from Z[j][t], one fuse; in one "
             "call without the GIL. Returns (X (T, n), P (T, n, n)).")
        .def_prop_ro("x", &InformationFilter::x, nb::rv_policy::take_ownership,
                     "The state estimate (n,), a copy.")
        .def_prop_ro("P", &InformationFilter::P, nb::rv_policy::take_ownership,
                     "Its error covariance (n, n), a copy.")
        .def_prop_ro("y", &InformationFilter::y, nb::rv_policy::take_ownership,
                     "The information vector Y x (n,), a copy.")
        .def_prop_ro("Y", &InformationFilter::Y, nb::rv_policy::take_ownership,
                     "The information matrix P^-1 (n, n), a copy.")
        .def_prop_ro("n", &InformationFilter::n)
        .def("__repr__", [](const InformationFilter &f) {
            return "<dkf InformationFilter n=" + std::to_string(f.n()) + " " DKF_PY_DTYPE ">";
        });

    using D = DifferenceKF;
    nb::class_<DifferenceKF> dkf_cls(m, "DifferenceKF",
                             "The Difference Kalman filter with unknown inputs (dkf/diffkf.h).");
    dkf_cls.def(nb::init<nb::handle, nb::handle, size_t, size_t>(), nb::arg("x0"), nb::arg("P0"),
             nb::kw_only(), nb::arg("m"), nb::arg("p"))
        .def("start", &D::start, nb::arg("y1"), nb::arg("H"), nb::arg("D"), nb::arg("R"),
             nb::kw_only(), nb::arg("F0") = nb::none(), nb::arg("Q0") = nb::none(),
             "Predicts x_{1|0} with F0, Q0 (or takes x0, P0 as that prior without them) and "
             "takes y_1 with its model.")
        .def("step", &D::step, nb::arg("y_next"), nb::kw_only(), nb::arg("F"), nb::arg("Q"),
             nb::arg("B"), nb::arg("Rd"), nb::arg("H"), nb::arg("D"), nb::arg("R"),
             "One step with y_{k+1}: the dynamics at k (F, Q, B, Rd), the model at k+1 "
             "(H, D, R); gives x_{k|k} and x_{k+1|k}.")
        .def("filter", &D::filter, nb::arg("Y"), nb::kw_only(), nb::arg("F"), nb::arg("Q"),
             nb::arg("B"), nb::arg("Rd"), nb::arg("H"), nb::arg("D"), nb::arg("R"),
             nb::arg("prior") = false,
             "start() with Y[0] = y_1, then a step per further row, in one call without the GIL; "
             "returns (XF, PF, XN, PN) for k = 1..T-1.")
        .def_prop_ro("k", &D::k, "The time of xf.")
        .def_prop_ro("started", &D::started)
        .def_prop_ro("n", &D::n)
        .def_prop_ro("m", &D::m)
        .def_prop_ro("p", &D::p)
        .def("__repr__", [](const D &f) {
            return "<dkf DifferenceKF n=" + std::to_string(f.n()) + " m=" + std::to_string(f.m()) +
                   " p=" + std::to_string(f.p()) + " k=" + std::to_string(f.k()) +
                   " " DKF_PY_DTYPE ">";
        });
    // The estimates and the last step's quantities, as copies.
    static const struct {
        const char *name;
        dkf_mat_t dkf_diffkf_t::*mat;
        const char *doc;
    } dkf_fields[] = {
        {"xf", &dkf_diffkf_t::xf, "x_{k|k} (n,), a copy."},
        {"Pf", &dkf_diffkf_t::Pf, "P_{k|k} (n, n), a copy."},
        {"xn", &dkf_diffkf_t::xn, "x_{k+1|k} (n,), a copy."},
        {"Pn", &dkf_diffkf_t::Pn, "P_{k+1|k} (n, n), a copy."},
        {"xp", &dkf_diffkf_t::xp, "x_{k|k-1} (n,), a copy."},
        {"z", &dkf_diffkf_t::z, "The last step's z_k (p,)."},
        {"dz", &dkf_diffkf_t::dz, "Its innovation (p,)."},
        {"J", &dkf_diffkf_t::J, "J_k (n, p)."},
        {"L", &dkf_diffkf_t::L, "L_k (p, p)."},
        {"K", &dkf_diffkf_t::K, "K_k (n, p)."},
    };
    for (const auto &fd : dkf_fields) {
        const auto mat = fd.mat;
        const std::string call = std::string("DifferenceKF.") + fd.name;
        dkf_cls.def_prop_ro(
            fd.name, [mat, call](const D &f) { return f.get(f.state().*mat, call.c_str()); },
            nb::rv_policy::take_ownership, fd.doc);
    }

    dkf_cls.def("message", &D::message,
                "The node message (k, x_{k|k}, x_{k|k-1}) for DiffKFFusionCentre.step.")
        .def("set_steady", &D::set_steady, nb::arg("tol"),
             "The steady gain of a time-invariant model: tol in [0, 1), 0 off.")
        .def("set_time", &D::set_time, nb::arg("k"),
             "Sets the time k of xf (a filter restarted at k_start: set_time(k_start - 1)).")
        .def("save", &D::save, nb::rv_policy::take_ownership,
             "A checkpoint of the filter, a new 1-D array of the module's dtype.")
        .def("restore", &D::restore, nb::arg("buf"),
             "Back to the checkpoint buf (save()'s); a refused buffer changes nothing.")
        .def_prop_ro("steady", &D::steady, "The last step reused the settled gain.");

    using C = DiffKFFusionCentre;
    nb::class_<C> fc_cls(m, "DiffKFFusionCentre",
                         "The fusion centre of the distributed Difference KF "
                         "(dkf/diffkf_fusion.h): the centralized estimate from the nodes' "
                         "messages.");
    fc_cls.def(nb::init<nb::handle, nb::handle, std::vector<size_t>, std::vector<size_t>,
                        nb::handle>(),
               nb::arg("x0"), nb::arg("P0"), nb::kw_only(), nb::arg("m"), nb::arg("p"),
               nb::arg("P0_local") = nb::none())
        .def("start", &C::start, nb::arg("F0"), nb::arg("Q0"), nb::arg("sensors"),
             "As every node's start: F0, Q0 and each sensor's B, H, D, R at time 1.")
        .def("step", &C::step, nb::arg("F"), nb::arg("Q"), nb::arg("sensors"),
             nb::arg("messages"),
             "Step k = self.k + 1: F_k, Q_k, each sensor's B, Rd (at k) and H, D, R (at k+1), "
             "and each node's message of step k.")
        .def("step_partial", &C::step_partial, nb::arg("F"), nb::arg("Q"), nb::arg("sensors"),
             nb::arg("messages"),
             "As step() with messages[i] None for a node whose message is missing: the masked "
             "central gain. Returns contributed, per node whether its z entered the estimate.")
        .def("restart_node", &C::restart_node, nb::arg("node"), nb::arg("k_start"),
             nb::arg("P_prior"), nb::arg("sensor"),
             "Node `node` restarted its filter at k_start = self.k + 1 from the prior covariance "
             "P_prior, with its H, D, R at k_start (sensor, a dict).")
        .def("set_steady", &C::set_steady, nb::arg("tol"),
             "The steady gain for the central filter and every replica: tol in [0, 1), 0 off.")
        .def("save", &C::save, nb::rv_policy::take_ownership,
             "A checkpoint of the whole centre, a new 1-D array of the module's dtype.")
        .def("restore", &C::restore, nb::arg("buf"),
             "Back to the checkpoint buf (save()'s); a refused buffer changes nothing.")
        .def_prop_ro("synced", &C::synced,
                     "Per node: its replica is in sync, so its next message is recovered.")
        .def_prop_ro("steady", &C::steady, "The last step reused the settled gain.")
        .def("recovered", &C::recovered, nb::arg("node"),
             "(z, dz) of the node recovered in the last step.")
        .def_prop_ro("k", &C::k, "The time of xf (0 before the first step).")
        .def_prop_ro("n", &C::n)
        .def_prop_ro("l", &C::l)
        .def_prop_ro("m", &C::m)
        .def_prop_ro("p", &C::p)
        .def("__repr__", [](const C &c) {
            return "<dkf DiffKFFusionCentre n=" + std::to_string(c.n()) + " l=" +
                   std::to_string(c.l()) + " k=" + std::to_string(c.k()) + " " DKF_PY_DTYPE ">";
        });
    for (const auto &fd : dkf_fields) {
        const auto mat = fd.mat;
        const std::string call = std::string("DiffKFFusionCentre.") + fd.name;
        fc_cls.def_prop_ro(
            fd.name, [mat, call](const C &c) { return c.get(c.central().*mat, call.c_str()); },
            nb::rv_policy::take_ownership, fd.doc);
    }

    // ASKF and OTSKF: the same calls; their own constructors and fields.
    auto bind_uikf = [&m](auto *tag, const char *name, const char *doc) {
        using K = std::remove_pointer_t<decltype(tag)>;
        nb::class_<K> cls(m, name, doc);
        cls.def("predict", &K::predict, nb::arg("F"), nb::arg("Q"), nb::arg("B"), nb::arg("Rd"),
                "Time update with the dynamics at k - 1: x = F x, d = B d; Q, Rd their noises.")
            .def("update", &K::update, nb::arg("y"), nb::arg("H"), nb::arg("D"), nb::arg("R"),
                 "Measurement update with y_k = H x + D d + v, R = cov(v); an all-NaN y is no "
                 "update.")
            .def("filter", &K::filter, nb::arg("Y"), nb::kw_only(), nb::arg("F"), nb::arg("Q"),
                 nb::arg("B"), nb::arg("Rd"), nb::arg("H"), nb::arg("D"), nb::arg("R"),
                 "Per row t of Y (T, m): a predict with the dynamics at t and an update with "
                 "y_{t+1} = Y[t] and the model at t + 1 (a stack has T + 1 entries, times 0..T), "
                 "in one call without the GIL; returns (X (T, n), P (T, n, n), D (T, p), "
                 "Pd (T, p, p)).")
            .def_prop_ro("n", &K::n)
            .def_prop_ro("m", &K::m)
            .def_prop_ro("p", &K::p)
            .def("__repr__", [name](const K &f) {
                return std::string("<dkf ") + name + " n=" + std::to_string(f.n()) +
                       " m=" + std::to_string(f.m()) + " p=" + std::to_string(f.p()) +
                       " " DKF_PY_DTYPE ">";
            });
        static const char *const est_names[4] = {"x", "P", "d", "Pd"};
        static const char *const est_docs[4] = {
            "The state estimate x (n,), a copy.", "Its error covariance (n, n), a copy.",
            "The input estimate d (p,), a copy.", "Its error covariance (p, p), a copy."};
        for (size_t i = 0; i < 4; ++i) {
            const std::string call = std::string(name) + "." + est_names[i];
            cls.def_prop_ro(
                est_names[i],
                [i, call](const K &f) { return nb::object(f.estimate(call.c_str())[i]); },
                est_docs[i]);
        }
        return cls;
    };

    auto askf = bind_uikf(static_cast<ASKF *>(nullptr), "ASKF",
                          "The augmented-state Kalman filter on [x; d] (dkf/askf.h).");
    askf.def(nb::init<nb::handle, nb::handle, nb::handle, nb::handle, size_t, nb::handle>(),
             nb::arg("x0"), nb::arg("P0"), nb::arg("d0"), nb::arg("Pd0"), nb::kw_only(),
             nb::arg("m"), nb::arg("Pxd0") = nb::none())
        .def_prop_ro(
            "X", [](const ASKF &f) { return f.field(f.state().kf.x, "ASKF.X", true); },
            nb::rv_policy::take_ownership, "The augmented estimate [x; d] (n + p,), a copy.")
        .def_prop_ro(
            "PX", [](const ASKF &f) { return f.field(f.state().kf.P, "ASKF.PX", false); },
            nb::rv_policy::take_ownership, "Its covariance P^a (n + p, n + p), a copy.");

    auto otskf = bind_uikf(static_cast<OTSKF *>(nullptr), "OTSKF",
                           "The optimal two-stage Kalman filter (dkf/otskf.h).");
    otskf.def(
        "__init__",
        [](OTSKF *self, nb::handle x0, nb::handle P0, nb::handle d0, nb::handle Pd0, size_t mm) {
            new (self) OTSKF(x0, P0, d0, Pd0, mm, nb::none());
        },
        nb::arg("x0"), nb::arg("P0"), nb::arg("d0"), nb::arg("Pd0"), nb::kw_only(), nb::arg("m"));
    static const Field<dkf_otskf_t> otskf_fields[] = {
        {"xt", &dkf_otskf_t::xt, true, "The bias-free estimate x~ (n,), a copy."},
        {"Px", &dkf_otskf_t::Px, false, "Its covariance P^x (n, n), a copy."},
        {"U", &dkf_otskf_t::U, false, "The blending matrix U_k of the last predict (n, p)."},
        {"V", &dkf_otskf_t::V, false, "The blending matrix V_k of the last update (n, p)."},
    };
    def_fields(otskf, "OTSKF", otskf_fields);

    nb::class_<UIF> uif(m, "UIF",
                        "Joint state and unknown-input filters of dkf/uif.h: RTSF, NRTSF_DF, "
                        "NRTSF (kind).");
    uif.def(nb::init<nb::handle, nb::handle, size_t, size_t, const std::string &>(),
            nb::arg("x0"), nb::arg("P0"), nb::kw_only(), nb::arg("m"), nb::arg("p"),
            nb::arg("kind"))
        .def("step", &UIF::step, nb::arg("y"), nb::kw_only(), nb::arg("H"), nb::arg("R"),
             nb::arg("D") = nb::none(), nb::arg("F") = nb::none(), nb::arg("G") = nb::none(),
             nb::arg("Q") = nb::none(),
             "One step with y_k and the model at k (H, D, R), and the dynamics from k - 1 "
             "(F, G, Q), which an RTSF or NRTSF_DF filter's first step does not take.")
        .def("filter", &UIF::filter, nb::arg("Y"), nb::kw_only(), nb::arg("F"), nb::arg("G"),
             nb::arg("Q"), nb::arg("H"), nb::arg("R"), nb::arg("D") = nb::none(),
             "The steps of times 0..T-1 (NRTSF: 1..T-1), y_t = Y[t], a stack indexed by the "
             "time (T entries), in one call without the GIL; returns (X, Px, D, Pd), one row "
             "per step.")
        .def_prop_ro("estimable", &UIF::estimable,
                     "Per input component: 2 estimated, 1 only in a combination, 0 not at all.")
        .def_prop_ro("rank", [](const UIF &f) { return f.state().rank; })
        .def_prop_ro("bias_risk", [](const UIF &f) { return f.state().bias_risk != 0; })
        .def_prop_ro("bias_steps", [](const UIF &f) { return f.state().bias_steps; })
        .def_prop_ro("k", [](const UIF &f) { return f.state().k; }, "Steps taken.")
        .def_prop_ro("kind", &UIF::kind)
        .def_prop_ro("n", &UIF::n)
        .def_prop_ro("m", &UIF::m)
        .def_prop_ro("p", &UIF::p)
        .def("__repr__", [](const UIF &f) {
            return "<dkf UIF " + f.kind() + " n=" + std::to_string(f.n()) + " m=" +
                   std::to_string(f.m()) + " p=" + std::to_string(f.p()) + " k=" +
                   std::to_string(f.state().k) + " " DKF_PY_DTYPE ">";
        });
    static const Field<dkf_uif_t> uif_fields[] = {
        {"x", &dkf_uif_t::x, true, "x_{k|k} (n,), a copy."},
        {"Px", &dkf_uif_t::Px, false, "Its error covariance (n, n), a copy."},
        {"d", &dkf_uif_t::d, true, "d_{k|k} (NRTSF: d_{k-1|k}) (p,), a copy."},
        {"Pd", &dkf_uif_t::Pd, false, "The covariance of d - proj d (p, p), a copy."},
        {"Pxd", &dkf_uif_t::Pxd, false, "The cross covariance of the errors of x and d (n, p)."},
        {"x_pred", &dkf_uif_t::x_pred, true, "x_{k|k-1} of the last step (n,)."},
        {"P_pred", &dkf_uif_t::P_pred, false, "P_{k|k-1} of the last step (n, n)."},
        {"Rtilde", &dkf_uif_t::Rtilde, false, "R~ = H P_{k|k-1} H^T + R (m, m)."},
        {"K", &dkf_uif_t::K, false, "P_{k|k-1} H^T R~^-1 (n, m)."},
        {"L", &dkf_uif_t::L, false, "The state gain (n, m)."},
        {"M", &dkf_uif_t::M, false, "The input gain (p, m)."},
        {"proj", &dkf_uif_t::proj, false, "The projector onto the estimable inputs (p, p)."},
    };
    def_fields(uif, "UIF", uif_fields);

    using W = WeightedFusion;
    nb::class_<W> wf(m, "WeightedFusion",
                     "Weighted fusion of local Kalman filters with their cross covariances "
                     "(dkf/wfusion.h).");
    wf.def(nb::init<nb::handle, nb::handle, nb::handle, std::vector<size_t>>(), nb::arg("x0"),
           nb::arg("P0"), nb::arg("Hs"), nb::kw_only(), nb::arg("m"))
        .def("step", &W::step, nb::arg("F"), nb::arg("Q"), nb::arg("H"), nb::arg("R"),
             nb::arg("y") = nb::none(),
             "Every local filter's step with the model F, Q and H[i], R[i] and y[i] (y None: the "
             "gains alone), then the cross covariances.")
        .def("steady", &W::steady, nb::arg("F"), nb::arg("Q"), nb::arg("H"), nb::arg("R"),
             "Switches every local filter and the cross covariances to the steady state.")
        .def("fuse_scalar", &W::fuse_scalar, nb::arg("x") = nb::none(),
             "Scalar-weight fusion of the signal Hs x over the sensors present (x[i] not None; "
             "x None: every local estimate); returns (s0, PS0).")
        .def("fuse_matrix", &W::fuse_matrix, nb::arg("x") = nb::none(),
             "Matrix-weight fusion of x over the same choice of sensors; returns (xf, Pf).")
        .def("filter", &W::filter, nb::arg("Y"), nb::kw_only(), nb::arg("F"), nb::arg("Q"),
             nb::arg("H"), nb::arg("R"),
             "Per step t: step() with Y[i][t], fuse_scalar(), fuse_matrix(), in one call without "
             "the GIL; returns (XF (T, n), PF (T, n, n), S0 (T,), PS0 (T,)).")
        .def_prop_ro("K", &W::gains, "Each local gain K_i (n, m_i) of the last step, a list.")
        .def_prop_ro("s0", [](const W &w) { return static_cast<double>(w.state().s0); })
        .def_prop_ro("PS0", [](const W &w) { return static_cast<double>(w.state().PS0); })
        .def_prop_ro("w_unique", [](const W &w) { return w.state().w_unique != 0; })
        .def_prop_ro("A_unique", [](const W &w) { return w.state().A_unique != 0; })
        .def_prop_ro("used", [](const W &w) { return w.state().used; })
        .def_prop_ro("t", [](const W &w) { return static_cast<size_t>(w.state().t); })
        .def_prop_ro("steady_state", [](const W &w) { return w.state().steady != 0; })
        .def_prop_ro("n", &W::n)
        .def_prop_ro("l", &W::l)
        .def_prop_ro("m", &W::m)
        .def("__repr__", [](const W &w) {
            return "<dkf WeightedFusion n=" + std::to_string(w.n()) + " l=" +
                   std::to_string(w.l()) + " t=" + std::to_string(w.state().t) +
                   " " DKF_PY_DTYPE ">";
        });
    static const Field<dkf_wfusion_t> wf_fields[] = {
        {"Pj", &dkf_wfusion_t::Pj, false, "The joint covariance (P_ij) (n l, n l), a copy."},
        {"Hs", &dkf_wfusion_t::Hs, false, "The signal row (1, n)."},
        {"PS", &dkf_wfusion_t::PS, false, "(Hs P_ij Hs^T) of the last scalar fusion (l, l)."},
        {"w", &dkf_wfusion_t::w, true, "The scalar weights (l,) (0 for an absent sensor)."},
        {"A", &dkf_wfusion_t::A, false, "The matrix weights [A_1 ... A_l] (n, n l)."},
        {"xf", &dkf_wfusion_t::xf, true, "The matrix-fused estimate (n,)."},
        {"Pf", &dkf_wfusion_t::Pf, false, "Its error covariance (n, n)."},
    };
    def_fields(wf, "WeightedFusion", wf_fields);
    static const struct {
        const char *name;
        dkf_mat_t dkf_wfusion_local_t::*mat;
        bool vector;
        const char *doc;
    } wf_locals[] = {
        {"x_local", &dkf_wfusion_local_t::x, true, "Each x_i(t|t), stacked (l, n)."},
        {"P_local", &dkf_wfusion_local_t::P, false, "Each P_i(t|t), stacked (l, n, n)."},
        {"Sigma_pred", &dkf_wfusion_local_t::Sp, false, "Each Sigma_i(t|t-1) (l, n, n)."},
        {"Psi", &dkf_wfusion_local_t::Psi, false, "Each Psi_i = (I - K_i H_i) F (l, n, n)."},
        {"J", &dkf_wfusion_local_t::J, false, "Each J_i = I - K_i H_i (l, n, n)."},
    };
    for (const auto &fd : wf_locals) {
        const auto mat = fd.mat;
        const bool vec = fd.vector;
        const std::string call = std::string("WeightedFusion.") + fd.name;
        wf.def_prop_ro(
            fd.name, [mat, vec, call](const W &w) { return w.locals(mat, vec, call.c_str()); },
            nb::rv_policy::take_ownership, fd.doc);
    }

    nb::class_<SelfTuning>(m, "SelfTuning",
                           "Self-tuning identifier of seed 002's signal model (dkf/selftune.h).")
        .def(nb::init<size_t, nb::handle, nb::handle, double, size_t, size_t, size_t, size_t,
                      double, double, double, nb::handle, double, double>(),
             nb::kw_only(), nb::arg("L"), nb::arg("sigma_v2"), nb::arg("p") = nb::none(),
             nb::arg("sigma_xi2") = 0.0, nb::arg("na") = 2, nb::arg("nc") = 1,
             nb::arg("lags") = 5, nb::arg("t_min") = 50, nb::arg("root_max") = 0.99,
             nb::arg("rho_max") = 0.499, nb::arg("sigma_w2_min") = 1e-3,
             nb::arg("a0") = nb::none(), nb::arg("c0") = 0.0, nb::arg("sigma_w2_0") = 1.0)
        .def("update", &SelfTuning::update, nb::arg("y"),
             "One time step with the L measurements y (L,).")
        .def("filter", &SelfTuning::filter, nb::arg("Y"),
             "An update per row of Y (T, L) in one call without the GIL; returns the accepted "
             "(a (T, na), c1 (T,), sigma_w2 (T,)) after each.")
        .def("estimate", &SelfTuning::estimate,
             "The accepted estimate, the last step's guard and its raw estimate, a dict.")
        .def("autocov", [](const SelfTuning &s) { return s.autocov(false); },
             nb::rv_policy::take_ownership, "r_ybar(0..K) of the steps fed so far.")
        .def("noise_autocov", [](const SelfTuning &s) { return s.autocov(true); },
             nb::rv_policy::take_ownership, "r_eta(0..K), computed at construction.")
        .def("model", &SelfTuning::model,
             "The observer-form (F, Q) of the accepted estimate, n = na + max(np, 1).")
        .def_prop_ro("L", &SelfTuning::L)
        .def_prop_ro("n", &SelfTuning::n);

    m.def("dare", &dare, nb::arg("F"), nb::arg("H"), nb::arg("Q"), nb::arg("R"),
          nb::rv_policy::take_ownership,
          "The stabilising solution X of the filtering DARE X = F X F^T - F X H^T (H X H^T + "
          "R)^-1 H X F^T + Q (dkf_mat_dare): the steady predictor covariance.");
    m.def("stein", &stein, nb::arg("A"), nb::arg("B"), nb::arg("C"),
          nb::rv_policy::take_ownership,
          "The solution X of the Stein equation X = A X B^T + C (dkf_mat_stein).");
}
