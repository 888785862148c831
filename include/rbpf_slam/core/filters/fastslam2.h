#pragma once
// FastSLAM 2.0 (Montemerlo et al. 2003) over point and line landmarks: the pose proposal
// is refined by each associated observation, each landmark is a 2D EKF, association is
// per-particle maximum likelihood with a Mahalanobis gate (or, with association.sample, drawn
// among the landmarks inside the gate by likelihood).

#include <memory>
#include <vector>

#include "rbpf_slam/core/filters/estimator_rule.h"
#include "rbpf_slam/core/filters/landmark_map.h"
#include "rbpf_slam/core/filters/measurement_models.h"
#include "rbpf_slam/core/filters/observation.h"
#include "rbpf_slam/core/filters/slam_filter.h"
#include "rbpf_slam/core/motion/motion_model.h"
#include "rbpf_slam/core/random.h"

namespace rbpf_slam {
namespace core {

/// A particle's past pose at one update, linked to the one before; particles that share an
/// ancestor share its history (resampling copies a pointer, not the path).
/// Each node also keeps its depth (0 at the path's first pose) and a jump to an ancestor
/// (skew-binary jump pointers), so that the pose at any depth is found in O(log depth)
/// (ancestorAt) instead of walking the path.
struct PathNode {
  PathNode(const Pose2& p, std::shared_ptr<PathNode> previous);
  ~PathNode();  // unlinks iteratively: a path of a million updates must not recurse
  PathNode(const PathNode&) = delete;
  PathNode& operator=(const PathNode&) = delete;
  Pose2 pose;
  std::shared_ptr<PathNode> parent;
  std::size_t depth = 0;
  const PathNode* jump = this;  // an ancestor (itself at depth 0); kept alive through parent
};

/// The ancestor of node (or node itself) at depth (<= node->depth), in O(log node->depth).
const PathNode* ancestorAt(const PathNode* node, std::size_t depth);

/// One hypothesis: a pose, its own map, and the path that led to it (FastSLAM estimates the
/// posterior over whole paths: the best particle's path is the map's trajectory).
struct Particle {
  Pose2 pose = Pose2::Zero();
  double log_weight = 0.0;
  std::shared_ptr<LandmarkMap> map = std::make_shared<LandmarkMap>();
  std::shared_ptr<PathNode> path;  // pose at each update(), newest first; null before any
};

class FastSlam2 : public SlamFilter {
 public:
  explicit FastSlam2(const FilterOptions& options);

  std::string variant() const override { return "fastslam2"; }
  void reset(const Pose2& initial_pose) override;
  void predict(const MotionInput& motion) override;
  UpdateStats update(const FeatureSet& features) override;
  PoseEstimate estimate() const override;
  std::vector<LandmarkEstimate> landmarks() const override;
  std::vector<WeightedPose> particles() const override;
  FilterStats stats() const override;
  bool resetPose(const Pose2& pose, const Eigen::Matrix3d& covariance) override;
  bool loadMap(const std::vector<LandmarkEstimate>& landmarks) override;
  bool setMapping(bool enabled) override;
  bool mapping() const { return mapping_; }

  /// Feature set -> observations with the configured noise; counts rejected features.
  std::vector<Observation> prepare(const FeatureSet& features, int* rejected) const;
  const std::vector<Particle>& particleSet() const { return particles_; }
  int bestParticle() const;
  /// The pose at every update() since the last reset, oldest first, of the particle that now
  /// carries the most weight (its map is landmarks()); resetPose() starts a new path.
  std::vector<Pose2> bestPath() const override;
  /// Picks the poses through the path's jump pointers: O(max_poses log T), not O(T).
  std::vector<Pose2> bestPathSample(std::size_t max_poses, std::size_t* length) const override;

 protected:
  /// A FastSLAM 2.0 whose proposal and landmark updates follow `rule` (e.g. H-infinity).
  FastSlam2(const FilterOptions& options, std::unique_ptr<EstimatorRule> rule);

  /// Outcome of incorporating all observations into one particle.
  struct ParticleUpdate {
    int associated = 0;
    int created = 0;
    int fallbacks = 0;  // H-infinity corrections that fell back to the EKF
    int removed = 0;    // landmarks dropped by existence management
    bool relocalized = false;  // the proposal started from a searched pose correction
    std::vector<double> nis;   // v^T S^-1 v of the proposal's matches (EstimatorRule feedback)
  };
  /// The proposal of one particle before drawing: the prior refined by each associated
  /// observation in turn (Montemerlo 2003, eq. 3.7), with the marginal log-likelihood.
  struct Proposal {
    Pose2 mean = Pose2::Zero();
    Eigen::Matrix3d cov = Eigen::Matrix3d::Identity();
    double log_likelihood = 0.0;
    std::vector<std::pair<int, int>> matched;  // (observation, landmark index)
    std::vector<int> fresh;                    // observations that start new landmarks
    std::vector<double> nis;  // v^T S^-1 v of the matches (when the rule learns from them)
  };
  Proposal refineProposal(const LandmarkMap& map, const Pose2& prior_mean,
                          const Eigen::Matrix3d& prior_cov,
                          const std::vector<Observation>& observations,
                          Rng* rng = nullptr) const;
  /// When `proposal` (from the motion prior) leaves most observations unmatched, searches a
  /// pose correction (relocalization.h); if the proposal from the corrected pose associates
  /// clearly more, replaces *proposal with it, sets *prior_mean to the corrected pose and
  /// returns true. Off unless options.relocalization.enabled.
  bool relocalize(const LandmarkMap& map, const Eigen::Matrix3d& motion_cov,
                  const std::vector<Observation>& observations, Pose2* prior_mean,
                  Proposal* proposal) const;
  /// FastSLAM 2.0 step for one particle from its predicted pose and motion covariance.
  ParticleUpdate updateParticle(Particle* particle, const Pose2& predicted_mean,
                                const Eigen::Matrix3d& motion_cov,
                                const std::vector<Observation>& observations);
  /// Normalises weights, resamples when Neff is low; fills stats.
  void weighAndResample(UpdateStats* stats);

  /// Association result for one observation against one particle's map.
  struct Match {
    int index = -1;           // landmark index, -1 when none within the gate
    double distance2 = 1e300;  // smallest Mahalanobis^2
    Prediction prediction;
    Eigen::Matrix2d landmark_innovation_cov = Eigen::Matrix2d::Identity();
  };
  /// Maximum-likelihood landmark for an observation among those the map's spatial index
  /// offers near it.
  /// With `gated`, also every landmark inside the association gate, in index order.
  /// Landmarks listed in `exclude` (e.g. matched by another feature of the frame) are skipped.
  Match associate(const LandmarkMap& map, const Pose2& pose, const Eigen::Matrix3d& pose_cov,
                  const Observation& observation, std::vector<Match>* gated = nullptr,
                  const std::vector<int>* exclude = nullptr) const;
  /// The same by a scan of every landmark, O(N): the reference associate() must equal.
  Match associateByScan(const LandmarkMap& map, const Pose2& pose,
                        const Eigen::Matrix3d& pose_cov, const Observation& observation) const;
  /// Pre-gate (cheap geometric test) before the Mahalanobis distance: a line's normal angle
  /// and rho within these of the observed line's, a point within this radius.
  static constexpr double kLinePregateAngleRad = 0.5;
  static constexpr double kLinePregateRhoM = 1.5;
  static double pointPregateRadius(const Observation& o) { return 1.5 + 0.2 * o.z.x(); }
  /// An observation in the map frame at a pose: the point or line, and a line's extent.
  struct ObservationInMap {
    Eigen::Vector2d value = Eigen::Vector2d::Zero();
    Eigen::Vector2d start = Eigen::Vector2d::Zero();
    Eigen::Vector2d end = Eigen::Vector2d::Zero();
  };
  static ObservationInMap inMap(const Pose2& pose, const Observation& observation);
  /// The maximum-likelihood match among `candidates` (every landmark when null).
  Match associateAmong(const LandmarkMap& map, const Pose2& pose, const Eigen::Matrix3d& pose_cov,
                       const Observation& observation, const ObservationInMap& seen,
                       const std::vector<int>* candidates,
                       std::vector<Match>* gated = nullptr) const;
  /// The order in which refineProposal takes the observations: the frame's, except that with
  /// association.exclusive the point features without a known id swap places among themselves
  /// into ascending order of their best match's Mahalanobis distance at the prior pose (the
  /// closest fit takes its landmark first; ties keep the frame's order). Empty when that is
  /// the frame's order (always without the option: nothing is allocated on the default path).
  std::vector<size_t> associationOrder(const LandmarkMap& map, const Pose2& prior_mean,
                                       const Eigen::Matrix3d& prior_cov,
                                       const std::vector<Observation>& observations) const;
  /// log N(z; predicted z, H_pose P H_pose^T + scale (H_lm Sigma H_lm^T + R)) of a match.
  double matchLogLikelihood(const Eigen::Matrix3d& pose_cov, const Observation& observation,
                            const Match& match) const;
  /// The weight's factor (log) of a feature taken as a new landmark: as if observed at the
  /// new-landmark threshold, its noise scaled as a match's.
  double newLandmarkLogLikelihood(const Observation& observation) const;
  void addLandmark(LandmarkMap* map, const Pose2& pose, const Observation& observation);
  /// The heading prior's part of a step, the same for every particle: drift tracking's turn of
  /// every particle's predicted heading (0 without it), and the walls that measure the heading,
  /// picked once at the filter's predicted heading after that turn.
  struct HeadingStep {
    double drift_turn = 0.0;
    HeadingPrior::LineSelection lines;
  };
  /// Predicts and corrects the drift (when tracked) with this step's motion and observations.
  HeadingStep headingStep(const std::vector<Observation>& observations, const MotionInput& motion);
  /// Walls along the building's axes measure the heading (heading_prior.h): conditions the
  /// pose Gaussian (mean, cov) on the step's selected lines when they qualify and returns the
  /// log weight factor (0 when they do not).
  double conditionOnWalls(const HeadingPrior::LineSelection& lines, Pose2* mean,
                          Eigen::Matrix3d* cov);

  /// Returns false when the correction fell back to the EKF.
  bool updateLandmark(LandmarkMap* map, const Match& match, const Pose2& pose,
                      const Observation& observation, double* log_likelihood);

  const FilterOptions options_;
  const bool soft_ambiguous_;  // association.ambiguous_weight == "soft", compared once
  std::unique_ptr<MotionModel> motion_model_;
  std::unique_ptr<EstimatorRule> rule_;
  Rng rng_;
  std::vector<Particle> particles_;
  std::vector<double> weights_;  // normalised, same order as particles_
  /// After a resampling (equal weights), the index of a copy of the particle that was the most
  /// probable before it: bestParticle() then names it instead of whichever copy came first.
  /// -1 when the weights tell (no resampling since they were computed).
  int resampled_best_ = -1;
  PendingMotion pending_motion_;
  HeadingPrior heading_prior_;
  int next_landmark_id_ = 0;
  bool mapping_ = true;  // false: localization only, the maps stay as they are
  int step_ = 0;
  double last_drift_turn_ = 0.0;  // HeadingStep::drift_turn of the latest update()
  FilterStats stats_;
};

}  // namespace core
}  // namespace rbpf_slam
