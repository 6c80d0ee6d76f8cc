// python/src/tw.cpp - the two-stage filters of dkf/tw.h over a sensor network
// (seed 003): TWCentral (Algorithm 1) and TWNetwork (Algorithms 2 and 3 on
// one graph, dkf/graph.h). docs/guide/python.md, "Graph filters".
#include <nanobind/stl/string.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "common.h"
#include "dkf/graph.h"
#include "dkf/tw.h"

namespace DKF_PY_NS {

namespace {

// ---- the sensors of one step ----------------------------------------------

// The N per-node arguments of a step or a filter() run: y (a vector per node,
// or (T, m_l) per node), H and R (one matrix or a stack per node).
struct NodeArgs {
    std::vector<Mat> y, H, R;
    std::vector<size_t> m;
    size_t N = 0, T = 0;
};

std::vector<Mat> node_list(nb::handle seq, const char *call, const char *name)
{
    if (!nb::isinstance<nb::sequence>(seq) || nb::isinstance<nb::str>(seq))
        throw nb::type_error(
            (std::string(call) + ": " + name + " must be a sequence, one entry per node").c_str());
    std::vector<Mat> out;
    nb::sequence sq = nb::borrow<nb::sequence>(seq);
    const size_t L = nb::len(sq);
    for (size_t l = 0; l < L; ++l) {
        const std::string nm = std::string(name) + "[" + std::to_string(l) + "]";
        out.push_back(std::string(name) == "y" ? vector_arg(sq[l], call, nm.c_str(), 0)
                                               : matrix_arg(sq[l], call, nm.c_str(), 0, 0, true));
    }
    return out;
}

// One step's y, H, R (series = false), or filter()'s Y (T, m_l) per node and
// H, R as one matrix or a stack of T per node (series = true). N: the
// network's node count, or 0 (any, at least 1).
NodeArgs node_args(nb::handle y, nb::handle H, nb::handle R, const char *call, size_t n,
                   size_t m_max, size_t N, bool series)
{
    NodeArgs a;
    const char *yname = series ? "Y" : "y";
    if (series) {
        if (!nb::isinstance<nb::sequence>(y) || nb::isinstance<nb::str>(y))
            throw nb::type_error((std::string(call) +
                                  ": Y must be a sequence of arrays (T, m_l), one per node")
                                     .c_str());
        nb::sequence sq = nb::borrow<nb::sequence>(y);
        for (size_t l = 0; l < nb::len(sq); ++l) {
            const std::string nm = "Y[" + std::to_string(l) + "]";
            Mat v;
            v.keep = as_array(sq[l], call, nm.c_str());
            if (v.keep.ndim() != 2 || v.keep.shape(1) == 0 ||
                (l && v.keep.shape(0) != a.y[0].count)) {
                value_error(call, nm + " must be (T, m_l) with the T of Y[0], got shape " +
                                      shape_str(v.keep));
            }
            v.p = v.keep.data(), v.count = v.keep.shape(0), v.stacked = true;
            v.rows = v.keep.shape(1), v.cols = 1;
            a.y.push_back(v);
        }
    } else {
        a.y = node_list(y, call, "y");
    }
    a.N = a.y.size();
    if (a.N == 0 || (N && a.N != N)) {
        value_error(call, std::string(yname) + " has " + std::to_string(a.N) +
                              " entries, one per node: " + (N ? std::to_string(N) : "at least 1"));
    }
    for (size_t l = 0; l < a.N; ++l) {
        a.m.push_back(a.y[l].rows);
        if (a.y[l].rows > m_max) {
            raise_status(DKF_ERR_CAPACITY, call, -1, yname,
                         "node " + std::to_string(l) + " measures m = " +
                             std::to_string(a.y[l].rows) + " > m_max = " + std::to_string(m_max));
        }
    }
    a.T = series ? a.y[0].count : 1;
    a.H = sensor_mats(H, call, "H", a.N, a.m, n);
    a.R = sensor_mats(R, call, "R", a.N, a.m, 0);
    for (size_t l = 0; l < a.N; ++l) {
        const std::string sfx = "[" + std::to_string(l) + "]";
        if (series) {
            check_stack(a.H[l], a.T, call, "H" + sfx);
            check_stack(a.R[l], a.T, call, "R" + sfx);
        } else if (a.H[l].stacked || a.R[l].stacked) {
            value_error(call, "H" + sfx + " and R" + sfx + " must be single matrices here");
        }
    }
    return a;
}

// The measured components of every node at time t (a NaN in y is a missing
// component: the rows of H, the rows and columns of R of the measured ones),
// as the core's views. No Python.
struct Measured {
    size_t n;
    std::vector<real> ys, Hs, Rs;
    std::vector<dkf_mat_t> Hm, Rm, ym;
    std::vector<dkf_kf_meas_t> meas;
    std::vector<size_t> node;  // the node of each entry
    long empty = -1;           // a node with nothing measured (the network refuses it)
    Measured(size_t n_, size_t m_max, size_t N)
        : n(n_), ys(N * m_max), Hs(N * m_max * n_), Rs(N * m_max * m_max), Hm(N), Rm(N), ym(N),
          meas(N)
    {
    }
    // keep_empty: a node with nothing measured stays in (the network's
    // step needs every node) and is recorded in `empty`; else it is left out.
    size_t select(const NodeArgs &a, size_t t, size_t m_max, bool keep_empty)
    {
        size_t used = 0;
        empty = -1;
        node.clear();
        for (size_t l = 0; l < a.N; ++l) {
            const real *y = a.y[l].p + (a.y[l].stacked ? t * a.m[l] : 0);
            const real *H = a.H[l].at(t), *R = a.R[l].at(t);
            size_t k = select_measured(&y, &H, &R, a.m[l], n, &ys[l * m_max], &Hs[l * m_max * n],
                                       &Rs[l * m_max * m_max]);
            if (k == 0) {
                if (!keep_empty) continue;
                if (empty < 0) empty = static_cast<long>(l);
                k = a.m[l];
            }
            Hm[used] = view(k, n, H);
            Rm[used] = view(k, k, R);
            ym[used] = view(k, 1, y);
            meas[used] = {&Hm[used], &Rm[used]};
            node.push_back(l);
            ++used;
        }
        return used;
    }
};

// The dynamics F, G, Q of a step (single matrices) or of filter() (each one
// matrix or a stack indexed by the time).
struct Dyn {
    Mat F, G, Q;
};

Dyn dyn_args(nb::handle F, nb::handle G, nb::handle Q, const char *call, size_t n, size_t p,
             bool series)
{
    Dyn d;
    d.F = matrix_arg(F, call, "F", n, n, series);
    d.G = matrix_arg(G, call, "G", n, p, series);
    d.Q = matrix_arg(Q, call, "Q", n, n, series);
    return d;
}

// A failed step's dkf.Error. weights: "alpha", "W" or nullptr.
[[noreturn]] void raise_tw(dkf_status_t st, const char *call, long step, const NodeArgs &a,
                           const Dyn &d, size_t t, size_t n, size_t p, const char *weights,
                           const std::vector<real> &w, long empty)
{
    const char *culprit = nullptr;
    std::string detail;
    const size_t td = t ? t - 1 : 0;
    if (st == DKF_ERR_NONFINITE) {
        if (empty >= 0) {
            culprit = "y";
            detail = "node " + std::to_string(empty) +
                     ": y all missing (every node of the network needs a measurement)";
        } else {
            culprit = first_nonfinite({{"F", d.F.at(td), n * n, false},
                                       {"G", d.G.at(td), n * p, false},
                                       {"Q", d.Q.at(td), n * n, false},
                                       {weights, weights ? w.data() : nullptr, w.size(), false}});
            for (size_t l = 0; l < a.N && !culprit; ++l) {
                const real *y = a.y[l].p + (a.y[l].stacked ? t * a.m[l] : 0);
                culprit = first_nonfinite({{"y", y, a.m[l], true},
                                           {"H", a.H[l].at(t), a.m[l] * n, false},
                                           {"R", a.R[l].at(t), a.m[l] * a.m[l], false}});
                if (culprit) detail = "node " + std::to_string(l) + ": ";
            }
            detail += nonfinite_detail(culprit);
        }
    } else if (st == DKF_ERR_NOT_SPD) {
        detail = "a node's R is not SPD, or F P F^T + Q or Psi = Phi-^-1 + I is not (Q "
                 "indefinite?)";
    } else if (st == DKF_ERR_RANK) {
        culprit = "G";
        detail = "S = Gpost^T I G is singular: rank(H G) < p over the nodes the information "
                 "came from";
    } else if (st == DKF_ERR_WEIGHTS) {
        culprit = weights;
        detail = std::string(weights) +
                 (weights[0] == 'W' ? " must be doubly stochastic and >= 0 on the graph"
                                    : " must be row-stochastic and >= 0 on the graph");
    } else if (st == DKF_ERR_ARG) {
        culprit = "eta", detail = "eta must be at most " + std::to_string(DKF_TW_MAX_ETA);
    }
    raise_status(st, call, step, culprit, detail);
}

// The Y of filter(): Y[t] is y_t, Y[0] is not read (x0 is x_{0|0}).
void check_T(const NodeArgs &a, const Dyn &d, const char *call)
{
    if (a.T < 2) value_error(call, "Y needs T >= 2 rows (Y[0], y_0, is not read)");
    check_stack(d.F, a.T, call, "F");
    check_stack(d.G, a.T, call, "G");
    check_stack(d.Q, a.T, call, "Q");
}

// ---- TWCentral ---------------------------------------------------------------

// A constructor's prior (x0, P0) and sizes, checked, and the refusal of its init.
struct Prior {
    const char *call;
    Mat x, P;
    size_t n, m_max, p;
    dkf_mat_t xm, Pm;
    Prior(nb::handle x0, nb::handle P0, size_t m_max_, size_t p_, const char *call_)
        : call(call_), x(vector_arg(x0, call_, "x0", 0)), n(x.rows), m_max(m_max_), p(p_)
    {
        P = matrix_arg(P0, call, "P0", n, n, false);
        if (m_max == 0 || p == 0) value_error(call, "m_max and p must be positive");
        xm = view(n, 1, x.p), Pm = view(n, n, P.p);
    }
    void check(dkf_status_t st) const
    {
        if (st == DKF_ERR_RANK)
            raise_status(st, call, -1, nullptr, "p > n: the input cannot be estimated");
        if (st != DKF_OK) {
            raise_init(st, call, x, P,
                       "n = " + std::to_string(n) + ", m_max = " + std::to_string(m_max) +
                           ", p = " + std::to_string(p));
        }
    }
};

class TWCentral : Guarded {
public:
    TWCentral(nb::handle x0, nb::handle P0, size_t m_max, size_t p)
    {
        Prior pr(x0, P0, m_max, p, "TWCentral");
        n_ = pr.n, m_max_ = m_max, p_ = p;
        storage_.assign(DKF_TW_NODE_STORAGE_LEN(n_, m_max_, p_), real(0));
        std::memset(&nd_, 0, sizeof nd_);
        pr.check(dkf_tw_node_init(&nd_, n_, m_max_, p_, storage_.data(), storage_.size(), &pr.xm,
                                  &pr.Pm));
    }
    TWCentral(const TWCentral &) = delete;
    TWCentral &operator=(const TWCentral &) = delete;

    void step(nb::handle y, nb::handle F, nb::handle G, nb::handle Q, nb::handle H, nb::handle R)
    {
        static const char *call = "TWCentral.step";
        not_busy(call);
        NodeArgs a = node_args(y, H, R, call, n_, m_max_, 0, false);
        Dyn d = dyn_args(F, G, Q, call, n_, p_, false);
        Measured ms(n_, m_max_, a.N);
        dkf_status_t st = do_step(a, d, ms, 0);
        if (st != DKF_OK) raise_tw(st, call, -1, a, d, 0, n_, p_, nullptr, {}, -1);
    }

    nb::tuple filter(nb::handle Y, nb::handle F, nb::handle G, nb::handle Q, nb::handle H,
                     nb::handle R)
    {
        static const char *call = "TWCentral.filter";
        not_busy(call);
        check_unstarted(nd_.k, call);
        NodeArgs a = node_args(Y, H, R, call, n_, m_max_, 0, true);
        Dyn d = dyn_args(F, G, Q, call, n_, p_, true);
        check_T(a, d, call);
        const size_t S = a.T - 1, xs[2] = {S, n_}, ps[3] = {S, n_, n_}, ds[2] = {S, p_};
        OutArray X = new_array(2, xs), P = new_array(3, ps), D = new_array(2, ds);
        Measured ms(n_, m_max_, a.N);
        Undo<dkf_tw_node_t> undo(nd_, storage_);
        dkf_status_t st = DKF_OK;
        size_t t = 1;
        busy_ = true;
        {
            nb::gil_scoped_release unlocked;
            for (t = 1; t < a.T; ++t) {
                st = do_step(a, d, ms, t);
                if (st != DKF_OK) break;
                put_row(X.data(), t - 1, nd_.x);
                put_row(P.data(), t - 1, nd_.P);
                put_row(D.data(), t - 1, nd_.d);
            }
            if (st != DKF_OK) undo.restore();
        }
        busy_ = false;
        if (st != DKF_OK) raise_tw(st, call, static_cast<long>(t), a, d, t, n_, p_, nullptr, {}, -1);
        return nb::make_tuple(X, P, D);
    }

    OutArray field(const dkf_mat_t &M, const char *what, bool vector) const
    {
        not_busy(what);
        return mat_out(M, vector);
    }
    const dkf_tw_node_t &state() const { return nd_; }
    size_t n() const { return n_; }
    size_t m_max() const { return m_max_; }
    size_t p() const { return p_; }

private:
    // Step t's sensors with the dynamics at t - 1 (the step takes y_t). No Python.
    dkf_status_t do_step(const NodeArgs &a, const Dyn &d, Measured &ms, size_t t)
    {
        const size_t used = ms.select(a, t, m_max_, false);
        const size_t td = t ? t - 1 : 0;
        dkf_mat_t Fm = view(n_, n_, d.F.at(td)), Gm = view(n_, p_, d.G.at(td)),
                  Qm = view(n_, n_, d.Q.at(td));
        dkf_uif_dyn_t dyn = {&Fm, &Gm, &Qm};
        return dkf_tw_central_step(&nd_, &dyn, ms.meas.data(), ms.ym.data(), used);
    }

    size_t n_ = 0, m_max_ = 0, p_ = 0;
    std::vector<real> storage_;
    dkf_tw_node_t nd_;
};

// ---- TWNetwork ---------------------------------------------------------------

class TWNetwork : Guarded {
public:
    TWNetwork(nb::handle x0, nb::handle P0, nb::handle adjacency, size_t m_max, size_t p)
    {
        static const char *call = "TWNetwork";
        Prior pr(x0, P0, m_max, p, call);
        n_ = pr.n, m_max_ = m_max, p_ = p;
        graph_.bind(adjacency, call);
        N_ = graph_.N;
        nodes_.resize(N_);
        std::memset(nodes_.data(), 0, N_ * sizeof(dkf_tw_node_t));
        storage_.assign(DKF_TW_NET_STORAGE_LEN(N_, n_, m_max_, p_), real(0));
        std::memset(&net_, 0, sizeof net_);
        pr.check(dkf_tw_net_init(&net_, &graph_.g, nodes_.data(), n_, m_max_, p_, storage_.data(),
                                 storage_.size(), &pr.xm, &pr.Pm));
    }
    TWNetwork(const TWNetwork &) = delete;
    TWNetwork &operator=(const TWNetwork &) = delete;

    void diffusion_step(nb::handle y, nb::handle alpha, nb::handle F, nb::handle G, nb::handle Q,
                        nb::handle H, nb::handle R)
    {
        static const char *call = "TWNetwork.diffusion_step";
        one_step(call, y, F, G, Q, H, R, weights(alpha, call, "alpha"), "alpha", 0);
    }

    void consensus_step(nb::handle y, nb::handle W, size_t eta, nb::handle F, nb::handle G,
                        nb::handle Q, nb::handle H, nb::handle R)
    {
        static const char *call = "TWNetwork.consensus_step";
        one_step(call, y, F, G, Q, H, R, weights(W, call, "W"), "W", eta);
    }

    nb::tuple filter(nb::handle Y, nb::handle F, nb::handle G, nb::handle Q, nb::handle H,
                     nb::handle R, nb::handle alpha, nb::handle W, nb::handle eta)
    {
        static const char *call = "TWNetwork.filter";
        not_busy(call);
        check_unstarted(k(), call);
        const bool diffusion = !alpha.is_none();
        if (diffusion == !W.is_none())
            value_error(call, "give alpha (diffusion) or W and eta (consensus), not both");
        if (diffusion != eta.is_none())
            value_error(call, diffusion ? "eta is the consensus's: give W with it"
                                        : "the consensus needs eta");
        const char *wname = diffusion ? "alpha" : "W";
        std::vector<real> w = weights(diffusion ? alpha : W, call, wname);
        const size_t e = diffusion ? 0 : nb::cast<size_t>(eta);
        NodeArgs a = node_args(Y, H, R, call, n_, m_max_, N_, true);
        Dyn d = dyn_args(F, G, Q, call, n_, p_, true);
        check_T(a, d, call);
        const size_t S = a.T - 1, xs[3] = {S, N_, n_}, ps[4] = {S, N_, n_, n_},
                     ds[3] = {S, N_, p_};
        OutArray X = new_array(3, xs), P = new_array(4, ps), D = new_array(3, ds);
        Measured ms(n_, m_max_, N_);
        Undo<dkf_tw_net_t> undo(net_, storage_);
        const std::vector<dkf_tw_node_t> saved_nodes(nodes_);
        dkf_status_t st = DKF_OK;
        size_t t = 1;
        busy_ = true;
        {
            nb::gil_scoped_release unlocked;
            for (t = 1; t < a.T; ++t) {
                st = do_step(a, d, ms, t, w.data(), wname, e);
                if (st != DKF_OK) break;
                for (size_t l = 0; l < N_; ++l) {
                    put_row(X.data(), (t - 1) * N_ + l, nodes_[l].x);
                    put_row(P.data(), (t - 1) * N_ + l, nodes_[l].P);
                    put_row(D.data(), (t - 1) * N_ + l, nodes_[l].d);
                }
            }
            if (st != DKF_OK) {
                undo.restore();
                std::copy(saved_nodes.begin(), saved_nodes.end(), nodes_.begin());
            }
        }
        busy_ = false;
        if (st != DKF_OK)
            raise_tw(st, call, static_cast<long>(t), a, d, t, n_, p_, wname, w, ms.empty);
        return nb::make_tuple(X, P, D);
    }

    // A field of every node, stacked: (N, rows) for a vector, else (N, rows, cols).
    OutArray field(dkf_mat_t dkf_tw_node_t::*mat, const char *what, bool vector) const
    {
        not_busy(what);
        const dkf_mat_t &M0 = nodes_[0].*mat;
        const size_t shape[3] = {N_, M0.rows, M0.cols};
        OutArray out = new_array(vector ? 2 : 3, shape);
        for (size_t l = 0; l < N_; ++l) put_row(out.data(), l, nodes_[l].*mat);
        return out;
    }
    OutArray adjacency() const { return graph_.adjacency(); }
    const dkf_tw_net_t &net() const { return net_; }
    size_t k() const { return nodes_[0].k; }
    size_t steps() const { return net_.steps; }
    size_t N() const { return N_; }
    size_t n() const { return n_; }
    size_t m_max() const { return m_max_; }
    size_t p() const { return p_; }

private:
    std::vector<real> weights(nb::handle w, const char *call, const char *name) const
    {
        return graph_.weights(w, call, name);
    }

    void one_step(const char *call, nb::handle y, nb::handle F, nb::handle G, nb::handle Q,
                  nb::handle H, nb::handle R, const std::vector<real> &w, const char *wname,
                  size_t eta)
    {
        not_busy(call);
        NodeArgs a = node_args(y, H, R, call, n_, m_max_, N_, false);
        Dyn d = dyn_args(F, G, Q, call, n_, p_, false);
        Measured ms(n_, m_max_, N_);
        dkf_status_t st = do_step(a, d, ms, 0, w.data(), wname, eta);
        if (st != DKF_OK) raise_tw(st, call, -1, a, d, 0, n_, p_, wname, w, ms.empty);
    }

    // Step t: every node's y_t with the dynamics at t - 1. No Python.
    dkf_status_t do_step(const NodeArgs &a, const Dyn &d, Measured &ms, size_t t, const real *w,
                         const char *wname, size_t eta)
    {
        ms.select(a, t, m_max_, true);
        if (ms.empty >= 0) return DKF_ERR_NONFINITE;
        const size_t td = t ? t - 1 : 0;
        dkf_mat_t Fm = view(n_, n_, d.F.at(td)), Gm = view(n_, p_, d.G.at(td)),
                  Qm = view(n_, n_, d.Q.at(td));
        dkf_uif_dyn_t dyn = {&Fm, &Gm, &Qm};
        if (wname[0] == 'a')
            return dkf_tw_net_diffusion_step(&net_, w, &dyn, ms.meas.data(), ms.ym.data());
        return dkf_tw_net_consensus_step(&net_, w, eta, &dyn, ms.meas.data(), ms.ym.data());
    }

    size_t N_ = 0, n_ = 0, m_max_ = 0, p_ = 0;
    GraphArg graph_;
    std::vector<dkf_tw_node_t> nodes_;
    std::vector<real> storage_;
    dkf_tw_net_t net_;
};

// The node fields both classes show.
struct TwField {
    const char *name;
    dkf_mat_t dkf_tw_node_t::*mat;
    bool vector;
    const char *doc;
};

const TwField tw_fields[] = {
    {"x", &dkf_tw_node_t::x, true, "x_{k|k} (n,), a copy."},
    {"P", &dkf_tw_node_t::P, false, "P_{k|k} (n, n), a copy."},
    {"d", &dkf_tw_node_t::d, true, "The estimate of d_{k-1} (p,), a copy."},
    {"phi", &dkf_tw_node_t::phi, true, "phi_{k|k-1} of the last step."},
    {"Phi", &dkf_tw_node_t::Phi, false, "Phi_{k|k-1} of the last step."},
    {"I", &dkf_tw_node_t::I, false, "The information matrix the last step used."},
    {"i", &dkf_tw_node_t::i, true, "The information vector the last step used."},
    {"phi_post", &dkf_tw_node_t::phi_post, true, "phi_{k|k} of the last step."},
    {"Phi_post", &dkf_tw_node_t::Phi_post, false, "Phi_{k|k} of the last step."},
    {"S", &dkf_tw_node_t::S, false, "S_k = Gpost^T I G (p, p) of the last step."},
    {"Gpost", &dkf_tw_node_t::Gpost, false, "Gpost_k (n, p) of the last step."},
    {"psi", &dkf_tw_node_t::psi, true, "The local psi of the last step."},
    {"Ploc", &dkf_tw_node_t::Ploc, false, "The local Ploc of the last step."},
};

} // namespace

void check_unstarted(size_t k, const char *call)
{
    if (k != 0) {
        raise_status(DKF_ERR_STATE, call, -1, nullptr,
                     "filter() runs a filter from its start: this one has taken " +
                         std::to_string(k) + " steps");
    }
}

// ---- a graph argument (declared in common.h) ---------------------------------

void GraphArg::bind(nb::handle adjacency, const char *call)
{
    Mat A = matrix_arg(adjacency, call, "adjacency", 0, 0, false);
    N = A.rows;
    if (A.cols != N) {
        value_error(call, "adjacency must be square (N, N), got shape " + shape_str(A.keep));
    }
    // The neighbourhoods, self included (dkf/graph.h); a nonzero entry is a link.
    start.assign(1, 0);
    nbr.clear();
    for (size_t i = 0; i < N; ++i) {
        for (size_t j = 0; j < N; ++j) {
            const real v = A.p[i * N + j];
            if (!std::isfinite(v))
                value_error(call, "adjacency[" + std::to_string(i) + ", " + std::to_string(j) +
                                      "] is not finite");
            if (i == j || v != 0) nbr.push_back(j);
        }
        start.push_back(nbr.size());
    }
    std::memset(&g, 0, sizeof g);
    dkf_status_t st = dkf_graph_init(&g, N, start.data(), nbr.data());
    if (st == DKF_ERR_GRAPH) raise_status(st, call, -1, "adjacency", "adjacency not symmetric");
    if (st != DKF_OK) raise_status(st, call, -1, "adjacency", "");
}

// A dense (N, N) weight matrix as the core's nnz weights along the graph;
// dkf.GraphError for a nonzero entry off the graph.
std::vector<real> GraphArg::weights(nb::handle w, const char *call, const char *name) const
{
    Mat m = matrix_arg(w, call, name, N, N, false);
    std::vector<real> out;
    for (size_t i = 0; i < N; ++i) {
        size_t e = start[i];
        for (size_t j = 0; j < N; ++j) {
            const real v = m.p[i * N + j];
            if (e < start[i + 1] && nbr[e] == j) {
                out.push_back(v);
                ++e;
            } else if (v != 0) {
                raise_status(DKF_ERR_GRAPH, call, -1, name,
                             std::string(name) + "[" + std::to_string(i) + ", " +
                                 std::to_string(j) + "] is nonzero where the graph has no link");
            }
        }
    }
    return out;
}

OutArray GraphArg::adjacency() const
{
    const size_t shape[2] = {N, N};
    OutArray out = new_array(2, shape);
    std::fill(out.data(), out.data() + N * N, real(0));
    for (size_t i = 0; i < N; ++i)
        for (size_t e = start[i]; e < start[i + 1]; ++e)
            if (nbr[e] != i) out.data()[i * N + nbr[e]] = real(1);
    return out;
}

// The weights a dkf_graph_weights_* function gives on the graph of
// adjacency, as a dense (N, N) array, zero off the graph.
static OutArray graph_weights(nb::handle adjacency, const char *call,
                              dkf_status_t (*make)(dkf_real_t *, const dkf_graph_t *))
{
    GraphArg g;
    g.bind(adjacency, call);
    std::vector<real> w(g.nbr.size());
    const dkf_status_t st = make(w.data(), &g.g);
    if (st != DKF_OK) raise_status(st, call, -1, "adjacency", "");
    const size_t shape[2] = {g.N, g.N};
    OutArray out = new_array(2, shape);
    std::fill(out.data(), out.data() + g.N * g.N, real(0));
    for (size_t i = 0; i < g.N; ++i)
        for (size_t e = g.start[i]; e < g.start[i + 1]; ++e) out.data()[i * g.N + g.nbr[e]] = w[e];
    return out;
}

void register_tw(nb::module_ &m)
{
    using WeightsFn = dkf_status_t (*)(dkf_real_t *, const dkf_graph_t *);
    static const struct {
        const char *name;
        WeightsFn make;
        const char *doc;
    } weight_fns[] = {
        {"graph_weights_uniform", dkf_graph_weights_uniform,
         "Uniform weights w_ij = 1 / |N_i| on the graph (self included), (N, N): the default "
         "alpha of the diffusion (dkf_graph_weights_uniform)."},
        {"graph_weights_metropolis", dkf_graph_weights_metropolis,
         "Metropolis-Hastings weights w_ij = 1 / (1 + max(d_i, d_j)), w_ii = 1 - the others, "
         "(N, N): the default W of the consensus (dkf_graph_weights_metropolis)."},
        {"graph_weights_max_degree", dkf_graph_weights_max_degree,
         "Max-degree weights w_ij = 1 / (1 + d_max), w_ii = 1 - d_i / (1 + d_max), (N, N) "
         "(dkf_graph_weights_max_degree)."},
    };
    for (const auto &fn : weight_fns) {
        const char *name = fn.name;
        const WeightsFn make = fn.make;
        m.def(
            name, [name, make](nb::handle A) { return graph_weights(A, name, make); },
            nb::arg("adjacency"), nb::rv_policy::take_ownership, fn.doc);
    }

    nb::class_<TWCentral> c(m, "TWCentral",
                            "The centralised two-stage filter with unknown inputs, Algorithm 1 of "
                            "dkf/tw.h (seed 003).");
    c.def(nb::init<nb::handle, nb::handle, size_t, size_t>(), nb::arg("x0"), nb::arg("P0"),
          nb::kw_only(), nb::arg("m_max"), nb::arg("p"))
        .def("step", &TWCentral::step, nb::arg("y"), nb::kw_only(), nb::arg("F"), nb::arg("G"),
             nb::arg("Q"), nb::arg("H"), nb::arg("R"),
             "One step with y_k of every sensor (a sequence), the dynamics F, G, Q of time k - 1 "
             "and the sensors' H, R (sequences); NaN components of y are missing.")
        .def("filter", &TWCentral::filter, nb::arg("Y"), nb::kw_only(), nb::arg("F"),
             nb::arg("G"), nb::arg("Q"), nb::arg("H"), nb::arg("R"),
             "Steps 1..T-1 in one call without the GIL: Y a sequence of (T, m_l), Y[t] = y_t "
             "(Y[0] not read); F, G, Q, H[l], R[l] one matrix or a stack indexed by the time. "
             "Returns (X (T-1, n), P (T-1, n, n), D (T-1, p)).")
        .def_prop_ro("k", [](const TWCentral &f) { return f.state().k; }, "Steps taken.")
        .def_prop_ro("n", &TWCentral::n)
        .def_prop_ro("m_max", &TWCentral::m_max)
        .def_prop_ro("p", &TWCentral::p)
        .def("__repr__", [](const TWCentral &f) {
            return "<dkf TWCentral n=" + std::to_string(f.n()) + " m_max=" +
                   std::to_string(f.m_max()) + " p=" + std::to_string(f.p()) + " " DKF_PY_DTYPE
                   ">";
        });
    for (const TwField &fd : tw_fields) {
        const auto mat = fd.mat;
        const bool vec = fd.vector;
        const std::string name = std::string("TWCentral.") + fd.name;
        c.def_prop_ro(
            fd.name,
            [mat, vec, name](const TWCentral &f) { return f.field(f.state().*mat, name.c_str(), vec); },
            nb::rv_policy::take_ownership, fd.doc);
    }

    nb::class_<TWNetwork> net(m, "TWNetwork",
                              "The diffusion and consensus two-stage filters with unknown "
                              "inputs over one graph, Algorithms 2 and 3 of dkf/tw.h (seed 003).");
    net.def(nb::init<nb::handle, nb::handle, nb::handle, size_t, size_t>(), nb::arg("x0"),
            nb::arg("P0"), nb::kw_only(), nb::arg("adjacency"), nb::arg("m_max"), nb::arg("p"))
        .def("diffusion_step", &TWNetwork::diffusion_step, nb::arg("y"), nb::kw_only(),
             nb::arg("alpha"), nb::arg("F"), nb::arg("G"), nb::arg("Q"), nb::arg("H"),
             nb::arg("R"), "Algorithm 2's step: alpha (N, N) row-stochastic on the graph.")
        .def("consensus_step", &TWNetwork::consensus_step, nb::arg("y"), nb::kw_only(),
             nb::arg("W"), nb::arg("eta"), nb::arg("F"), nb::arg("G"), nb::arg("Q"), nb::arg("H"),
             nb::arg("R"), "Algorithm 3's step: W (N, N) doubly stochastic on the graph, eta "
                           "consensus iterations.")
        .def("filter", &TWNetwork::filter, nb::arg("Y"), nb::kw_only(), nb::arg("F"),
             nb::arg("G"), nb::arg("Q"), nb::arg("H"), nb::arg("R"),
             nb::arg("alpha") = nb::none(), nb::arg("W") = nb::none(), nb::arg("eta") = nb::none(),
             "Steps 1..T-1 of the diffusion (alpha) or the consensus (W, eta) in one call without "
             "the GIL; Y a sequence of (T, m_l) per node, Y[0] not read. Returns (X (T-1, N, n), "
             "P (T-1, N, n, n), D (T-1, N, p)).")
        .def_prop_ro("adjacency", &TWNetwork::adjacency, nb::rv_policy::take_ownership,
                     "The graph (N, N), 1 for a link, a copy.")
        .def_prop_ro("k", &TWNetwork::k, "Steps taken.")
        .def_prop_ro("N", &TWNetwork::N)
        .def_prop_ro("n", &TWNetwork::n)
        .def_prop_ro("m_max", &TWNetwork::m_max)
        .def_prop_ro("p", &TWNetwork::p)
        .def_prop_ro("reals_sent", [](const TWNetwork &f) { return f.net().reals_sent; },
                     "Reals broadcast, summed over nodes and steps.")
        .def_prop_ro("broadcasts", [](const TWNetwork &f) { return f.net().broadcasts; },
                     "Broadcasts, summed over nodes and steps.")
        .def_prop_ro("steps", &TWNetwork::steps,
                     "Steps the communication counters cover (per node per step: reals_sent / "
                     "(N steps)).")
        .def("__repr__", [](const TWNetwork &f) {
            return "<dkf TWNetwork N=" + std::to_string(f.N()) + " n=" + std::to_string(f.n()) +
                   " m_max=" + std::to_string(f.m_max()) + " p=" + std::to_string(f.p()) +
                   " " DKF_PY_DTYPE ">";
        });
    for (const TwField &fd : tw_fields) {
        const auto mat = fd.mat;
        const bool vec = fd.vector;
        const std::string name = std::string("TWNetwork.") + fd.name;
        net.def_prop_ro(
            fd.name, [mat, vec, name](const TWNetwork &f) { return f.field(mat, name.c_str(), vec); },
            nb::rv_policy::take_ownership, fd.doc);
    }
}

} // namespace DKF_PY_NS
