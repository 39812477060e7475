// dpc._mask_anneal: the inner loop of dpc.mask_design (spectral annealing of threshold masks).
//
// A mask is T frames of n x n ranks (each frame a permutation of 0 ... n*n - 1). The energy is
//   sum over frames f, frequencies q:  w_mask(q) |M_f(q)|^2  +  sum_g w_level[g](q) sum_l kappa[g][l] |B_fl(q)|^2
//   + sum over pixels p, levels l, temporal frequencies k:  kappa_time[l] w_time(k) |C_pl(k)|^2
// with M_f the DFT of frame f's ranks, B_fl that of its pattern [rank < threshold_l], and C_pl
// that of pixel p's sequence [rank_f < threshold_l] - threshold_l / (n*n) along the frames
// (k = 0 included: over the frames, each pixel should fall below each level its share of times).
// With joint thresholds, the two "frames" are the two channels of a vector mask and the energy
// adds  sum_q w_joint(q) sum_ij joint_kappa[i][j] |D_ij(q)|^2,  D_ij the DFT of the box pattern
// [rank_0 < joint_threshold_i][rank_1 < joint_threshold_j]. A step swaps two ranks of one frame (pixels at most `reach`
// apart on the torus); its energy change costs O(groups x frequencies + temporal frequencies)
// because each group (and each pixel's temporal term) keeps prefix sums over levels of
// kappa-weighted pattern spectra: the swap flips the levels between the two ranks, and their sum
// is a difference of two prefix sums.
// Metropolis acceptance at a temperature falling geometrically from t_start to t_end (in units
// of the mean energy increase of random steps at the start); t_start = 0 is greedy descent.
// Written in C++ because a 64 x 64 mask wants millions of steps; numpy costs ~1 ms per step.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <vector>

namespace py = pybind11;

namespace {

struct SplitMix {
    uint64_t s;
    uint64_t next() {
        uint64_t z = (s += 0x9E3779B97F4A7C15ull);
        z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
        z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
        return z ^ (z >> 31);
    }
    double uniform() { return double(next() >> 11) * 0x1.0p-53; }
    int below(int n) { return int(((next() >> 32) * uint64_t(n)) >> 32); }
};

using F64 = py::array_t<double, py::array::c_style | py::array::forcecast>;
using I32 = py::array_t<int32_t, py::array::c_style | py::array::forcecast>;

class Annealer {
  public:
    Annealer(const I32 &ranks, const I32 &qx, const I32 &qy, const F64 &w_mask, const F64 &w_level,
             const I32 &thresholds, const F64 &kappa, const F64 &w_time, const F64 &kappa_time,
             const I32 &joint_thresholds, const F64 &joint_kappa, const F64 &w_joint)
        : T_(int(ranks.shape(0))), n_(int(ranks.shape(1))), S_(n_ * n_), Q_(int(qx.size())), G_(int(w_level.shape(0))),
          K_(int(thresholds.size())), Kt_(int(w_time.size())), J_(int(joint_thresholds.size())) {
        if (ranks.ndim() != 3 || ranks.shape(2) != n_) throw std::invalid_argument("ranks must be (frames, n, n)");
        if (qy.size() != Q_ || w_mask.size() != Q_ || w_level.ndim() != 2 || w_level.shape(1) != Q_)
            throw std::invalid_argument("frequency arrays disagree in length");
        if (kappa.ndim() != 2 || kappa.shape(0) != G_ || kappa.shape(1) != K_)
            throw std::invalid_argument("kappa must be (groups, levels)");
        if (Kt_ > 0 && kappa_time.size() != K_) throw std::invalid_argument("kappa_time must have one entry per level");
        if (J_ > 0 && (T_ != 2 || Kt_ > 0 || joint_kappa.size() != J_ * J_ || w_joint.size() != Q_))
            throw std::invalid_argument("a joint term needs 2 channels, no temporal term, (J, J) joint_kappa and "
                                        "one joint weight per frequency");
        rank_.assign(ranks.data(), ranks.data() + size_t(T_) * S_);
        for (int f = 0; f < T_; ++f) {
            std::vector<char> seen(S_, 0);
            for (int p = 0; p < S_; ++p) {
                int r = rank_[size_t(f) * S_ + p];
                if (r < 0 || r >= S_ || seen[r])
                    throw std::invalid_argument("each frame must be a permutation of 0 ... n*n-1");
                seen[r] = 1;
            }
        }
        qx_.resize(Q_), qy_.resize(Q_);
        for (int i = 0; i < Q_; ++i) qx_[i] = ((qx.data()[i] % n_) + n_) % n_, qy_[i] = ((qy.data()[i] % n_) + n_) % n_;
        wm_.assign(w_mask.data(), w_mask.data() + Q_);
        wl_.assign(w_level.data(), w_level.data() + size_t(G_) * Q_);
        thr_.assign(thresholds.data(), thresholds.data() + K_);
        kap_.assign(kappa.data(), kappa.data() + size_t(G_) * K_);
        wt_.assign(w_time.data(), w_time.data() + Kt_);
        kpt_.assign(K_ + 1, 0.0);
        for (int l = 0; l < K_ && Kt_ > 0; ++l) kpt_[l + 1] = kpt_[l] + kappa_time.data()[l];
        for (int l = 1; l < K_; ++l)
            if (thr_[l] <= thr_[l - 1]) throw std::invalid_argument("thresholds must increase");
        kpre_.assign(size_t(G_) * (K_ + 1), 0.0);
        for (int g = 0; g < G_; ++g)
            for (int l = 0; l < K_; ++l) kpre_[g * (K_ + 1) + l + 1] = kpre_[g * (K_ + 1) + l] + kap_[g * K_ + l];
        level_of_rank_.resize(S_);
        for (int r = 0, l = 0; r < S_; ++r) {
            while (l < K_ && thr_[l] <= r) ++l;
            level_of_rank_[r] = l; // levels l ... K-1 have threshold > r: the pixel is on in them
        }
        cos_.resize(n_), sin_.resize(n_);
        for (int k = 0; k < n_; ++k) cos_[k] = std::cos(2 * M_PI * k / n_), sin_[k] = -std::sin(2 * M_PI * k / n_);
        if (Kt_ > 0) {
            tcos_.resize(size_t(Kt_) * T_), tsin_.resize(size_t(Kt_) * T_);
            for (int k = 0; k < Kt_; ++k)
                for (int f = 0; f < T_; ++f)
                    tcos_[k * T_ + f] = std::cos(2 * M_PI * k * f / T_),
                                   tsin_[k * T_ + f] = -std::sin(2 * M_PI * k * f / T_);
        }
        jthr_.assign(joint_thresholds.data(), joint_thresholds.data() + J_);
        for (int l = 1; l < J_; ++l)
            if (jthr_[l] <= jthr_[l - 1]) throw std::invalid_argument("joint thresholds must increase");
        jkap_.assign(joint_kappa.data(), joint_kappa.data() + size_t(J_) * J_);
        wj_.assign(w_joint.data(), w_joint.data() + (J_ > 0 ? Q_ : 0));
        joint_level_of_rank_.resize(S_);
        for (int r = 0, l = 0; r < S_; ++r) {
            while (l < J_ && jthr_[l] <= r) ++l;
            joint_level_of_rank_[r] = l;
        }
        rebuild();
        dr_.resize(Q_), di_.resize(Q_), ear_.resize(Q_), eai_.resize(Q_), ebr_.resize(Q_), ebi_.resize(Q_);
    }

    double energy() const {
        double e = 0;
        for (int f = 0; f < T_; ++f) {
            const double *mr = &Mr_[size_t(f) * Q_];
            const double *mi = &Mi_[size_t(f) * Q_];
            for (int i = 0; i < Q_; ++i) e += wm_[i] * (mr[i] * mr[i] + mi[i] * mi[i]);
            for (int g = 0; g < G_; ++g)
                for (int l = 1; l <= K_; ++l) {
                    double k = kap_[g * K_ + l - 1];
                    if (k == 0) continue;
                    const double *hr = prefix_re(f, g, l);
                    const double *hi = prefix_im(f, g, l);
                    const double *lr = prefix_re(f, g, l - 1);
                    const double *li = prefix_im(f, g, l - 1);
                    for (int i = 0; i < Q_; ++i) {
                        double br = hr[i] - lr[i], bi = hi[i] - li[i];
                        e += wl_[size_t(g) * Q_ + i] * (br * br + bi * bi) / k;
                    }
                }
        }
        for (int p = 0; p < S_ && Kt_ > 0; ++p)
            for (int l = 1; l <= K_; ++l) {
                double c = kpt_[l] - kpt_[l - 1];
                if (c == 0) continue;
                for (int k = 0; k < Kt_; ++k) {
                    double br = Vr_[tidx(p, l) + k] - Vr_[tidx(p, l - 1) + k],
                           bi = Vi_[tidx(p, l) + k] - Vi_[tidx(p, l - 1) + k];
                    e += wt_[k] * (br * br + bi * bi) / c;
                }
            }
        for (int i = 0; i < J_; ++i)
            for (int j = 0; j < J_; ++j)
                for (int q = 0; q < Q_; ++q) {
                    double br = Dr_[didx(0, i, j) + q], bi = Di_[didx(0, i, j) + q];
                    e += jkap_[i * J_ + j] * wj_[q] * (br * br + bi * bi);
                }
        return e;
    }

    py::tuple run(long long steps, int reach, int rank_reach, double t_start, double t_end, uint64_t seed) {
        rank_reach_ = rank_reach;
        pixel_of_rank_.assign(size_t(T_) * S_, 0);
        for (int f = 0; f < T_; ++f)
            for (int p = 0; p < S_; ++p) pixel_of_rank_[size_t(f) * S_ + rank_[size_t(f) * S_ + p]] = p;
        SplitMix rng{seed * 0x2545F4914F6CDD1Dull + 0x1234567ull};
        double e_start = energy();
        long long accepted = 0;
        double scale = 1.0;
        {
            py::gil_scoped_release release;
            double sum = 0;
            int count = 0;
            for (int t = 0; t < 4000; ++t) {
                int f, a, b;
                propose(rng, reach, f, a, b);
                if (a == b) continue;
                double d = delta(f, a, b);
                if (d > 0) sum += d, ++count;
            }
            if (count > 0 && sum > 0) scale = sum / count;
            const bool greedy = !(t_start > 0);
            const double l0 = greedy ? 0 : std::log(t_start * scale), l1 = greedy ? 0 : std::log(t_end * scale);
            for (long long t = 0; t < steps; ++t) {
                int f, a, b;
                propose(rng, reach, f, a, b);
                if (a == b) continue;
                double d = delta(f, a, b);
                bool take = d < 0;
                if (!take && !greedy) {
                    double temp = std::exp(l0 + (l1 - l0) * double(t) / double(steps));
                    take = rng.uniform() < std::exp(-d / temp);
                }
                if (take) apply(f, a, b), ++accepted;
            }
        }
        double e_end = energy();
        I32 out({T_, n_, n_});
        std::copy(rank_.begin(), rank_.end(), out.mutable_data());
        return py::make_tuple(out, accepted, e_start, e_end);
    }

  private:
    int T_, n_, S_, Q_, G_, K_, Kt_, J_, rank_reach_ = 0;
    // Joint term: D_[o][i][j] is the box pattern's DFT with level i of channel o and level j of the
    // other channel; DP_ its joint_kappa-weighted prefix sums over j (exclusive, J + 1 entries).
    std::vector<int> jthr_, joint_level_of_rank_;
    std::vector<double> jkap_, wj_, Dr_, Di_, DPr_, DPi_, ear_, eai_, ebr_, ebi_;
    std::vector<int> pixel_of_rank_, rank_, qx_, qy_, thr_, level_of_rank_;
    std::vector<double> wm_, wl_, kap_, kpre_, wt_, kpt_, cos_, sin_, tcos_, tsin_;
    std::vector<double> Mr_, Mi_, Pr_, Pi_, Vr_, Vi_, dr_, di_;

    size_t pidx(int f, int g, int l) const { return ((size_t(f) * G_ + g) * (K_ + 1) + l) * Q_; }
    size_t didx(int o, int i, int j) const { return ((size_t(o) * J_ + i) * J_ + j) * Q_; }
    size_t dpidx(int o, int i, int j) const { return ((size_t(o) * J_ + i) * (J_ + 1) + j) * Q_; }
    double joint_kappa(int o, int i, int j) const { return o == 0 ? jkap_[i * J_ + j] : jkap_[j * J_ + i]; }
    void joint_prefix_row(int o, int i) {
        for (int q = 0; q < Q_; ++q) DPr_[dpidx(o, i, 0) + q] = 0, DPi_[dpidx(o, i, 0) + q] = 0;
        for (int j = 0; j < J_; ++j) {
            const double k = joint_kappa(o, i, j);
            for (int q = 0; q < Q_; ++q) {
                DPr_[dpidx(o, i, j + 1) + q] = DPr_[dpidx(o, i, j) + q] + k * Dr_[didx(o, i, j) + q];
                DPi_[dpidx(o, i, j + 1) + q] = DPi_[dpidx(o, i, j) + q] + k * Di_[didx(o, i, j) + q];
            }
        }
    }
    size_t tidx(int p, int l) const { return (size_t(p) * (K_ + 1) + l) * Kt_; }
    const double *prefix_re(int f, int g, int l) const { return &Pr_[pidx(f, g, l)]; }
    const double *prefix_im(int f, int g, int l) const { return &Pi_[pidx(f, g, l)]; }
    int phase(int i, int p) const { return (qx_[i] * (p % n_) + qy_[i] * (p / n_)) % n_; }

    void rebuild() {
        Mr_.assign(size_t(T_) * Q_, 0), Mi_.assign(size_t(T_) * Q_, 0);
        Pr_.assign(size_t(T_) * G_ * (K_ + 1) * Q_, 0), Pi_.assign(Pr_.size(), 0);
        std::vector<double> br(size_t(K_) * Q_), bi(size_t(K_) * Q_);
        for (int f = 0; f < T_; ++f) {
            std::fill(br.begin(), br.end(), 0.0), std::fill(bi.begin(), bi.end(), 0.0);
            for (int p = 0; p < S_; ++p) {
                int r = rank_[size_t(f) * S_ + p], l0 = level_of_rank_[r];
                for (int i = 0; i < Q_; ++i) {
                    int k = phase(i, p);
                    Mr_[size_t(f) * Q_ + i] += r * cos_[k], Mi_[size_t(f) * Q_ + i] += r * sin_[k];
                    for (int l = l0; l < K_; ++l) br[size_t(l) * Q_ + i] += cos_[k], bi[size_t(l) * Q_ + i] += sin_[k];
                }
            }
            for (int g = 0; g < G_; ++g)
                for (int l = 1; l <= K_; ++l) {
                    double k = kap_[g * K_ + l - 1];
                    for (int i = 0; i < Q_; ++i) {
                        Pr_[pidx(f, g, l) + i] = Pr_[pidx(f, g, l - 1) + i] + k * br[size_t(l - 1) * Q_ + i];
                        Pi_[pidx(f, g, l) + i] = Pi_[pidx(f, g, l - 1) + i] + k * bi[size_t(l - 1) * Q_ + i];
                    }
                }
        }
        Vr_.assign(size_t(S_) * (K_ + 1) * Kt_, 0), Vi_.assign(Vr_.size(), 0);
        for (int p = 0; p < S_ && Kt_ > 0; ++p)
            for (int l = 1; l <= K_; ++l) { // C_pl(k) = sum_f ([rank_f < thr] - thr / S) e_f(k)
                const double share = double(thr_[l - 1]) / S_, c = kpt_[l] - kpt_[l - 1];
                for (int k = 0; k < Kt_; ++k) {
                    double sr = 0, si = 0;
                    for (int f = 0; f < T_; ++f) {
                        double b = (rank_[size_t(f) * S_ + p] < thr_[l - 1] ? 1.0 : 0.0) - share;
                        sr += b * tcos_[k * T_ + f], si += b * tsin_[k * T_ + f];
                    }
                    Vr_[tidx(p, l) + k] = Vr_[tidx(p, l - 1) + k] + c * sr,
                                     Vi_[tidx(p, l) + k] = Vi_[tidx(p, l - 1) + k] + c * si;
                }
            }
        Dr_.assign(size_t(2) * J_ * J_ * Q_, 0), Di_.assign(Dr_.size(), 0);
        DPr_.assign(size_t(2) * J_ * (J_ + 1) * Q_, 0), DPi_.assign(DPr_.size(), 0);
        for (int p = 0; p < S_ && J_ > 0; ++p) {
            const int l0 = joint_level_of_rank_[rank_[p]], l1 = joint_level_of_rank_[rank_[size_t(S_) + p]];
            for (int q = 0; q < Q_; ++q) {
                const int k = phase(q, p);
                for (int i = l0; i < J_; ++i)
                    for (int j = l1; j < J_; ++j) {
                        Dr_[didx(0, i, j) + q] += cos_[k], Di_[didx(0, i, j) + q] += sin_[k];
                        Dr_[didx(1, j, i) + q] += cos_[k], Di_[didx(1, j, i) + q] += sin_[k];
                    }
            }
        }
        for (int o = 0; o < 2 && J_ > 0; ++o)
            for (int i = 0; i < J_; ++i) joint_prefix_row(o, i);
    }

    void propose(SplitMix &rng, int reach, int &f, int &a, int &b) {
        f = T_ > 1 ? rng.below(T_) : 0;
        a = rng.below(S_);
        if (rank_reach_ > 0 && (rng.next() & 1)) { // half the steps: a pixel of nearly the same rank
            int r = rank_[size_t(f) * S_ + a] + rng.below(2 * rank_reach_ + 1) - rank_reach_;
            b = r < 0 || r >= S_ ? a : pixel_of_rank_[size_t(f) * S_ + r];
        } else if (2 * reach + 1 >= n_) {
            b = rng.below(S_);
        } else {
            int bx = (a % n_ + rng.below(2 * reach + 1) - reach + n_) % n_;
            int by = (a / n_ + rng.below(2 * reach + 1) - reach + n_) % n_;
            b = by * n_ + bx;
        }
        if (rank_[size_t(f) * S_ + a] > rank_[size_t(f) * S_ + b]) std::swap(a, b);
    }

    // Energy change of swapping the ranks of pixels a and b in frame f (rank a < rank b). Leaves
    // the pattern change e_b - e_a per frequency in dr_, di_ for apply().
    double delta(int f, int a, int b) {
        const int ra = rank_[size_t(f) * S_ + a], rb = rank_[size_t(f) * S_ + b];
        const int lo = level_of_rank_[ra], hi = level_of_rank_[rb];
        const double dv = double(rb - ra);
        const double *mr = &Mr_[size_t(f) * Q_];
        const double *mi = &Mi_[size_t(f) * Q_];
        double e = 0;
        for (int i = 0; i < Q_; ++i) {
            int ka = phase(i, a), kb = phase(i, b);
            double xr = cos_[kb] - cos_[ka], xi = sin_[kb] - sin_[ka];
            dr_[i] = xr, di_[i] = xi;
            ear_[i] = cos_[ka], eai_[i] = sin_[ka], ebr_[i] = cos_[kb], ebi_[i] = sin_[kb];
            // The mask's DFT changes by (rb - ra)(e_a - e_b) = -dv (e_b - e_a).
            e += wm_[i] * (dv * dv * (xr * xr + xi * xi) - 2 * dv * (mr[i] * xr + mi[i] * xi));
        }
        if (hi > lo) {
            for (int g = 0; g < G_; ++g) {
                const double ks = kpre_[g * (K_ + 1) + hi] - kpre_[g * (K_ + 1) + lo];
                if (ks == 0) continue;
                const double *hr = prefix_re(f, g, hi), *hi_ = prefix_im(f, g, hi);
                const double *lr = prefix_re(f, g, lo), *li = prefix_im(f, g, lo);
                const double *w = &wl_[size_t(g) * Q_];
                for (int i = 0; i < Q_; ++i) {
                    double sr = hr[i] - lr[i], si = hi_[i] - li[i];
                    e += w[i] * (2 * (sr * dr_[i] + si * di_[i]) + ks * (dr_[i] * dr_[i] + di_[i] * di_[i]));
                }
            }
        }
        const double kt = Kt_ > 0 ? kpt_[hi] - kpt_[lo] : 0.0;
        if (kt != 0) { // at frame f, pixel a leaves the flipped levels' patterns and pixel b joins them
            for (int k = 0; k < Kt_; ++k) {
                double c = tcos_[k * T_ + f], s = tsin_[k * T_ + f];
                double ar = Vr_[tidx(a, hi) + k] - Vr_[tidx(a, lo) + k],
                       ai = Vi_[tidx(a, hi) + k] - Vi_[tidx(a, lo) + k];
                double br = Vr_[tidx(b, hi) + k] - Vr_[tidx(b, lo) + k],
                       bi = Vi_[tidx(b, hi) + k] - Vi_[tidx(b, lo) + k];
                e += wt_[k] * (2 * ((br - ar) * c + (bi - ai) * s) + 2 * kt);
            }
        }
        if (J_ > 0) { // box patterns: channel f's levels i in [jlo, jhi) lose a and gain b where the
                      // other channel's value of the pixel is below level j
            const int jlo = joint_level_of_rank_[ra], jhi = joint_level_of_rank_[rb];
            const int la = joint_level_of_rank_[rank_[size_t(1 - f) * S_ + a]];
            const int lb = joint_level_of_rank_[rank_[size_t(1 - f) * S_ + b]];
            for (int i = jlo; i < jhi; ++i) {
                double both = 0, one = 0;
                for (int j = 0; j < J_; ++j) {
                    const bool ina = j >= la, inb = j >= lb;
                    if (ina && inb) both += joint_kappa(f, i, j);
                    else if (ina || inb) one += joint_kappa(f, i, j);
                }
                const double *er = &DPr_[dpidx(f, i, J_)], *ei = &DPi_[dpidx(f, i, J_)];
                const double *ar = &DPr_[dpidx(f, i, la)], *ai = &DPi_[dpidx(f, i, la)];
                const double *br = &DPr_[dpidx(f, i, lb)], *bi = &DPi_[dpidx(f, i, lb)];
                for (int q = 0; q < Q_; ++q) {
                    const double sar = er[q] - ar[q], sai = ei[q] - ai[q]; // sum over j >= la
                    const double sbr = er[q] - br[q], sbi = ei[q] - bi[q]; // sum over j >= lb
                    const double d2 = dr_[q] * dr_[q] + di_[q] * di_[q];
                    e += wj_[q] *
                         (2 * (sbr * ebr_[q] + sbi * ebi_[q] - sar * ear_[q] - sai * eai_[q]) + both * d2 + one);
                }
            }
        }
        return e;
    }

    void apply(int f, int a, int b) {
        int &ra = rank_[size_t(f) * S_ + a];
        int &rb = rank_[size_t(f) * S_ + b];
        const int lo = level_of_rank_[ra], hi = level_of_rank_[rb];
        const double dv = double(rb - ra);
        double *mr = &Mr_[size_t(f) * Q_];
        double *mi = &Mi_[size_t(f) * Q_];
        for (int i = 0; i < Q_; ++i) mr[i] -= dv * dr_[i], mi[i] -= dv * di_[i];
        for (int g = 0; g < G_ && hi > lo; ++g)
            for (int j = lo + 1; j <= K_; ++j) {
                double c = kpre_[g * (K_ + 1) + std::min(j, hi)] - kpre_[g * (K_ + 1) + lo];
                if (c == 0) continue;
                double *pr = &Pr_[pidx(f, g, j)], *pi = &Pi_[pidx(f, g, j)];
                for (int i = 0; i < Q_; ++i) pr[i] += c * dr_[i], pi[i] += c * di_[i];
            }
        for (int j = lo + 1; j <= K_ && Kt_ > 0 && hi > lo; ++j) {
            const double c = kpt_[std::min(j, hi)] - kpt_[lo];
            if (c == 0) continue;
            for (int k = 0; k < Kt_; ++k) {
                double er = c * tcos_[k * T_ + f], ei = c * tsin_[k * T_ + f];
                Vr_[tidx(a, j) + k] -= er, Vi_[tidx(a, j) + k] -= ei;
                Vr_[tidx(b, j) + k] += er, Vi_[tidx(b, j) + k] += ei;
            }
        }
        if (J_ > 0) {
            const int jlo = joint_level_of_rank_[ra], jhi = joint_level_of_rank_[rb];
            const int la = joint_level_of_rank_[rank_[size_t(1 - f) * S_ + a]];
            const int lb = joint_level_of_rank_[rank_[size_t(1 - f) * S_ + b]];
            for (int i = jlo; i < jhi; ++i) {
                for (int j = 0; j < J_; ++j) {
                    const double ca = j >= la ? 1.0 : 0.0, cb = j >= lb ? 1.0 : 0.0;
                    if (ca == 0 && cb == 0) continue;
                    for (int q = 0; q < Q_; ++q) {
                        const double xr = cb * ebr_[q] - ca * ear_[q], xi = cb * ebi_[q] - ca * eai_[q];
                        Dr_[didx(f, i, j) + q] += xr, Di_[didx(f, i, j) + q] += xi;
                        Dr_[didx(1 - f, j, i) + q] += xr, Di_[didx(1 - f, j, i) + q] += xi;
                    }
                }
                joint_prefix_row(f, i);
            }
            for (int j = 0; j < J_ && jhi > jlo; ++j) joint_prefix_row(1 - f, j);
        }
        std::swap(ra, rb);
        pixel_of_rank_[size_t(f) * S_ + ra] = a, pixel_of_rank_[size_t(f) * S_ + rb] = b;
    }
};

} // namespace

PYBIND11_MODULE(_mask_anneal, m) {
    m.doc() = "Inner loop of dpc.mask_design: simulated annealing of threshold-mask ranks on spectral energies.";
    m.def(
        "anneal",
        [](const I32 &ranks, const I32 &qx, const I32 &qy, const F64 &w_mask, const F64 &w_level, const I32 &thresholds,
           const F64 &kappa, const F64 &w_time, const F64 &kappa_time, const I32 &joint_thresholds,
           const F64 &joint_kappa, const F64 &w_joint, long long steps, int reach, int rank_reach, double t_start,
           double t_end, uint64_t seed) {
            Annealer a(ranks, qx, qy, w_mask, w_level, thresholds, kappa, w_time, kappa_time, joint_thresholds,
                       joint_kappa, w_joint);
            return a.run(steps, reach, rank_reach, t_start, t_end, seed);
        },
        py::arg("ranks"), py::arg("qx"), py::arg("qy"), py::arg("w_mask"), py::arg("w_level"), py::arg("thresholds"),
        py::arg("kappa"), py::arg("w_time"), py::arg("kappa_time"), py::arg("joint_thresholds"), py::arg("joint_kappa"),
        py::arg("w_joint"), py::arg("steps"), py::arg("reach"), py::arg("rank_reach"), py::arg("t_start"),
        py::arg("t_end"), py::arg("seed"));
}
