#include "rbpf_slam/io/slam_config.h"

#include <cmath>
#include <sstream>
#include <stdexcept>

#include "rbpf_slam/io/grid_map_file.h"
#include "rbpf_slam/io/landmark_file.h"

namespace rbpf_slam {
namespace io {
namespace {

// The readers below only map keys to options and check types: every range and every allowed
// word is checked once, by the core's validate() of the options (parseSlamConfigTree's
// validateAs), which programmatic users of the core get too. Only the ROS-side options, which
// the core never sees, are range-checked here.

void readMotion(YamlSection section, core::MotionOptions* o) {
  section.read("model", &o->model);
  section.read("alpha1", &o->alpha1);
  section.read("alpha2", &o->alpha2);
  section.read("alpha3", &o->alpha3);
  section.read("alpha4", &o->alpha4);
  section.read("wheel_base_m", &o->wheel_base_m);
  section.read("wheel_alpha1", &o->wheel_alpha1);
  section.read("wheel_alpha2", &o->wheel_alpha2);
  section.read("min_sigma_xy_m", &o->min_sigma_xy_m);
  section.read("min_sigma_theta_rad", &o->min_sigma_theta_rad);
  section.read("sigma_xy_per_sqrt_s", &o->sigma_xy_per_sqrt_s);
  section.read("sigma_theta_per_sqrt_s", &o->sigma_theta_per_sqrt_s);
  section.finish();
}

void readAssociation(YamlSection section, core::AssociationOptions* o) {
  section.read("gate_chi2", &o->gate_chi2);
  section.read("new_landmark_chi2", &o->new_landmark_chi2);
  section.read("line_overlap_margin_m", &o->line_overlap_margin_m);
  section.read("sample", &o->sample);
  section.read("sample_weight", &o->sample_weight);
  section.read("ambiguous_weight", &o->ambiguous_weight);
  section.read("exclusive", &o->exclusive);
  section.finish();
}

void readRelocalization(YamlSection section, core::RelocalizationOptions* o) {
  section.read("enabled", &o->enabled);
  section.read("search_xy_m", &o->search_xy_m);
  section.read("search_theta_rad", &o->search_theta_rad);
  section.read("min_unmatched", &o->min_unmatched);
  section.read("min_unmatched_ratio", &o->min_unmatched_ratio);
  section.read("min_matches", &o->min_matches);
  section.read("min_gain", &o->min_gain);
  section.read("min_matched_ratio", &o->min_matched_ratio);
  section.read("min_landmark_age", &o->min_landmark_age);
  section.read("line_tolerance_m", &o->line_tolerance_m);
  section.read("angle_tolerance_rad", &o->angle_tolerance_rad);
  section.read("point_tolerance_m", &o->point_tolerance_m);
  section.read("min_information", &o->min_information);
  section.finish();
}

void readRobust(YamlSection section, core::RobustOptions* o) {
  section.read("ancestor_sets", &o->ancestor_sets);
  section.read("ancestor_spacing_steps", &o->ancestor_spacing_steps);
  section.read("window_steps", &o->window_steps);
  section.read("min_old_observations", &o->min_old_observations);
  section.read("intermediate_path", &o->intermediate_path);
  section.read("path_iterations", &o->path_iterations);
  section.finish();
}

void readTracker(YamlSection section, core::LandmarkTrackerOptions* o) {
  section.read("gate_chi2", &o->gate_chi2);
  section.read("new_landmark_chi2", &o->new_landmark_chi2);
  section.read("forget_after_steps", &o->forget_after_steps);
  section.read("forget_distance_m", &o->forget_distance_m);
  section.read("max_landmarks", &o->max_landmarks);
  section.read("line_overlap_margin_m", &o->line_overlap_margin_m);
  section.finish();
}

void readMeasurement(YamlSection section, core::MeasurementOptions* o) {
  section.read("use_feature_covariance", &o->use_feature_covariance);
  section.read("sigma_range_m", &o->sigma_range_m);
  section.read("sigma_bearing_rad", &o->sigma_bearing_rad);
  section.read("sigma_rho_m", &o->sigma_rho_m);
  section.read("sigma_theta_rad", &o->sigma_theta_rad);
  section.read("covariance_inflation", &o->covariance_inflation);
  section.read("landmark_iterations", &o->landmark_iterations);
  section.finish();
}

void readExistence(YamlSection section, core::ExistenceOptions* o) {
  section.read("min_observations", &o->min_observations);
  section.read("tentative_updates", &o->tentative_updates);
  section.read("visible_range_m", &o->visible_range_m);
  section.read("visible_min_range_m", &o->visible_min_range_m);
  section.read("visible_fov_rad", &o->visible_fov_rad);
  section.read("max_count", &o->max_count);
  section.read("sighting_count", &o->sighting_count);
  section.read("merge_chi2", &o->merge_chi2);
  section.read("merge_min_observations", &o->merge_min_observations);
  section.read("merge_max_distance_m", &o->merge_max_distance_m);
  section.finish();
}

void readHeadingPrior(YamlSection section, core::HeadingPriorOptions* o) {
  section.read("enabled", &o->enabled);
  section.read("learn_direction", &o->learn_direction);
  section.read("learn_updates", &o->learn_updates);
  section.read("min_family_fraction", &o->min_family_fraction);
  section.read("max_skew_rad", &o->max_skew_rad);
  section.read("direction_rad", &o->direction_rad);
  section.read("tolerance_rad", &o->tolerance_rad);
  section.read("sigma_rad", &o->sigma_rad);
  section.read("min_lines", &o->min_lines);
  section.read("outlier_ratio", &o->outlier_ratio);
  section.read("drift_tracking", &o->drift_tracking);
  section.read("drift_per_rad", &o->drift_per_rad);
  section.read("drift_per_m", &o->drift_per_m);
  section.finish();
}

void readHinf(YamlSection section, core::HinfOptions* o) {
  // Config values are finite (a large gamma, e.g. 1e12, is the EKF for any realistic covariance).
  section.read("mode", &o->mode);
  section.read("theta_pose", &o->theta_pose);
  section.read("theta_landmark", &o->theta_landmark);
  section.read("adapt_steps", &o->adapt_steps);
  section.read("gamma_position", &o->gamma_position);
  section.read("gamma_heading", &o->gamma_heading);
  section.read("gamma_landmark", &o->gamma_landmark);
  section.read("gain", &o->gain);
  section.read("proposal_covariance", &o->proposal_covariance);
  section.read("weight", &o->weight);
  section.read("max_inflation", &o->max_inflation);
  section.finish();
}

// Multi-filter SMC and EKF-SLAM (Yuen and MacDonald).
void readLineSlam(YamlSection& top, core::FilterOptions* f) {
  YamlSection association = top.section("line_association");
  association.read("h_similar_feature", &f->line_association.h_similar_feature);
  association.read("c_w1", &f->line_association.c_w1);
  association.read("c_w2", &f->line_association.c_w2);
  association.read("compare_at", &f->line_association.compare_at);
  association.finish();
  YamlSection multifilter = top.section("multifilter");
  multifilter.read("line_particles", &f->multifilter.line_particles);
  multifilter.read("c_m1", &f->multifilter.c_m1);
  multifilter.read("c_m2", &f->multifilter.c_m2);
  multifilter.read("init_sigma_m", &f->multifilter.init_sigma_m);
  multifilter.read("init_sigma_rad", &f->multifilter.init_sigma_rad);
  multifilter.read("roughening_m", &f->multifilter.roughening_m);
  multifilter.read("roughening_rad", &f->multifilter.roughening_rad);
  multifilter.finish();
  YamlSection ekf = top.section("ekf");
  ekf.read("innovation_gate_chi2", &f->ekf.innovation_gate_chi2);
  ekf.finish();
}

void readGrid(YamlSection section, core::GridOptions* o) {
  section.read("resolution_m", &o->resolution_m);
  section.read("size_x_m", &o->size_x_m);
  section.read("size_y_m", &o->size_y_m);
  section.read("max_size_m", &o->max_size_m);
  section.read("tile_cells", &o->tile_cells);
  section.read("log_odds_occupied", &o->log_odds_occupied);
  section.read("log_odds_free", &o->log_odds_free);
  section.read("log_odds_clamp", &o->log_odds_clamp);
  section.read("cone_arc_thickness_m", &o->cone_arc_thickness_m);
  section.read("cone_max_range_m", &o->cone_max_range_m);
  section.read("max_range_margin_m", &o->max_range_margin_m);
  section.read("no_echo_free_range_m", &o->no_echo_free_range_m);
  section.read("cone_fov_rad", &o->cone_fov_rad);
  section.read("laser_max_range_m", &o->laser_max_range_m);
  section.read("laser_no_return_free_m", &o->laser_no_return_free_m);
  section.read("laser_beam_step", &o->laser_beam_step);
  section.read("match_f", &o->match_f);
  section.read("match_occupied_weight", &o->match_occupied_weight);
  section.read("match_free_weight", &o->match_free_weight);
  section.read("match_model", &o->match_model);
  section.read("field_sigma_m", &o->field_sigma_m);
  section.read("field_max_dist_m", &o->field_max_dist_m);
  section.read("field_z_hit", &o->field_z_hit);
  section.read("spread_candidates", &o->spread_candidates);
  section.read("spread_match_f", &o->spread_match_f);
  section.read("spread_gathered_m", &o->spread_gathered_m);
  section.read("kld_min_particles", &o->kld_min_particles);
  section.read("kld_error", &o->kld_error);
  section.read("kld_z", &o->kld_z);
  section.read("kld_bin_xy_m", &o->kld_bin_xy_m);
  section.read("kld_bin_theta_rad", &o->kld_bin_theta_rad);
  section.finish();
}

void readDpf(YamlSection section, core::DpfOptions* o) {
  section.read("local_filters", &o->local_filters);
  section.read("threads", &o->threads);
  section.read("weighting", &o->weighting);
  section.read("fusion", &o->fusion);
  section.read("mix_innovation", &o->mix_innovation);
  section.read("adaptive_covariance", &o->adaptive_covariance);
  section.read("feedback", &o->feedback);
  section.read("feedback_inflation", &o->feedback_inflation);
  section.read("feedback_mode", &o->feedback_mode);
  section.read("innovation_smoothing", &o->innovation_smoothing);
  section.read("fault_nis", &o->fault_nis);
  section.read("fault_neff_ratio", &o->fault_neff_ratio);
  section.read("fault_prior_chi2", &o->fault_prior_chi2);
  section.read("suspect_weight", &o->suspect_weight);
  section.read("isolate_after_steps", &o->isolate_after_steps);
  section.read("readmit_after_steps", &o->readmit_after_steps);
  section.read("step_timeout_s", &o->step_timeout_s);
  section.finish();
}

void readFault(YamlSection section, core::FaultInjectorOptions* o) {
  section.read("enabled", &o->enabled);
  section.read("start_step", &o->start_step);
  section.read("local_index", &o->local_index);
  section.read("sigma_xy_m", &o->sigma_xy_m);
  section.read("sigma_theta_rad", &o->sigma_theta_rad);
  section.finish();
}

void readLaser(YamlSection section, core::LaserExtractorOptions* o) {
  section.read("method", &o->method);
  section.read("sigma_range_m", &o->sigma_range_m);
  section.read("max_mean_sq_residual_m2", &o->max_mean_sq_residual_m2);
  section.read("split_distance_m", &o->split_distance_m);
  section.read("max_point_gap_m", &o->max_point_gap_m);
  section.read("min_points_per_line", &o->min_points_per_line);
  section.read("min_line_length_m", &o->min_line_length_m);
  section.read("merge_angle_rad", &o->merge_angle_rad);
  section.read("merge_distance_m", &o->merge_distance_m);
  section.read("extract_corners", &o->extract_corners);
  section.read("corner_min_angle_rad", &o->corner_min_angle_rad);
  section.read("corner_max_gap_m", &o->corner_max_gap_m);
  section.read("extract_clusters", &o->extract_clusters);
  section.read("cluster_max_width_m", &o->cluster_max_width_m);
  section.read("cluster_min_points", &o->cluster_min_points);
  section.read("cluster_isolation_m", &o->cluster_isolation_m);
  section.read("sigma_point_range_m", &o->sigma_point_range_m);
  section.read("sigma_point_bearing_rad", &o->sigma_point_bearing_rad);
  section.read("max_range_m", &o->max_range_m);
  section.finish();
}

void readScanMatching(YamlSection section, core::ScanMatcherOptions* o) {
  section.read("enabled", &o->enabled);
  section.read("max_iterations", &o->max_iterations);
  section.read("max_correspondence_m", &o->max_correspondence_m);
  section.read("min_correspondence_m", &o->min_correspondence_m);
  section.read("min_inlier_ratio", &o->min_inlier_ratio);
  section.read("max_residual_rms_m", &o->max_residual_rms_m);
  section.read("max_range_m", &o->max_range_m);
  section.read("rotation_guess_rad", &o->rotation_guess_rad);
  section.read("search_below_inlier_ratio", &o->search_below_inlier_ratio);
  section.read("search_step_rad", &o->search_step_rad);
  section.read("min_information", &o->min_information);
  section.read("max_correction_m", &o->max_correction_m);
  section.read("max_correction_rad", &o->max_correction_rad);
  section.read("noise_scale", &o->noise_scale);
  section.read("degenerate_noise_scale", &o->degenerate_noise_scale);
  section.read("submap_scans", &o->submap_scans);
  section.read("prior_weight_xy", &o->prior_weight_xy);
  section.read("prior_weight_theta", &o->prior_weight_theta);
  section.finish();
}

void readSonar(YamlSection section, core::SonarExtractorOptions* o) {
  section.read("min_range_m", &o->min_range_m);
  section.read("max_range_m", &o->max_range_m);
  section.read("max_range_margin_m", &o->max_range_margin_m);
  section.read("cone_rad", &o->cone_rad);
  section.read("sigma_range_m", &o->sigma_range_m);
  section.read("reject_isolated", &o->reject_isolated);
  section.read("isolated_jump_m", &o->isolated_jump_m);
  section.read("window_distance_m", &o->window_distance_m);
  section.read("window_time_s", &o->window_time_s);
  section.read("max_echoes", &o->max_echoes);
  section.read("min_echo_spacing_m", &o->min_echo_spacing_m);
  section.read("extract_distance_m", &o->extract_distance_m);
  section.read("extract_angle_rad", &o->extract_angle_rad);
  section.read("extract_lines", &o->extract_lines);
  section.read("hough_rho_step_m", &o->hough_rho_step_m);
  section.read("hough_theta_step_rad", &o->hough_theta_step_rad);
  section.read("min_line_echoes", &o->min_line_echoes);
  section.read("min_line_length_m", &o->min_line_length_m);
  section.read("line_inlier_m", &o->line_inlier_m);
  section.read("cone_margin_rad", &o->cone_margin_rad);
  section.read("line_max_incidence_rad", &o->line_max_incidence_rad);
  section.read("max_line_sigma_rho_m", &o->max_line_sigma_rho_m);
  section.read("max_line_sigma_theta_rad", &o->max_line_sigma_theta_rad);
  section.read("line_sigma_rho_m", &o->line_sigma_rho_m);
  section.read("line_sigma_theta_rad", &o->line_sigma_theta_rad);
  section.read("line_theta_per_length_m", &o->line_theta_per_length_m);
  section.read("extract_points", &o->extract_points);
  section.read("point_cell_m", &o->point_cell_m);
  section.read("min_point_echoes", &o->min_point_echoes);
  section.read("min_point_baseline_m", &o->min_point_baseline_m);
  section.read("point_inlier_m", &o->point_inlier_m);
  section.read("max_point_sigma_m", &o->max_point_sigma_m);
  section.read("max_contradiction_ratio", &o->max_contradiction_ratio);
  section.read("point_sigma_range_m", &o->point_sigma_range_m);
  section.read("point_sigma_bearing_rad", &o->point_sigma_bearing_rad);
  section.finish();
}

void readRos(YamlSection& top, RosOptions* o) {
  top.read("map_frame", &o->map_frame);
  top.read("odom_frame", &o->odom_frame);
  top.read("base_frame", &o->base_frame);
  top.read("scan_topic", &o->scan_topic);
  top.read("features_topic", &o->features_topic);
  top.readNames("sonar_topic", &o->sonar_topics);
  top.read("sonar_cloud_topic", &o->sonar_cloud_topic);
  top.read("sonar_source", &o->sonar_source, {"range", "cloud"});
  top.read("sonar_frame_prefix", &o->sonar_frame_prefix);
  top.read("sonar_cloud_fov", &o->sonar_cloud_fov, 1e-3, 3.0);
  top.read("sonar_cloud_max_range", &o->sonar_cloud_max_range, 0.1, 100.0);
  top.read("transform_publish_period", &o->transform_publish_period, 0.0, 10.0);
  top.read("transform_tolerance", &o->transform_tolerance, 0.0, 10.0);
  top.read("trajectory_publish_period", &o->trajectory_publish_period, 0.0, 3600.0);
  top.read("queue_size", &o->queue_size, 1, 10000);
  top.read("publish_particles", &o->publish_particles);
  top.read("map_save_prefix", &o->map_save_prefix);
  top.read("map_update_period", &o->map_update_period, 0.0, 3600.0);
  top.read("map_resolution", &o->map_resolution, 1e-3, 10.0);
  // tf2 frame names carry no leading '/' (ROS 1 configs often still write one).
  for (std::string* frame :
       {&o->map_frame, &o->odom_frame, &o->base_frame, &o->sonar_frame_prefix}) {
    if (!frame->empty() && frame->front() == '/') frame->erase(0, 1);
  }
  const std::pair<const char*, const std::string*> frames[] = {
      {"map_frame", &o->map_frame}, {"odom_frame", &o->odom_frame}, {"base_frame", &o->base_frame}};
  for (const auto& [key, frame] : frames) {
    if (frame->empty()) {
      throw ConfigError(top.where(key) + " is empty (a frame name is needed; a lone '/' is "
                                         "empty once its leading '/' is dropped)");
    }
  }
}

/// Runs a core validate() and turns its message into a ConfigError naming the source.
template <typename Options>
void validateAs(const Options& options, const std::string& source) {
  try {
    core::validate(options);
  } catch (const std::invalid_argument& e) {
    throw ConfigError(source + ": " + e.what());
  }
}

SlamConfig parseSlamConfigTree(const YAML::Node& root, const std::string& source) {
  SlamConfig config;
  YamlSection top(root, source);
  top.read("frontend", &config.frontend, {"laser", "sonar", "features"});
  core::FilterOptions& f = config.filter;
  top.read("variant", &f.variant);
  top.read("particles", &f.particles);
  top.read("seed", &f.seed);
  top.read("resample_threshold", &f.resample_threshold);
  top.read("proposal_sample_scale", &f.proposal_sample_scale);
  top.read("use_points", &f.use_points);
  top.read("use_lines", &f.use_lines);
  readMotion(top.section("motion"), &f.motion);
  readAssociation(top.section("association"), &f.association);
  readMeasurement(top.section("measurement"), &f.measurement);
  readRobust(top.section("robust"), &f.robust);
  readTracker(top.section("tracker"), &f.tracker);
  readExistence(top.section("existence"), &f.existence);
  readRelocalization(top.section("relocalization"), &f.relocalization);
  readHinf(top.section("hinf"), &f.hinf);
  readHeadingPrior(top.section("heading_prior"), &f.heading_prior);
  readLineSlam(top, &f);
  readGrid(top.section("grid"), &f.grid);
  readDpf(top.section("dpf"), &f.dpf);
  readFault(top.section("fault"), &f.dpf.fault);
  YamlSection ensemble = top.section("ensemble");
  ensemble.read("members", &f.ensemble.members);
  ensemble.read("rank_by", &f.ensemble.rank_by);
  ensemble.read("switch_margin", &f.ensemble.switch_margin);
  ensemble.read("consensus_period", &f.ensemble.consensus_period);
  ensemble.read("consensus_margin_m", &f.ensemble.consensus_margin_m);
  ensemble.read("consensus_max_poses", &f.ensemble.consensus_max_poses);
  ensemble.finish();
  readLaser(top.section("laser_features"), &config.laser);
  readScanMatching(top.section("scan_matching"), &config.scan_matching);
  readSonar(top.section("sonar_features"), &config.sonar);
  core::SessionOptions& s = config.session;
  top.read("linear_update", &s.linear_update_m);
  top.read("angular_update", &s.angular_update_rad);
  top.read("max_time_gap", &s.max_time_gap_s);
  top.read("max_odometry_jump", &s.max_odometry_jump_m);
  top.read("gap_action", &s.gap_action);
  top.read("gap_noise_inflation", &s.gap_noise_inflation);
  top.read("reset_on_time_jump_back", &s.reset_on_time_jump_back_s);
  top.read("reset_after_frames_back", &s.reset_after_frames_back);
  top.read("filter_origin", &s.filter_origin);
  YamlSection smoothing = top.section("smoothing");
  smoothing.read("enabled", &config.smoothing.enabled);
  smoothing.read("rounds", &config.smoothing.rounds);
  smoothing.read("max_iterations", &config.smoothing.max_iterations);
  smoothing.read("gate_chi2", &config.smoothing.gate_chi2);
  smoothing.read("huber_k", &config.smoothing.huber_k);
  smoothing.read("min_sightings", &config.smoothing.min_sightings);
  smoothing.read("member_landmark_cost", &config.smoothing.member_landmark_cost);
  smoothing.read("member_consensus_margin", &config.smoothing.member_consensus_margin);
  smoothing.read("merge_max_cost", &config.smoothing.merge_max_cost);
  smoothing.read("merge_max_distance_m", &config.smoothing.merge_max_distance_m);
  smoothing.finish();
  s.keep_frames = config.smoothing.enabled;
  top.read("map_file", &config.map_file);
  top.read("localization_only", &config.localization_only);
  top.read("global_localization", &config.global_localization);
  readRos(top, &config.ros);
  top.finish();
  if (config.localization_only && config.map_file.empty()) {
    throw ConfigError(source +
                      ": localization_only = true needs map_file (written by "
                      "~save_map or offline_slam: the landmarks YAML, or for grid_pf "
                      "map_server's map.yaml)");
  }
  if (config.global_localization && !config.localization_only) {
    throw ConfigError(source +
                      ": global_localization = true needs localization_only: true (and grid_pf "
                      "with map_file naming map_server's map.yaml): each of thousands of "
                      "particles would map its own copy from a random pose");
  }
  if (config.smoothing.enabled && config.filter.use_lines) {
    throw ConfigError(source + ": smoothing.enabled re-estimates point landmarks only: it needs "
                               "use_lines: false (a line map would no longer fit the smoothed "
                               "path)");
  }
  const core::MotionOptions& m = config.filter.motion;
  if (config.smoothing.enabled &&
      !((m.min_sigma_xy_m > 0.0 || m.sigma_xy_per_sqrt_s > 0.0) &&
        (m.min_sigma_theta_rad > 0.0 || m.sigma_theta_per_sqrt_s > 0.0))) {
    // A still robot's odometry increment would get no noise at all, which the smoother's
    // least squares cannot weigh: refused now rather than after the run.
    throw ConfigError(source + ": smoothing.enabled needs motion noise floors: "
                               "motion.min_sigma_xy_m (or sigma_xy_per_sqrt_s) and "
                               "motion.min_sigma_theta_rad (or sigma_theta_per_sqrt_s) > 0, or "
                               "smoothing.enabled: false (e.g. for an odometry-only run)");
  }
  if (config.filter.variant == "grid_pf" && config.frontend == "features") {
    throw ConfigError(source +
                      ": variant grid_pf maps raw laser or sonar readings: frontend "
                      "must be laser or sonar, not features");
  }
  validateAs(config.filter, source);
  validateAs(config.session, source);
  validateAs(config.laser, source);
  validateAs(config.scan_matching, source);
  validateAs(config.sonar, source);
  validateAs(config.smoothing, source);
  return config;
}

}  // namespace

SlamConfig parseSlamConfig(const YAML::Node& root, const std::string& source) {
  try {
    return parseSlamConfigTree(root, source);
  } catch (const YAML::Exception& e) {  // a shape the readers did not expect (fuzzing found some)
    throw ConfigError(source + ": malformed config: " + e.what());
  }
}

SlamConfig loadSlamConfig(const std::string& path, const std::vector<std::string>& overrides) {
  YAML::Node root;
  try {
    root = YAML::LoadFile(path);
  } catch (const YAML::BadFile&) {
    throw ConfigError(path + ": cannot open the config file");
  } catch (const YAML::Exception& e) {
    throw ConfigError(path + ": not valid YAML: " + e.what());
  } catch (const std::exception& e) {  // a directory, an unreadable file
    throw ConfigError(path + ": cannot read the config file: " + e.what());
  }
  if (root.IsNull()) root = YAML::Node(YAML::NodeType::Map);
  if (!root.IsMap()) {  // before the overrides, which would index (or turn) it into a map
    throw ConfigError(path + ": the top level must be a map of keys (key: value lines), not a " +
                      (root.IsSequence() ? "list" : "single value"));
  }
  for (const auto& assignment : overrides) applyOverride(&root, assignment);
  // A value out of range may come from an override, not from the file: name both.
  std::string source = path;
  for (size_t i = 0; i < overrides.size(); ++i) {
    source += (i == 0 ? " (with --set " : ", --set ") + overrides[i];
  }
  if (!overrides.empty()) source += ")";
  return parseSlamConfig(root, source);
}

namespace {

/// What a map file holds, by its keys: a map_server map has `image`, a landmarks YAML
/// `landmarks`; anything else (unreadable, not YAML) is left to the reader to explain.
enum class MapFileKind { kGrid, kLandmarks, kOther };
MapFileKind mapFileKind(const std::string& path) {
  try {
    const YAML::Node root = YAML::LoadFile(path);
    if (!root.IsMap()) return MapFileKind::kOther;
    if (root["landmarks"]) return MapFileKind::kLandmarks;
    return root["image"] ? MapFileKind::kGrid : MapFileKind::kOther;
  } catch (const std::exception&) {
    return MapFileKind::kOther;
  }
}

}  // namespace

std::string loadPriorMap(const std::string& path, core::SlamSession* session) {
  const core::SlamFilter& filter = session->filter();
  const std::string variant = "variant " + filter.variant();
  const MapFileKind kind = mapFileKind(path);
  if (!filter.usesLandmarkFeatures()) {
    if (kind == MapFileKind::kLandmarks) {
      throw ConfigError(path + ": a landmarks YAML; " + variant +
                        " maps cells and starts from an occupancy-grid map: map_server's "
                        "map.yaml (image, resolution, origin), as save_map and offline_slam "
                        "write for it");
    }
    core::GridMapData grid;
    try {
      grid = readGridMap(path);
      if (grid.count(kOccupiedPercent, 100) == 0) {  // nothing to localize on
        throw ConfigError(path + ": the map has no occupied cell (" +
                          std::to_string(grid.count(0, kFreePercent)) + " free, " +
                          std::to_string(grid.count(-1, -1)) + " unknown, " +
                          std::to_string(grid.count(kFreePercent + 1, kOccupiedPercent - 1)) +
                          " between the thresholds)");
      }
      if (!session->setPriorGridMap(grid)) throw ConfigError(variant + " cannot start from a map");
    } catch (const ConfigError&) {
      throw;
    } catch (const std::exception& e) {
      throw ConfigError(std::string(e.what()).rfind(path, 0) == 0 ? e.what()
                                                                  : path + ": " + e.what());
    }
    std::ostringstream what;
    what << "a " << grid.width << " x " << grid.height << " grid of " << grid.resolution_m
         << " m cells (" << grid.count(kOccupiedPercent, 100) << " occupied, "
         << grid.count(0, kFreePercent) << " free)";
    const double resolution = filter.gridResolution();
    if (resolution > 0.0 && grid.resolution_m > 1.5 * resolution) {
      what << "; note: its cells are coarser than grid.resolution_m (" << resolution
           << " m), so its walls are up to " << grid.resolution_m
           << " m thick in the filter's cells: a map at the filter's resolution localizes "
              "better";
    }
    if (grid.count(kOccupiedPercent, 100) > grid.count(0, kFreePercent)) {
      what << "; note: more of it is occupied than free: is its image inverted (negate)?";
    }
    return what.str();
  }
  if (kind == MapFileKind::kGrid) {
    throw ConfigError(path + ": an occupancy-grid map (map_server's map.yaml); " + variant +
                      " maps landmarks and starts from the landmarks YAML that save_map and "
                      "offline_slam write beside it (landmarks.yaml)");
  }
  std::vector<core::LandmarkEstimate> landmarks;
  try {
    landmarks = loadLandmarksYaml(path);
  } catch (const std::exception& e) {
    throw ConfigError(e.what());
  }
  if (!session->setPriorMap(landmarks)) throw ConfigError(variant + " cannot start from a map");
  return std::to_string(landmarks.size()) + " landmarks";
}

std::string applyMapConfig(const SlamConfig& config, core::SlamSession* session) {
  if (config.map_file.empty()) return "";
  std::string loaded;
  try {
    loaded = loadPriorMap(config.map_file, session);
  } catch (const ConfigError& e) {
    throw ConfigError(std::string("map_file: ") + e.what());
  }
  if (config.localization_only && !session->setMapping(false)) {
    throw ConfigError("localization_only: variant " + config.filter.variant +
                      " has no localization-only mode");
  }
  std::string why;
  if (config.global_localization &&
      !session->localizeGlobally(&why, core::SlamSession::GlobalStart::kConfigured)) {
    throw ConfigError(std::string("global_localization: true (") +
                      core::SlamSession::kGlobalLocalizationNeeds + "): " + why);
  }
  return loaded;
}

std::vector<std::string> configNotes(const SlamConfig& config) {
  std::vector<std::string> notes;
  if (config.filter.variant == "grid_pf" && !config.localization_only &&
      config.filter.grid.match_model == "likelihood_field") {
    // The field is a loaded map's, and nothing turns mapping off during a run.
    notes.push_back(
        "grid.match_model likelihood_field weighs only while localizing on a map "
        "(localization_only: true); this run maps and weighs by eq. 14 (map_matching)");
  }
  return notes;
}

}  // namespace io
}  // namespace rbpf_slam
