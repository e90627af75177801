#include "server/response_conversion.h"

#include <algorithm>

#include "planner_client/compact_knots.h"

namespace wj::server {

namespace {

v1::ConstraintClass toProto(planner::ConstraintClass c) {
  return static_cast<v1::ConstraintClass>(static_cast<int>(c) + 1);
}

v1::VerificationStatus toProto(VerificationStatus s) {
  switch (s) {
    case VerificationStatus::NotRun:
      return v1::VERIFICATION_STATUS_NOT_RUN;
    case VerificationStatus::Passed:
      return v1::VERIFICATION_STATUS_PASSED;
    case VerificationStatus::Failed:
      return v1::VERIFICATION_STATUS_FAILED;
  }
  return v1::VERIFICATION_STATUS_UNSPECIFIED;
}

void toProto(const planner::JumpEvent& e, v1::JumpEvent* out) {
  out->set_t_s(e.t);
  out->set_com_x_m(e.state.x);
  out->set_com_z_m(e.state.z);
  out->set_pitch_rad(e.state.pitch);
  out->set_com_vx_m_s(e.state.vx);
  out->set_com_vz_m_s(e.state.vz);
  out->set_pitch_rate_rad_s(e.state.pitch_rate);
  out->set_base_z_m(e.base_z);
}

void toProto(const planner::JumpOutcome& o, v1::JumpOutcome* out) {
  toProto(o.takeoff, out->mutable_takeoff());
  toProto(o.apex, out->mutable_apex());
  toProto(o.touchdown, out->mutable_touchdown());
  out->set_min_obstacle_clearance_m(o.min_obstacle_clearance);
}

void toProto(const planner::Polynomial& p, v1::Polynomial* out) {
  out->mutable_coefficients()->Assign(p.c.begin(), p.c.end());
  if (p.c.empty()) out->add_coefficients(0.0);
}

std::string locationName(const model::RobotModel& robot, int location) {
  if (location >= 0 && location < model::kNumJoints)
    return robot.joints()[static_cast<std::size_t>(location)].name;
  switch (location) {
    case -1:
      return "hind pair";
    case -2:
      return "front pair";
    case -3:
      return "body";
    default:
      return "";
  }
}

// Knot-major float32 arrays: one converting, transposing copy per matrix.
void toProto(const planner::PlanKnots& k, v1::TrajectoryKnots* out) {
  const int n = k.size();
  out->mutable_t_s()->Assign(k.t.begin(), k.t.end());
  using KnotMajor = Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
  const auto fill = [n](const Eigen::MatrixXd& m, google::protobuf::RepeatedField<float>* f) {
    f->Reserve(n * model::kNumJoints);
    f->AddNAlreadyReserved(n * model::kNumJoints);
    Eigen::Map<KnotMajor>(f->mutable_data(), n, model::kNumJoints) = m.cast<float>();
  };
  fill(k.q, out->mutable_positions_rad());
  fill(k.qd, out->mutable_velocities_rad_s());
  fill(k.tau, out->mutable_torques_nm());
  auto* c = out->mutable_centroidal();
  c->Reserve(6 * n);
  for (const planner::PlanarState& s : k.centroidal)
    for (const double v : {s.x, s.z, s.pitch, s.vx, s.vz, s.pitch_rate})
      c->AddAlreadyReserved(static_cast<float>(v));
}

void toProto(const planner::JumpPlan& plan, const model::RobotModel& robot, TrajectoryFormat format,
             v1::Plan* out) {
  auto* times = out->mutable_phase_times();
  times->set_t1_s(plan.t1);
  times->set_t2_s(plan.t2);
  times->set_t3_s(plan.t3);
  for (const auto& phase : plan.force_phases) {
    auto* p = out->add_force_phases();
    p->set_t_start_s(phase.t_start);
    p->set_t_end_s(phase.t_end);
    toProto(phase.hind.fx, p->mutable_hind()->mutable_fx_n());
    toProto(phase.hind.fz, p->mutable_hind()->mutable_fz_n());
    toProto(phase.front.fx, p->mutable_front()->mutable_fx_n());
    toProto(phase.front.fz, p->mutable_front()->mutable_fz_n());
  }
  out->mutable_decision_vector()->Assign(plan.decision.data(),
                                         plan.decision.data() + plan.decision.size());
  if (plan.knots.size() > 0) {
    toProto(plan.knots, out->mutable_knots());
    if (format == TrajectoryFormat::CompactKnots) {
      client::compactKnots(out->knots(), out->mutable_compact_knots());
      out->clear_knots();
    }
    return;
  }
  const int n = plan.numSamples();
  auto* traj = out->mutable_centroidal_trajectory();
  traj->Reserve(n);
  for (int k = 0; k < n; ++k) {
    const auto& s = plan.centroidal[static_cast<std::size_t>(k)];
    auto* c = traj->Add();
    c->set_t_s(std::min(k * plan.dt, plan.t3));
    c->set_com_x_m(s.x);
    c->set_com_z_m(s.z);
    c->set_pitch_rad(s.pitch);
    c->set_com_vx_m_s(s.vx);
    c->set_com_vz_m_s(s.vz);
    c->set_pitch_rate_rad_s(s.pitch_rate);
  }
  auto* joints = out->mutable_joints();
  joints->set_sample_period_s(plan.dt);
  joints->set_num_samples(static_cast<std::uint32_t>(n));
  joints->mutable_joint_names()->Reserve(model::kNumJoints);
  for (const auto& j : robot.joints()) joints->add_joint_names(j.name);
  // Sample-major on the wire, column-major in Eigen: one transposing copy per matrix, written
  // straight into the response's array (no zero fill before, no intermediate).
  using SampleMajor = Eigen::Matrix<double, Eigen::Dynamic, model::kNumJoints, Eigen::RowMajor>;
  const auto fill = [n](const Eigen::MatrixXd& m, google::protobuf::RepeatedField<double>* f) {
    if (m.rows() != n || m.cols() != model::kNumJoints) return;
    f->Reserve(n * model::kNumJoints);
    f->AddNAlreadyReserved(n * model::kNumJoints);
    Eigen::Map<SampleMajor>(f->mutable_data(), n, model::kNumJoints) = m;
  };
  fill(plan.q, joints->mutable_positions_rad());
  fill(plan.qd, joints->mutable_velocities_rad_s());
  fill(plan.tau, joints->mutable_torques_nm());
}

}  // namespace

v1::PlanSource toProto(PlanSource source) {
  switch (source) {
    case PlanSource::CacheHit:
      return v1::PLAN_SOURCE_CACHE_HIT;
    case PlanSource::CacheMiss:
      return v1::PLAN_SOURCE_CACHE_MISS;
    case PlanSource::WarmStart:
      return v1::PLAN_SOURCE_WARM_START;
    case PlanSource::Coalesced:
      return v1::PLAN_SOURCE_COALESCED;
  }
  return v1::PLAN_SOURCE_UNSPECIFIED;
}

void toProto(const PlanAnswer& a, const model::RobotModel& robot, const std::string& request_id,
             TrajectoryFormat format, v1::PlanJumpResponse* out) {
  if (a.plan.numSamples() > 0 || a.plan.knots.size() > 0) {
    toProto(a.plan, robot, format, out->mutable_plan());
    auto* from = out->mutable_planned_for();
    from->set_v0_m_s(a.plan.initial.vx);
    from->set_pitch_rad(a.plan.initial.pitch);
    from->set_pitch_rate_rad_s(a.plan.initial.pitch_rate);
    from->mutable_joint_positions_rad()->Assign(a.plan.q_initial.data(),
                                                a.plan.q_initial.data() + a.plan.q_initial.size());
  }
  toProto(a.evaluation.predicted, out->mutable_predicted());
  auto* f = out->mutable_feasibility();
  f->set_feasible(a.evaluation.feasible);
  for (int i = 0; i < planner::kNumConstraintClasses; ++i) {
    const auto c = static_cast<planner::ConstraintClass>(i);
    const auto& m = a.evaluation.margins[static_cast<std::size_t>(i)];
    auto* margin = f->add_margins();
    margin->set_constraint(toProto(c));
    margin->set_worst_margin(m.worst);
    margin->set_unit(planner::unitOf(c));
    margin->set_t_s(m.t);
    margin->set_location(locationName(robot, m.location));
  }
  for (const auto c : a.binding) f->add_binding(toProto(c));
  f->set_target_error_dx_m(a.evaluation.err_dx);
  f->set_target_error_height_m(a.evaluation.err_height);
  f->set_target_error_pitch_rad(a.evaluation.err_pitch);
  f->set_summary(a.summary);
  auto* v = out->mutable_verification();
  v->set_status(toProto(a.verification.status));
  if (a.verification.status != VerificationStatus::NotRun)
    toProto(a.verification.simulated, v->mutable_simulated());
  for (const auto& r : a.verification.failure_reasons) v->add_failure_reasons(r);
  v->set_max_envelope_ratio(a.verification.max_envelope_ratio);
  v->set_landed_upright(a.verification.landed_upright);
  v->set_candidates_verified(static_cast<std::uint32_t>(a.verification.candidates_verified));
  v->set_returned_candidate_rank(
      static_cast<std::uint32_t>(a.verification.returned_candidate_rank));
  out->set_source(toProto(a.source));
  auto* s = out->mutable_stats();
  s->set_de_ms(a.stats.de_ms);
  s->set_polish_ms(a.stats.polish_ms);
  s->set_verify_ms(a.stats.verify_ms);
  s->set_total_ms(a.stats.total_ms);
  s->set_evaluations(static_cast<std::uint64_t>(a.stats.evaluations));
  s->set_generations(static_cast<std::uint32_t>(a.stats.generations));
  s->set_threads(static_cast<std::uint32_t>(a.stats.threads));
  s->set_de_cost(a.stats.de_cost);
  s->set_polished_cost(a.stats.polished_cost);
  s->set_seed(a.stats.seed);
  s->set_cache_key(a.stats.cache_key);
  out->set_request_id(request_id);
}

void toProto(const StatsSnapshot& s, v1::GetStatsResponse* out) {
  out->set_requests(s.requests);
  out->set_cache_hits(s.cache_hits);
  out->set_cache_misses(s.cache_misses);
  out->set_coalesced(s.coalesced);
  out->set_evictions(s.evictions);
  out->set_cache_entries(s.cache_entries);
  out->set_rejected_invalid(s.rejected_invalid);
  out->set_rejected_queue_full(s.rejected_queue_full);
  out->set_deadline_exceeded(s.deadline_exceeded);
  for (const auto& p : s.latencies) {
    auto* l = out->add_latencies();
    l->set_path(toString(p.path));
    l->set_count(p.count);
    l->set_p50_ms(p.p50_ms);
    l->set_p90_ms(p.p90_ms);
    l->set_p99_ms(p.p99_ms);
  }
  out->set_uptime_s(s.uptime_s);
  out->set_warm_starts(s.warm_starts);
  auto* store = out->mutable_store();
  const auto& c = s.cache.store;
  store->set_backend(s.cache.backend);
  store->set_available(s.cache.backend == "none" || c.available);
  store->set_hits(static_cast<std::uint64_t>(s.cache.persisted_hits));
  store->set_writes(static_cast<std::uint64_t>(c.writes));
  store->set_write_errors(static_cast<std::uint64_t>(c.write_errors));
  store->set_read_errors(static_cast<std::uint64_t>(c.read_errors));
  store->set_corrupt_values(static_cast<std::uint64_t>(c.corrupt_rows));
  store->set_reconnects(static_cast<std::uint64_t>(c.reconnects));
  store->set_writes_skipped(static_cast<std::uint64_t>(c.writes_skipped));
  store->set_entries_loaded(static_cast<std::uint64_t>(c.rows_loaded));
}

void toProto(const WarmProgress& p, v1::WarmCacheProgress* out) {
  out->set_done(static_cast<std::uint32_t>(p.done));
  out->set_total(static_cast<std::uint32_t>(p.total));
  out->set_v0_m_s(p.v0);
  out->set_feasible(p.feasible);
  out->set_source(toProto(p.source));
}

}  // namespace wj::server
