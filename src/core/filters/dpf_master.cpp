#include "rbpf_slam/core/filters/dpf_master.h"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "rbpf_slam/core/filters/pose_moments.h"

namespace rbpf_slam {
namespace core {
namespace {

std::vector<double> normalised(std::vector<double> w) {
  double total = 0.0;
  for (double& x : w) {
    if (!std::isfinite(x) || x < 0.0) x = 0.0;
    total += x;
  }
  for (double& x : w) x = total > 0.0 ? x / total : 1.0 / w.size();
  return w;
}

/// Every value the master reads from an estimate is finite (a NaN one, fused with weight 0,
/// still made the fusion NaN, and the master's NaN prediction then made every later local look
/// inconsistent: the filter stayed NaN for good).
bool finiteEstimate(const DpfLocalEstimate& e) {
  return e.mean.allFinite() && e.covariance.allFinite() && e.prior_mean.allFinite() &&
         e.prior_covariance.allFinite() && std::isfinite(e.nis_sum) && std::isfinite(e.neff);
}

/// The paper's fusion: x = sum_i w_i x_i (circular mean for the heading), covariance of the
/// mixture. Locals of weight 0 are left out (0 times a NaN is NaN).
void fuseAverage(const std::vector<const DpfLocalEstimate*>& locals,
                 const std::vector<double>& weights, DpfMasterOutput* out) {
  std::vector<Pose2> means;
  std::vector<Eigen::Matrix3d> covariances;
  std::vector<double> used;
  for (size_t i = 0; i < locals.size(); ++i) {
    if (!(weights[i] > 0.0)) continue;
    means.push_back(locals[i]->mean);
    covariances.push_back(locals[i]->covariance);
    used.push_back(weights[i]);
  }
  const PoseEstimate fused = mixtureMoments(means, covariances, used);
  out->mean = fused.mean;
  out->covariance = fused.covariance;
}

Pose2 difference(const Pose2& a, const Pose2& b) {
  Pose2 d = a - b;
  d.z() = wrapAngle(d.z());
  return d;
}

Eigen::Matrix3d regularised(const Eigen::Matrix3d& m) {
  return 0.5 * (m + m.transpose()) + Eigen::Vector3d(1e-8, 1e-8, 1e-10).asDiagonal().toDenseMatrix();
}

}  // namespace

void gainedInformation(const Eigen::Matrix3d& posterior_info, const Eigen::Matrix3d& prior_info,
                       const Eigen::Vector3d& vector, Eigen::Matrix3d* information,
                       Eigen::Vector3d* projected, Eigen::Matrix3d* not_gained) {
  const Eigen::Matrix3d gain = posterior_info - prior_info;
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(0.5 * (gain + gain.transpose()));
  const double floor = 1e-9 * std::max(posterior_info.trace(), 0.0);
  information->setZero();
  projected->setZero();
  not_gained->setIdentity();
  for (int k = 0; k < 3; ++k) {
    const double lambda = eigen.eigenvalues()(k);
    if (!(lambda > floor)) continue;  // nothing learned along this direction
    const Eigen::Vector3d u = eigen.eigenvectors().col(k);
    *information += lambda * u * u.transpose();
    *projected += u * u.dot(vector);
    *not_gained -= u * u.transpose();
  }
}

double segmentMahalanobis(const Eigen::Vector3d& r, const Eigen::Vector3d& v,
                          const Eigen::Matrix3d& covariance) {
  const Eigen::LDLT<Eigen::Matrix3d> ldlt(covariance);
  const Eigen::Vector3d sv = ldlt.solve(v);
  const double vv = v.dot(sv);
  const double t = vv > 0.0 ? std::clamp(r.dot(sv) / vv, 0.0, 1.0) : 0.0;
  const Eigen::Vector3d d = r - t * v;
  return d.dot(ldlt.solve(d));
}

std::vector<double> innovationWeights(const std::vector<double>& mean_nis) {
  std::vector<double> w;
  for (double nis : mean_nis) w.push_back(1.0 / std::max(nis, 1e-6));
  return normalised(w);
}

std::vector<double> neffWeights(const std::vector<double>& neff_ratio) {
  return normalised(neff_ratio);
}

std::vector<double> mixedWeights(const std::vector<double>& innovation,
                                 const std::vector<double>& neff, double alpha) {
  std::vector<double> w(innovation.size());
  for (size_t i = 0; i < w.size(); ++i) w[i] = alpha * innovation[i] + (1.0 - alpha) * neff[i];
  return normalised(w);
}

DpfMaster::DpfMaster(const DpfOptions& options) : options_(options) { reset(Pose2::Zero()); }

void DpfMaster::reset(const Pose2& initial_pose, const Eigen::Matrix3d& covariance) {
  health_.assign(options_.local_filters, DpfLocalHealth());
  last_ = DpfMasterOutput();
  last_.mean = initial_pose;
  last_.covariance = 0.5 * (covariance + covariance.transpose());
  last_.weights.assign(options_.local_filters, 1.0 / options_.local_filters);
}

DpfMasterOutput DpfMaster::fuse(long step, const MotionInput& motion,
                                const std::vector<DpfLocalEstimate>& estimates) {
  const int n = options_.local_filters;
  std::vector<const DpfLocalEstimate*> by_index(n, nullptr);
  for (const auto& e : estimates) {
    if (e.index < 0 || e.index >= n || by_index[e.index] || e.step != step) {
      throw std::invalid_argument("dpf master: unexpected estimate from local filter " +
                                  std::to_string(e.index) + " for step " +
                                  std::to_string(e.step) + " (fusing step " +
                                  std::to_string(step) + ")");
    }
    by_index[e.index] = &e;
  }
  for (int i = 0; i < n; ++i) {
    if (!by_index[i]) {
      throw std::invalid_argument("dpf master: no estimate from local filter " +
                                  std::to_string(i) + " for step " + std::to_string(step));
    }
  }
  std::vector<double> nis(n), neff(n);
  std::vector<bool> finite(n);
  for (int i = 0; i < n; ++i) {
    const DpfLocalEstimate& e = *by_index[i];
    DpfLocalHealth& h = health_[i];
    finite[i] = e.answered && finiteEstimate(e);
    h.answered = e.answered;
    if (!e.answered) h.inconsistent = false;  // not judged this step (not last step's verdict)
    if (!finite[i]) {
      if (e.answered) {
        ++h.non_finite;
      } else {
        // No answer: its last posterior is stale for the process check once it is back (a
        // restarted or resynchronised local comes back redrawn from the master's estimate).
        ++h.missed;
        h.has_last_mean = false;
      }
      nis[i] = h.smoothed_nis;
      neff[i] = 0.0;
      continue;
    }
    if (e.innovations > 0) {
      const double a = options_.innovation_smoothing;
      h.smoothed_nis = (1.0 - a) * h.smoothed_nis + a * e.nis_sum / e.innovations;
    }
    nis[i] = h.smoothed_nis;
    neff[i] = e.neff / std::max(e.particles, 1);
  }
  const std::vector<double> by_innovation = innovationWeights(nis);
  const std::vector<double> by_neff = neffWeights(neff);
  std::vector<double> w;
  if (options_.weighting == "innovation") {
    w = by_innovation;
  } else if (options_.weighting == "neff") {
    w = by_neff;
  } else {
    w = mixedWeights(by_innovation, by_neff, options_.mix_innovation);
  }
  DpfMasterOutput out;
  out.step = step;
  out.feedback.step = step;
  // The master's prediction: its last estimate moved by the step's odometry. Every local
  // predicted from the master's last estimate (the feedback) with the same odometry, so its
  // prior must agree with this one; the information fusion below adds what each local gained
  // relative to its prior, which is only valid when that prior is the master's.
  const Pose2 prior_mean = compose(last_.mean, motion.delta);
  // Fault detection: what the weighting looks at decides what counts as a fault.
  const bool watch_innovation = options_.weighting != "neff";
  const bool watch_neff = options_.weighting != "innovation";
  for (int i = 0; i < n; ++i) {
    DpfLocalHealth& h = health_[i];
    const DpfLocalEstimate& e = *by_index[i];
    if (!e.answered) {
      // No answer: not fused, and nothing to judge it by; its health record waits for its next
      // answer (it is neither flagged nor isolated for its silence).
      w[i] = 0.0;
      continue;
    }
    const Pose2 d = difference(e.prior_mean, prior_mean);
    const Eigen::Matrix3d s = regularised(e.prior_covariance + last_.covariance);
    h.prior_nis = d.dot(s.ldlt().solve(d));
    // Its process: the local started from a point between its own last posterior and the
    // master's last estimate (the feedback reweights its cloud towards the master), so a
    // healthy process predicts onto the segment between those two moved by the odometry. A
    // prior off that segment (not merely off the master's prediction, which a local that
    // kept its own correction, e.g. at a loop closure, is too) is a process fault.
    h.process_nis = h.prior_nis;
    if (h.has_last_mean) {
      const Pose2 own = difference(compose(h.last_mean, motion.delta), prior_mean);
      h.process_nis = segmentMahalanobis(d, own, s);
    }
    // A non-finite estimate is no process fault (its NaN process_nis would put the local on
    // probation after its isolation, unfused for readmit_after_steps clean steps).
    const bool process_fault = finite[i] && options_.fault_prior_chi2 > 0.0 &&
                               !(h.process_nis <= options_.fault_prior_chi2);  // NaN: fault
    if (finite[i]) {
      h.last_mean = e.mean;
      h.has_last_mean = true;
    }
    h.inconsistent = !finite[i] || (options_.fault_prior_chi2 > 0.0 &&
                                    !(h.prior_nis <= options_.fault_prior_chi2));  // NaN too
    h.suspect = h.inconsistent || (watch_innovation && nis[i] > options_.fault_nis) ||
                (watch_neff && neff[i] < options_.fault_neff_ratio);
    h.suspect_steps = h.suspect ? h.suspect_steps + 1 : 0;
    h.streak_process_fault = h.suspect && (h.streak_process_fault || process_fault);
    // Readmission after an isolation for a process fault: not fused until it has been
    // unflagged for readmit_after_steps consecutive steps (a flagged step restarts the count).
    // A persistent process fault passes the checks now and then (e.g. when a gap in the data
    // inflates every covariance); one clean step must not let it back in.
    if (h.probation_steps > 0) {
      w[i] = 0.0;
      h.probation_steps = h.suspect ? options_.readmit_after_steps : h.probation_steps - 1;
    }
    if (!h.suspect) continue;
    w[i] *= h.inconsistent ? 0.0 : options_.suspect_weight;
    if (h.suspect_steps >= options_.isolate_after_steps) {
      w[i] = 0.0;
      out.feedback.reinitialise.push_back(i);
      h.suspect_steps = 0;
      h.smoothed_nis = 2.0;
      if (h.streak_process_fault) h.probation_steps = options_.readmit_after_steps;
      h.streak_process_fault = false;
      ++h.isolations;
    }
  }
  // Trust of each local's information gain: min(1, N w_i); none when every local is suspect
  // of a fault with weight 0 (the master then predicts only: normalising would let them in).
  double total = 0.0;
  for (double x : w) total += std::isfinite(x) && x > 0.0 ? x : 0.0;
  out.weights = normalised(w);
  std::vector<double> trust(n, 0.0);
  for (int i = 0; i < n; ++i) trust[i] = total > 0.0 ? std::min(1.0, n * out.weights[i]) : 0.0;
  if (!(total > 0.0)) {
    // Every local is isolated or inconsistent: none is fused (averaging with the uniform
    // weights would let the faulty ones back in); the master keeps its own prediction, with
    // the locals' prior spread.
    out.mean = prior_mean;
    // (Only the finite answers: a placeholder's or a NaN prior would make it NaN.)
    Eigen::Matrix3d spread = Eigen::Matrix3d::Zero();
    int counted = 0;
    for (int i = 0; i < n; ++i) {
      if (!finite[i]) continue;
      spread += by_index[i]->prior_covariance;
      ++counted;
    }
    if (counted > 0) spread /= counted;
    out.covariance = regularised(spread.trace() > 0.0 ? spread : last_.covariance);
  } else if (options_.fusion != "information" ||
             !fuseInformation(prior_mean, by_index, out.weights, trust, &out)) {
    fuseAverage(by_index, out.weights, &out);
  }
  if (!out.mean.allFinite() || !out.covariance.allFinite()) {
    // Never kept: the next prediction starts from last_. The master predicts only.
    out.mean = prior_mean;
    out.covariance = regularised(last_.covariance);
  }
  out.feedback.mean = out.mean;
  out.feedback.covariance = out.covariance;
  last_ = out;
  return out;
}

bool DpfMaster::fuseInformation(const Pose2& prior_mean,
                                const std::vector<const DpfLocalEstimate*>& locals,
                                const std::vector<double>& weights,
                                const std::vector<double>& trusts, DpfMasterOutput* out) const {
  const int n = static_cast<int>(locals.size());
  Eigen::Matrix3d prior_cov = Eigen::Matrix3d::Zero();
  for (int i = 0; i < n; ++i) {
    if (weights[i] > 0.0) prior_cov += weights[i] * locals[i]->prior_covariance;
  }
  // Linearised at the master's prior: information and information vector relative to it.
  Eigen::Matrix3d information = regularised(prior_cov).inverse();
  Eigen::Vector3d vector = Eigen::Vector3d::Zero();
  Eigen::Vector3d shift = Eigen::Vector3d::Zero();
  for (int i = 0; i < n; ++i) {
    const DpfLocalEstimate& e = *locals[i];
    const double trust = trusts[i];
    if (e.innovations == 0 || !(trust > 0.0) || !(weights[i] > 0.0)) continue;  // nothing learned
    const Eigen::Matrix3d posterior_info = regularised(e.covariance).inverse();
    const Eigen::Matrix3d prior_info = regularised(e.prior_covariance).inverse();
    // What it learned: posterior minus prior information, and the matching information
    // vector, both kept only along the directions where it gained information (a particle
    // posterior can be broader than its prior along some direction; the vector's component
    // there is not information, and dividing it by a clipped, near-zero gain would throw the
    // master's estimate far away). Along those other directions the local's weighting may
    // still have moved its cloud (e.g. at a loop closure): the master takes that move of the
    // posterior mean itself, weighted by w_i (so bounded by the largest move), not a vector.
    Eigen::Matrix3d gained, not_gained;
    Eigen::Vector3d gained_vector;
    gainedInformation(posterior_info, prior_info,
                      posterior_info * difference(e.mean, prior_mean) -
                          prior_info * difference(e.prior_mean, prior_mean),
                      &gained, &gained_vector, &not_gained);
    information += trust * gained;
    vector += trust * gained_vector;
    shift += weights[i] * not_gained * difference(e.mean, e.prior_mean);
  }
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(information);
  if (!(eigen.eigenvalues().minCoeff() > 0.0) || !information.allFinite()) return false;
  out->covariance = information.inverse();
  const Eigen::Vector3d correction = out->covariance * vector;
  if (!correction.allFinite() || !shift.allFinite()) return false;
  out->mean = prior_mean + correction + shift;
  out->mean.z() = wrapAngle(out->mean.z());
  return true;
}

}  // namespace core
}  // namespace rbpf_slam
