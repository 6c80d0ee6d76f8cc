// python/src/nlm_builtin.cpp - dkf-run's built-in nonlinear model families
// (ports/linux/nlm/nlm_family.c: lin_x_sin_d, s1_radar, s1_radar_stacked,
// s1_ckf) as native models: the very C functions and the very callbacks
// (ports/linux/nlm/nlm_model.c: dkf_real_t <-> double, every value checked
// for finiteness) that dkf-run's models run, compiled into this module.
// _NlmFamily owns the C model (dkf_nlm_t and its parameters);
// dkf.builtin_model (python/dkf/_nlm.py) checks the parameters and makes
// NLModel.native over its function addresses, the model keeping it alive.
// docs/guide/python.md, "run_scenario"; docs/decisions.md item 75.
#include <nanobind/stl/string.h>
#include <nanobind/stl/vector.h>

#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "common.h"
#include "dkf/nerts.h"

extern "C" {
#include "nlm_model.h"
}

namespace DKF_PY_NS {

namespace {

// Copies v (count doubles) into a malloc'ed array (freed by the family's
// destroy); nullptr for an empty one.
double *dup(const std::vector<double> &v, size_t count, const char *name)
{
    if (v.size() != count)
        value_error("_NlmFamily", std::string(name) + ": expected " + std::to_string(count) +
                                       " values, got " + std::to_string(v.size()));
    if (!count) return nullptr;
    double *p = static_cast<double *>(std::malloc(count * sizeof(double)));
    if (!p) throw std::bad_alloc();
    std::memcpy(p, v.data(), count * sizeof(double));
    return p;
}

class NlmFamily {
public:
    // family: a built-in name; n, p the case's sizes; m the measurement
    // size (lin_x_sin_d: C's rows; s1_*: ignored, 2 or 3 per sensor). The
    // matrices row-major and flat; sensor_xy 2 L values. angles: None keeps
    // the family's (the bearings), a list replaces them.
    NlmFamily(const std::string &family, size_t n, size_t m, size_t p,
              const std::vector<double> &A, const std::vector<double> &b,
              const std::vector<double> &C, const std::vector<double> &H, double T,
              double phi_gain, double omega_fixed, const std::vector<double> &sensor_xy,
              nb::object angles, const std::string &path)
    {
        static const char *call = "_NlmFamily";
        const int idx = dkf_nlm_family_index(family.c_str());
        if (idx < 0)
            value_error(call, "unknown family '" + family + "' (built-in: " +
                                  dkf_nlm_builtin_names() + ")");
        if (n == 0 || n > DKF_MAX_DIM || p > DKF_MAX_DIM || m > DKF_MAX_DIM)
            value_error(call, "n, m, p out of range");
        m_ = static_cast<dkf_nlm_t *>(std::calloc(1, sizeof *m_));
        if (!m_) throw std::bad_alloc();
        m_->path = static_cast<char *>(std::malloc(path.size() + 1));
        auto *fam = static_cast<dkf_nlm_family_t *>(std::calloc(1, sizeof(dkf_nlm_family_t)));
        m_->impl = fam;
        m_->ops = &dkf_nlm_lin_ops; // its destroy frees fam
        if (!m_->path || !fam) {
            dkf_nlm_free(m_);
            throw std::bad_alloc();
        }
        std::memcpy(m_->path, path.c_str(), path.size() + 1);
        std::snprintf(m_->source, sizeof m_->source, "%.31s", family.c_str());
        m_->n = n, m_->p = p;
        try {
            if (idx == 0) {
                if (!p || !m) value_error(call, "lin_x_sin_d needs p >= 1 and m >= 1");
                fam->A = dup(A, n * n, "A");
                fam->B = dup(b, n * p, "b");
                fam->C = dup(C, m * n, "C");
                fam->H = dup(H, m * p, "H");
                m_->m = m;
            } else {
                const bool stacked = idx == 2, ckf = idx == 3;
                const size_t L = sensor_xy.size() / 2;
                if (n != 4 || p != (ckf ? 0u : 1u))
                    value_error(call, family + " has n = 4 and p = " + (ckf ? "0" : "1"));
                if (sensor_xy.size() % 2 || !L || (!stacked && L != 1) ||
                    L > DKF_NLM_MAX_SENSORS || 3 * L > DKF_MAX_DIM)
                    value_error(call, "sensor_xy: one [x, y] (or L <= " +
                                          std::to_string(DKF_MAX_DIM / 3) +
                                          " of them, s1_radar_stacked)");
                fam->T = T, fam->gain = phi_gain, fam->omega = omega_fixed;
                fam->L = L;
                std::memcpy(fam->sxy, sensor_xy.data(), 2 * L * sizeof(double));
                fam->per = ckf ? 2 : 3;
                dkf_nlm_s1_layout(m_, fam);
                R_default_.assign(m_->m * m_->m, 0.0);
                dkf_nlm_s1_default_R(R_default_.data(), m_->m, fam);
            }
            if (!angles.is_none()) {
                std::memset(m_->angle, 0, sizeof m_->angle);
                m_->nangles = 0;
                for (size_t a : nb::cast<std::vector<size_t>>(angles)) {
                    if (a >= m_->m || m_->angle[a])
                        value_error(call, "angles: index " + std::to_string(a) +
                                              " out of range or listed twice");
                    m_->angle[a] = 1;
                    m_->nangles++;
                }
            }
        } catch (...) {
            dkf_nlm_free(m_);
            m_ = nullptr;
            throw;
        }
        if (dkf_nlm_finish(m_) != 0) {
            dkf_nlm_free(m_);
            m_ = nullptr;
            throw std::bad_alloc();
        }
    }
    ~NlmFamily() { dkf_nlm_free(m_); }
    NlmFamily(const NlmFamily &) = delete;
    NlmFamily &operator=(const NlmFamily &) = delete;

    size_t m() const { return m_->m; }
    std::vector<size_t> angles() const
    {
        std::vector<size_t> out;
        for (size_t i = 0; i < m_->m; ++i)
            if (m_->angle[i]) out.push_back(i);
        return out;
    }
    const std::vector<double> &R_default() const { return R_default_; }
    // f at (x, d) given in the core's reals (as doubles), through the
    // table: the values in the core's reals (nerts_run.c's same_dynamics).
    std::vector<double> eval_f(const std::vector<double> &x, const std::vector<double> &d) const
    {
        if (x.size() != m_->n || d.size() != m_->p)
            value_error("_NlmFamily.eval_f", "x of n, d of p values");
        real xr[DKF_MAX_DIM], dr[DKF_MAX_DIM], out[DKF_MAX_DIM];
        for (size_t i = 0; i < m_->n; ++i) xr[i] = static_cast<real>(x[i]);
        for (size_t i = 0; i < m_->p; ++i) dr[i] = static_cast<real>(d[i]);
        if (m_->model.f(m_->model.ctx, 0, xr, dr, nullptr, out) != 0)
            throw nb::value_error(dkf_nlm_failure(m_));
        return std::vector<double>(out, out + m_->n);
    }
    const dkf_nl_model_t &table() const { return m_->model; }
    std::string failure() const { return dkf_nlm_failure(m_); }
    static uintptr_t addr(void *p) { return reinterpret_cast<uintptr_t>(p); }
    uintptr_t ctx() const { return addr(m_); }
    uintptr_t f() const { return addr(reinterpret_cast<void *>(m_->model.f)); }
    uintptr_t h() const { return addr(reinterpret_cast<void *>(m_->model.h)); }
    uintptr_t f_jac() const { return addr(reinterpret_cast<void *>(m_->model.f_jac)); }
    uintptr_t h_jac() const { return addr(reinterpret_cast<void *>(m_->model.h_jac)); }

private:
    dkf_nlm_t *m_ = nullptr;
    std::vector<double> R_default_; // s1_*: seed 001's blkdiag (the stacked family's default)
};

// nerts_run.c's stacked model of a network case (cf_dnertsf): the core's
// dkf_nerts_stack over the nodes' C models, which it keeps alive.
class NlmStack {
public:
    explicit NlmStack(nb::list families)
    {
        for (nb::handle h : families) {
            owners_.push_back(nb::borrow(h));
            tables_.push_back(nb::cast<const NlmFamily &>(h).table());
        }
        std::memset(&model_, 0, sizeof model_);
        const dkf_status_t st = dkf_nerts_stack(&model_, &stack_, tables_.data(), tables_.size());
        if (st != DKF_OK) raise_status(st, "_NlmStack", -1, nullptr, "the nodes' n, p or m");
    }
    NlmStack(const NlmStack &) = delete;
    NlmStack &operator=(const NlmStack &) = delete;
    static uintptr_t addr(void *p) { return reinterpret_cast<uintptr_t>(p); }
    uintptr_t ctx() const { return addr(model_.ctx); }
    uintptr_t f() const { return addr(reinterpret_cast<void *>(model_.f)); }
    uintptr_t h() const { return addr(reinterpret_cast<void *>(model_.h)); }
    uintptr_t f_jac() const { return addr(reinterpret_cast<void *>(model_.f_jac)); }
    uintptr_t h_jac() const { return addr(reinterpret_cast<void *>(model_.h_jac)); }

private:
    std::vector<nb::object> owners_;
    std::vector<dkf_nl_model_t> tables_;
    dkf_nerts_stack_t stack_;
    dkf_nl_model_t model_;
};

} // namespace

void register_nlm_builtin(nb::module_ &m)
{
    nb::class_<NlmFamily>(m, "_NlmFamily",
                          "A built-in model family's C model (dkf-run's nlm_family.c); "
                          "dkf.builtin_model wraps it in NLModel.native.")
        .def(nb::init<const std::string &, size_t, size_t, size_t, const std::vector<double> &,
                      const std::vector<double> &, const std::vector<double> &,
                      const std::vector<double> &, double, double, double,
                      const std::vector<double> &, nb::object, const std::string &>(),
             nb::arg("family"), nb::kw_only(), nb::arg("n"), nb::arg("m"), nb::arg("p"),
             nb::arg("A"), nb::arg("b"), nb::arg("C"), nb::arg("H"), nb::arg("T"),
             nb::arg("phi_gain"), nb::arg("omega_fixed"), nb::arg("sensor_xy"),
             nb::arg("angles").none(), nb::arg("path"))
        .def_prop_ro("m", &NlmFamily::m)
        .def_prop_ro("angles", &NlmFamily::angles)
        .def_prop_ro("R_default", &NlmFamily::R_default)
        .def_prop_ro("failure", &NlmFamily::failure, "The last callback's failure, \"\" if none.")
        .def_prop_ro("ctx", &NlmFamily::ctx)
        .def_prop_ro("f", &NlmFamily::f)
        .def_prop_ro("h", &NlmFamily::h)
        .def_prop_ro("f_jac", &NlmFamily::f_jac)
        .def_prop_ro("h_jac", &NlmFamily::h_jac)
        .def("eval_f", &NlmFamily::eval_f, nb::arg("x"), nb::arg("d"));
    nb::class_<NlmStack>(m, "_NlmStack",
                         "The nodes' built-in C models stacked (dkf_nerts_stack), for "
                         "run_scenario's cf_dnertsf on a network case.")
        .def(nb::init<nb::list>(), nb::arg("families"))
        .def_prop_ro("ctx", &NlmStack::ctx)
        .def_prop_ro("f", &NlmStack::f)
        .def_prop_ro("h", &NlmStack::h)
        .def_prop_ro("f_jac", &NlmStack::f_jac)
        .def_prop_ro("h_jac", &NlmStack::h_jac);
}

} // namespace DKF_PY_NS
