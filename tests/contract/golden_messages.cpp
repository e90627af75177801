#include "golden_messages.h"

#include <array>
#include <cmath>
#include <cstdint>
#include <stdexcept>

#include <google/protobuf/io/coded_stream.h>
#include <google/protobuf/io/zero_copy_stream_impl_lite.h>
#include <google/protobuf/util/json_util.h>

namespace wj::contract {
namespace {

namespace v1 = wheeljump::planner::v1;

// The 16 joints in the contract's order: leg-major LF, RF, LH, RH; HAA, HFE, KFE, WHEEL.
constexpr std::array<const char*, 4> kLegs = {"LF", "RF", "LH", "RH"};
constexpr std::array<const char*, 4> kJointKinds = {"HAA", "HFE", "KFE", "WHEEL"};
constexpr int kNumJoints = 16;

// Run-up speed of the golden request [m/s] and the URDF wheel radius [m].
constexpr double kRunUpSpeed = 3.0;
constexpr double kWheelRadius = 0.085;

// Rounds to 1e-4 so that the JSON goldens stay readable (the result is the double nearest to a
// four-decimal number, which every JSON printer writes back with at most four decimals).
double round4(double value) {
  return std::round(value * 1e4) / 1e4;
}

// One planar state of the jump (the fields shared by CentroidalSample and JumpEvent), in J.
struct PlanarState {
  double t_s;
  double com_x_m;
  double com_z_m;
  double pitch_rad;
  double com_vx_m_s;
  double com_vz_m_s;
  double pitch_rate_rad_s;
};

void setSample(const PlanarState& s, v1::CentroidalSample* out) {
  out->set_t_s(s.t_s);
  out->set_com_x_m(s.com_x_m);
  out->set_com_z_m(s.com_z_m);
  out->set_pitch_rad(s.pitch_rad);
  out->set_com_vx_m_s(s.com_vx_m_s);
  out->set_com_vz_m_s(s.com_vz_m_s);
  out->set_pitch_rate_rad_s(s.pitch_rate_rad_s);
}

void setEvent(const PlanarState& s, double base_z_m, v1::JumpEvent* out) {
  out->set_t_s(s.t_s);
  out->set_com_x_m(s.com_x_m);
  out->set_com_z_m(s.com_z_m);
  out->set_pitch_rad(s.pitch_rad);
  out->set_com_vx_m_s(s.com_vx_m_s);
  out->set_com_vz_m_s(s.com_vz_m_s);
  out->set_pitch_rate_rad_s(s.pitch_rate_rad_s);
  out->set_base_z_m(base_z_m);
}

void setPolynomial(std::initializer_list<double> coefficients, v1::Polynomial* out) {
  for (double c : coefficients) out->add_coefficients(c);
}

// The predicted planar trajectory: start, end of the all-wheel phase (t1), take-off (t2), apex,
// touchdown (t3). Flight is ballistic: z(t) = z2 + vz2 (t - t2) - g (t - t2)^2 / 2 with
// vz2 = 1.657 m/s, which clears the 0.25 m wall at x in [1.15, 1.25] m by 18 mm.
constexpr std::array<PlanarState, 5> kPredicted = {{
    {0.0, 0.0, 0.372, 0.0, 3.0, 0.0, 0.0},
    {0.12, 0.366, 0.383, 0.041, 3.09, 0.38, 0.98},
    {0.21, 0.655, 0.43, 0.105, 3.2, 1.657, -0.28},
    {0.379, 1.196, 0.57, 0.0577, 3.2, 0.0, -0.28},
    {0.586, 1.858, 0.3596, -0.0003, 3.2, -2.0316, -0.28},
}};

// The multibody simulation of the same plan: close to the prediction, not equal to it.
constexpr std::array<PlanarState, 3> kSimulated = {{
    {0.212, 0.661, 0.428, 0.109, 3.19, 1.641, -0.31},
    {0.38, 1.197, 0.5653, 0.0563, 3.19, 0.0, -0.31},
    {0.589, 1.871, 0.357, -0.0091, 3.19, -2.036, -0.31},
}};

}  // namespace

v1::PlanJumpRequest makeGoldenPlanJumpRequest() {
  v1::PlanJumpRequest request;
  v1::RobotState& state = *request.mutable_state();
  state.mutable_base_position_w_m()->set_x(12.84);
  state.mutable_base_position_w_m()->set_y(-0.37);
  state.mutable_base_position_w_m()->set_z(0.392);
  // Heading (yaw) 0.05 rad and 2.4 mrad nose-up, which is a rotation about -y (hence y < 0).
  v1::Quaternion& q = *state.mutable_base_orientation_w();
  q.set_w(0.9996868);
  q.set_x(0.0);
  q.set_y(-0.0012);
  q.set_z(0.0249974);
  // 3 m/s along the heading, measured with a little noise.
  state.mutable_base_linear_velocity_w_m_s()->set_x(2.9963);
  state.mutable_base_linear_velocity_w_m_s()->set_y(0.1499);
  state.mutable_base_linear_velocity_w_m_s()->set_z(-0.004);
  state.mutable_base_angular_velocity_b_rad_s()->set_x(0.011);
  state.mutable_base_angular_velocity_b_rad_s()->set_y(-0.023);
  state.mutable_base_angular_velocity_b_rad_s()->set_z(0.003);
  // Crouched stance (HFE 0.70, KFE -1.40) on all legs, hips slightly splayed; wheels at their
  // accumulated angles, spinning at v0 / r = 35.29 rad/s.
  constexpr std::array<double, 4> kWheelAngles = {12.61, 12.58, 11.94, 11.97};
  constexpr std::array<double, 4> kWheelSpeeds = {35.29, 35.31, 35.28, 35.3};
  for (int leg = 0; leg < 4; ++leg) {
    const double splay = (leg % 2 == 0) ? 0.02 : -0.02;
    for (double p : {splay, 0.7, -1.4, kWheelAngles.at(leg)}) state.add_joint_positions_rad(p);
    for (double v : {0.0, 0.012, -0.021, kWheelSpeeds.at(leg)}) state.add_joint_velocities_rad_s(v);
  }
  state.set_stamp_s(1732.417);

  v1::JumpTask& task = *request.mutable_task();
  task.set_target_dx_m(1.86);
  task.set_target_height_m(0.36);
  task.set_target_pitch_change_rad(0.0);
  task.set_event(v1::TARGET_EVENT_TOUCHDOWN);
  task.mutable_obstacle()->set_x_min_m(1.15);
  task.mutable_obstacle()->set_x_max_m(1.25);
  task.mutable_obstacle()->set_height_m(0.25);
  task.set_takeoff_mode(v1::TAKEOFF_MODE_TWO_STEP);

  v1::ComputeBudget& budget = *request.mutable_budget();
  budget.set_max_evaluations(60000);
  budget.set_max_verified_candidates(4);
  budget.set_skip_verification(false);
  // A seed above 2^53: JSON must carry it as a string to keep every bit.
  budget.set_seed(11400714819323198485ULL);

  request.set_request_id("wj-7f3a-000172");
  return request;
}

v1::PlanJumpResponse makeGoldenPlanJumpResponse() {
  v1::PlanJumpResponse response;
  v1::Plan& plan = *response.mutable_plan();
  plan.mutable_phase_times()->set_t1_s(0.12);
  plan.mutable_phase_times()->set_t2_s(0.21);
  plan.mutable_phase_times()->set_t3_s(0.586);

  // [0, t1]: both pairs push; the front normal force falls to zero at t1.
  v1::ForcePhase& all_wheels = *plan.add_force_phases();
  all_wheels.set_t_start_s(0.0);
  all_wheels.set_t_end_s(0.12);
  setPolynomial({0.0, 95.0, 180.0}, all_wheels.mutable_hind()->mutable_fx_n());
  setPolynomial({110.3, 1450.0, 2100.0}, all_wheels.mutable_hind()->mutable_fz_n());
  setPolynomial({0.0, 35.0, -290.0}, all_wheels.mutable_front()->mutable_fx_n());
  setPolynomial({110.4, 350.0, -10580.0}, all_wheels.mutable_front()->mutable_fz_n());
  // [t1, t2]: the hind pair alone; the front pair's force is the zero polynomial (no terms).
  v1::ForcePhase& hind_only = *plan.add_force_phases();
  hind_only.set_t_start_s(0.12);
  hind_only.set_t_end_s(0.21);
  setPolynomial({25.0, 160.0, -2400.0}, hind_only.mutable_hind()->mutable_fx_n());
  setPolynomial({314.5, 2600.0, -67000.0}, hind_only.mutable_hind()->mutable_fz_n());
  hind_only.mutable_front()->mutable_fx_n();
  hind_only.mutable_front()->mutable_fz_n();

  for (const PlanarState& s : kPredicted) setSample(s, plan.add_centroidal_trajectory());

  // The first three samples (500 Hz) of the joint references; a real plan has t3 / 0.002 + 1.
  v1::JointTrajectory& joints = *plan.mutable_joints();
  constexpr int kSamples = 3;
  constexpr double kPeriod = 0.002;
  joints.set_sample_period_s(kPeriod);
  joints.set_num_samples(kSamples);
  for (const char* leg : kLegs) {
    for (const char* kind : kJointKinds) joints.add_joint_names(std::string(leg) + "_" + kind);
  }
  constexpr std::array<double, 4> kWheelAngles = {12.61, 12.58, 11.94, 11.97};
  for (int k = 0; k < kSamples; ++k) {
    const double t = kPeriod * k;
    for (int leg = 0; leg < 4; ++leg) {
      const bool hind = leg >= 2;
      const double splay = (leg % 2 == 0) ? 0.02 : -0.02;
      // Hind legs extend faster than front legs: they push on to t2.
      const double hfe_rate = hind ? -0.75 : -0.4;
      const double kfe_rate = hind ? 1.6 : 0.5;
      const double wheel_rate = kRunUpSpeed / kWheelRadius;
      const std::array<double, 4> position = {splay, 0.7 + hfe_rate * t, -1.4 + kfe_rate * t,
                                              kWheelAngles.at(leg) + wheel_rate * t};
      const std::array<double, 4> velocity = {0.0, hfe_rate, kfe_rate, wheel_rate};
      const std::array<double, 4> torque = {hind ? 0.31 : 0.27, hind ? -9.8 : -6.2,
                                            (hind ? 21.5 : 12.4) + 40.0 * t, 0.05};
      for (int j = 0; j < 4; ++j) {
        joints.add_positions_rad(round4(position.at(j)));
        joints.add_velocities_rad_s(round4(velocity.at(j)));
        joints.add_torques_nm(round4(torque.at(j)));
      }
    }
  }
  // D = [s(t1/2), s(t2), s(t3), t1, t2, t3], s = (x, z, pitch).
  for (double d :
       {0.181, 0.374, 0.009, 0.655, 0.43, 0.105, 1.858, 0.3596, -0.0003, 0.12, 0.21, 0.586}) {
    plan.add_decision_vector(d);
  }

  v1::JumpOutcome& predicted = *response.mutable_predicted();
  setEvent(kPredicted.at(2), 0.447, predicted.mutable_takeoff());
  setEvent(kPredicted.at(3), 0.588, predicted.mutable_apex());
  setEvent(kPredicted.at(4), 0.381, predicted.mutable_touchdown());
  predicted.set_min_obstacle_clearance_m(0.018);

  v1::Feasibility& feasibility = *response.mutable_feasibility();
  feasibility.set_feasible(true);
  struct Margin {
    v1::ConstraintClass constraint;
    double worst_margin;
    const char* unit;
    double t_s;
    const char* location;
  };
  const std::array<Margin, 10> margins = {{
      {v1::CONSTRAINT_CLASS_NORMAL_FORCE, 4.8, "N", 0.209, "hind pair"},
      {v1::CONSTRAINT_CLASS_FRICTION_CONE, 0.21, "-", 0.118, "front pair"},
      {v1::CONSTRAINT_CLASS_JOINT_POSITION, 0.35, "rad", 0.45, "LH_KFE"},
      {v1::CONSTRAINT_CLASS_JOINT_SPEED, 9.6, "rad/s", 0.205, "RH_KFE"},
      {v1::CONSTRAINT_CLASS_JOINT_TORQUE, 5.3, "Nm", 0.19, "LH_KFE"},
      {v1::CONSTRAINT_CLASS_ACTUATOR_ENVELOPE, 1.9, "Nm", 0.2, "RH_KFE"},
      {v1::CONSTRAINT_CLASS_BODY_HEIGHT, 0.172, "m", 0.0, "base"},
      {v1::CONSTRAINT_CLASS_OBSTACLE_CLEARANCE, 0.018, "m", 0.478, "LH_WHEEL"},
      {v1::CONSTRAINT_CLASS_WHEEL_TRACTION, 31.5, "N", 0.13, "hind pair"},
      {v1::CONSTRAINT_CLASS_WHEEL_SPEED, 2.35, "rad/s", 0.21, "RF_WHEEL"},
  }};
  for (const Margin& m : margins) {
    v1::ConstraintMargin& out = *feasibility.add_margins();
    out.set_constraint(m.constraint);
    out.set_worst_margin(m.worst_margin);
    out.set_unit(m.unit);
    out.set_t_s(m.t_s);
    out.set_location(m.location);
  }
  feasibility.set_target_error_dx_m(0.002);
  feasibility.set_target_error_height_m(0.0004);
  feasibility.set_target_error_pitch_rad(0.0003);
  feasibility.set_summary(
      "Feasible: every constraint class holds; the tightest is the obstacle clearance "
      "(18 mm at t = 0.478 s, LH_WHEEL).");

  v1::Verification& verification = *response.mutable_verification();
  verification.set_status(v1::VERIFICATION_STATUS_PASSED);
  setEvent(kSimulated.at(0), 0.444, verification.mutable_simulated()->mutable_takeoff());
  setEvent(kSimulated.at(1), 0.583, verification.mutable_simulated()->mutable_apex());
  setEvent(kSimulated.at(2), 0.379, verification.mutable_simulated()->mutable_touchdown());
  verification.mutable_simulated()->set_min_obstacle_clearance_m(0.011);
  verification.set_max_envelope_ratio(0.957);
  verification.set_landed_upright(true);
  verification.set_candidates_verified(4);
  // The best predicted candidate failed in simulation; the second one passed.
  verification.set_returned_candidate_rank(1);

  response.set_source(v1::PLAN_SOURCE_CACHE_MISS);

  v1::SolveStats& stats = *response.mutable_stats();
  stats.set_de_ms(182.4);
  stats.set_polish_ms(21.7);
  stats.set_verify_ms(96.3);
  stats.set_total_ms(305.9);
  stats.set_evaluations(48000);
  stats.set_generations(120);
  stats.set_threads(2);
  stats.set_de_cost(0.0183);
  stats.set_polished_cost(0.0121);
  stats.set_seed(11400714819323198485ULL);
  stats.set_cache_key("9f2c4e1ab7d05388");

  response.set_request_id("wj-7f3a-000172");
  return response;
}

v1::GetStatsResponse makeGoldenGetStatsResponse() {
  v1::GetStatsResponse stats;
  stats.set_requests(1282);
  stats.set_cache_hits(1002);
  stats.set_cache_misses(231);
  stats.set_coalesced(37);
  stats.set_evictions(12);
  stats.set_cache_entries(219);
  stats.set_rejected_invalid(9);
  stats.set_rejected_queue_full(3);
  stats.set_deadline_exceeded(2);
  struct Latency {
    const char* path;
    std::uint64_t count;
    double p50_ms;
    double p90_ms;
    double p99_ms;
  };
  const std::array<Latency, 4> latencies = {{
      {"cache_hit", 1002, 0.41, 0.73, 1.9},
      {"cache_miss", 229, 288.5, 402.2, 611.0},
      {"warm_start", 0, 0.0, 0.0, 0.0},
      {"coalesced", 37, 141.2, 296.4, 380.7},
  }};
  for (const Latency& l : latencies) {
    v1::PathLatency& out = *stats.add_latencies();
    out.set_path(l.path);
    out.set_count(l.count);
    out.set_p50_ms(l.p50_ms);
    out.set_p90_ms(l.p90_ms);
    out.set_p99_ms(l.p99_ms);
  }
  stats.set_uptime_s(86412.5);
  return stats;
}

v1::WarmCacheProgress makeGoldenWarmCacheProgress() {
  // Grid 0.0 to 4.0 m/s in 0.1 m/s steps (41 points); the 17th point is 1.6 m/s.
  v1::WarmCacheProgress progress;
  progress.set_done(17);
  progress.set_total(41);
  progress.set_v0_m_s(1.6);
  progress.set_feasible(true);
  progress.set_source(v1::PLAN_SOURCE_WARM_START);
  return progress;
}

const std::vector<GoldenCase>& goldenCases() {
  static const std::vector<GoldenCase> cases = {
      {"plan_jump_request",
       [] { return std::make_unique<v1::PlanJumpRequest>(makeGoldenPlanJumpRequest()); }},
      {"plan_jump_response",
       [] { return std::make_unique<v1::PlanJumpResponse>(makeGoldenPlanJumpResponse()); }},
      {"get_stats_response",
       [] { return std::make_unique<v1::GetStatsResponse>(makeGoldenGetStatsResponse()); }},
      {"warm_cache_progress",
       [] { return std::make_unique<v1::WarmCacheProgress>(makeGoldenWarmCacheProgress()); }},
  };
  return cases;
}

std::string serializeDeterministic(const google::protobuf::Message& message) {
  std::string bytes;
  {
    google::protobuf::io::StringOutputStream stream(&bytes);
    google::protobuf::io::CodedOutputStream coded(&stream);
    coded.SetSerializationDeterministic(true);
    if (!message.SerializeToCodedStream(&coded)) {
      throw std::runtime_error("cannot serialize " + message.GetTypeName());
    }
  }  // the CodedOutputStream flushes into bytes when it goes out of scope
  return bytes;
}

std::string printGoldenJson(const google::protobuf::Message& message) {
  google::protobuf::util::JsonPrintOptions options;
  options.add_whitespace = true;
  options.always_print_primitive_fields = false;
  options.preserve_proto_field_names = false;
  std::string json;
  const auto status = google::protobuf::util::MessageToJsonString(message, &json, options);
  if (!status.ok()) {
    throw std::runtime_error("cannot print " + message.GetTypeName() +
                             " as JSON: " + status.ToString());
  }
  return json;
}

}  // namespace wj::contract
