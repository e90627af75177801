// Request validation and conversion: every bad field is INVALID_ARGUMENT naming the proto field
// and its allowed range; good requests convert to the planner's frame conventions.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <functional>
#include <limits>
#include <sstream>

#include "server/request_validation.h"
#include "server_test_util.h"
#include "test_robot.h"

namespace wj::server {
namespace {

using wj::test::robot;

// The message of the INVALID_ARGUMENT thrown for `request`, or "" if it is accepted.
std::string rejection(const v1::PlanJumpRequest& request) {
  try {
    toPlanRequest(request, robot());
  } catch (const ServiceError& e) {
    EXPECT_EQ(e.code(), ErrorCode::InvalidArgument) << e.what();
    return e.what();
  }
  return "";
}

struct Case {
  std::string name;
  std::function<void(v1::PlanJumpRequest&)> mutate;
  std::vector<std::string> expected;  // substrings of the message
};

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

TEST(RequestValidation, StandingRequestIsAccepted) {
  EXPECT_EQ(rejection(test::standingRequest(1.0)), "");
}

TEST(RequestValidation, GoldenContractRequestIsAccepted) {
  std::ifstream in(WJ_CONTRACT_GOLDEN_DIR "/plan_jump_request.binpb", std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  v1::PlanJumpRequest r;
  ASSERT_TRUE(r.ParseFromString(ss.str()));
  const PlanRequest p = toPlanRequest(r, robot());
  EXPECT_NEAR(p.initial.v0, 3.0, 0.01);  // rolling at 3 m/s along its heading
  EXPECT_EQ(p.task.mode, planner::TakeoffMode::TwoStep);
  ASSERT_TRUE(p.task.obstacle.has_value());
  EXPECT_DOUBLE_EQ(p.task.obstacle->height, 0.25);
  EXPECT_EQ(p.request_id, "wj-7f3a-000172");
  EXPECT_EQ(p.seed, 11400714819323198485ULL);
  EXPECT_EQ(p.max_verified_candidates, 4);
}

TEST(RequestValidation, EveryBadFieldIsNamedWithItsRange) {
  const std::vector<Case> cases = {
      {"no state", [](auto& r) { r.clear_state(); }, {"state is required"}},
      {"no task", [](auto& r) { r.clear_task(); }, {"task is required"}},
      {"NaN position",
       [](auto& r) { r.mutable_state()->mutable_base_position_w_m()->set_x(kNaN); },
       {"state.base_position_w_m.x", "finite"}},
      {"huge position",
       [](auto& r) { r.mutable_state()->mutable_base_position_w_m()->set_y(1e9); },
       {"state.base_position_w_m.y", "[-10000, 10000]"}},
      {"zero quaternion",
       [](auto& r) { r.mutable_state()->mutable_base_orientation_w()->set_w(0.0); },
       {"state.base_orientation_w", "unit quaternion", "norm within 0.001 of 1"}},
      {"long quaternion",
       [](auto& r) { r.mutable_state()->mutable_base_orientation_w()->set_w(1.01); },
       {"state.base_orientation_w", "unit quaternion"}},
      {"inf quaternion",
       [](auto& r) { r.mutable_state()->mutable_base_orientation_w()->set_z(kInf); },
       {"state.base_orientation_w.z", "finite"}},
      {"rolled 90 degrees",
       [](auto& r) {
         auto* q = r.mutable_state()->mutable_base_orientation_w();
         q->set_w(std::sqrt(0.5));
         q->set_x(std::sqrt(0.5));
       },
       {"roll", "[-0.5, 0.5]"}},
      {"pitched up 60 degrees",
       [](auto& r) {
         auto* q = r.mutable_state()->mutable_base_orientation_w();
         q->set_w(std::cos(0.5 * 1.05));
         q->set_y(-std::sin(0.5 * 1.05));  // nose-up is a rotation about -y
       },
       {"state.base_orientation_w (pitch", "[-0.5, 0.5]"}},
      {"too fast",
       [](auto& r) { r.mutable_state()->mutable_base_linear_velocity_w_m_s()->set_x(4.5); },
       {"state.base_linear_velocity_w_m_s (forward speed", "[-1, 3.4]", "wheels' reach", "4.5"}},
      {"faster than the wheels can roll",  // 3.5 m/s > 0.085 m x 40 rad/s
       [](auto& r) { r.mutable_state()->mutable_base_linear_velocity_w_m_s()->set_x(3.5); },
       {"state.base_linear_velocity_w_m_s (forward speed", "[-1, 3.4]", "3.5"}},
      {"NaN velocity",
       [](auto& r) { r.mutable_state()->mutable_base_linear_velocity_w_m_s()->set_z(kNaN); },
       {"state.base_linear_velocity_w_m_s.z", "finite"}},
      {"spinning",
       [](auto& r) { r.mutable_state()->mutable_base_angular_velocity_b_rad_s()->set_y(-5.0); },
       {"state.base_angular_velocity_b_rad_s (pitch rate", "[-3, 3]"}},
      {"15 joints",
       [](auto& r) { r.mutable_state()->mutable_joint_positions_rad()->RemoveLast(); },
       {"state.joint_positions_rad must have 16 entries", "got 15"}},
      {"17 velocities",
       [](auto& r) { r.mutable_state()->add_joint_velocities_rad_s(0.0); },
       {"state.joint_velocities_rad_s must have 16 entries", "got 17"}},
      {"NaN joint",
       [](auto& r) { r.mutable_state()->set_joint_positions_rad(6, kNaN); },
       {"state.joint_positions_rad[6]", "finite"}},
      {"knee beyond its limit",
       [](auto& r) { r.mutable_state()->set_joint_positions_rad(6, -3.0); },
       {"state.joint_positions_rad[RF_KFE]", "[-2.7, -0.5]"}},
      {"wild joint speed",
       [](auto& r) { r.mutable_state()->set_joint_velocities_rad_s(3, 1e6); },
       {"state.joint_velocities_rad_s[3]", "[-1000, 1000]"}},
      {"inf stamp",
       [](auto& r) { r.mutable_state()->set_stamp_s(kInf); },
       {"state.stamp_s", "finite"}},
      {"stamp at -1e308",
       [](auto& r) { r.mutable_state()->set_stamp_s(-1e308); },
       {"state.stamp_s", "[0, 1e+10]", "-1e+308"}},
      {"negative stamp",
       [](auto& r) { r.mutable_state()->set_stamp_s(-0.5); },
       {"state.stamp_s", "[0, 1e+10]"}},
      {"stamp in the year 3000",
       [](auto& r) { r.mutable_state()->set_stamp_s(3.25e10); },
       {"state.stamp_s", "[0, 1e+10]"}},
      {"control character in the id",
       [](auto& r) { r.set_request_id(std::string("ab\ncd")); },
       {"request_id", "control characters", "byte 10 at index 2"}},
      {"NUL in the id",
       [](auto& r) { r.set_request_id(std::string("ab\0cd", 5)); },
       {"request_id", "byte 0 at index 2"}},
      {"no event",
       [](auto& r) { r.mutable_task()->set_event(v1::TARGET_EVENT_UNSPECIFIED); },
       {"task.event", "TARGET_EVENT_APEX"}},
      {"unknown event",
       [](auto& r) { r.mutable_task()->set_event(static_cast<v1::TargetEvent>(7)); },
       {"task.event", "got 7"}},
      {"no mode",
       [](auto& r) { r.mutable_task()->set_takeoff_mode(v1::TAKEOFF_MODE_UNSPECIFIED); },
       {"task.takeoff_mode", "TAKEOFF_MODE_TWO_STEP"}},
      {"NaN dx",
       [](auto& r) { r.mutable_task()->set_target_dx_m(kNaN); },
       {"task.target_dx_m", "[-3, 5]"}},
      {"too high",
       [](auto& r) { r.mutable_task()->set_target_height_m(2.0); },
       {"task.target_height_m", "[0.1, 1.5]"}},
      {"triple flip",
       [](auto& r) { r.mutable_task()->set_target_pitch_change_rad(20.0); },
       {"task.target_pitch_change_rad", "[-7, 7]"}},
      {"inverted box",
       [](auto& r) {
         auto* o = r.mutable_task()->mutable_obstacle();
         o->set_x_min_m(1.3);
         o->set_x_max_m(1.2);
         o->set_height_m(0.2);
       },
       {"task.obstacle.x_max_m"}},
      {"box behind the wheels",
       [](auto& r) {
         auto* o = r.mutable_task()->mutable_obstacle();
         o->set_x_min_m(0.05);
         o->set_x_max_m(0.2);
         o->set_height_m(0.2);
       },
       {"task.obstacle.x_min_m must be ahead of the front wheels"}},
      {"flat box",
       [](auto& r) {
         auto* o = r.mutable_task()->mutable_obstacle();
         o->set_x_min_m(1.0);
         o->set_x_max_m(1.2);
         o->set_height_m(0.0);
       },
       {"task.obstacle.height_m"}},
      {"huge budget",
       [](auto& r) { r.mutable_budget()->set_max_evaluations(20'000'000); },
       {"budget.max_evaluations", "[0, 10000000]"}},
      {"many candidates",
       [](auto& r) { r.mutable_budget()->set_max_verified_candidates(65); },
       {"budget.max_verified_candidates", "[0, 64]"}},
      {"long id",
       [](auto& r) { r.set_request_id(std::string(129, 'x')); },
       {"request_id", "at most 128 bytes", "got 129"}},
      {"unknown trajectory format",
       [](auto& r) { r.set_trajectory_format(static_cast<v1::TrajectoryFormat>(7)); },
       {"trajectory_format", "TRAJECTORY_FORMAT_KNOTS (2)", "got 7"}},
  };
  for (const auto& c : cases) {
    v1::PlanJumpRequest r = test::standingRequest(1.0);
    c.mutate(r);
    const std::string message = rejection(r);
    ASSERT_FALSE(message.empty()) << c.name << ": accepted";
    for (const auto& part : c.expected)
      EXPECT_NE(message.find(part), std::string::npos) << c.name << ": " << message;
  }
}

// Every numeric field of the request, found by reflection (nested messages and the first
// element of repeated fields included), set in turn to each absurd value: each is refused with
// INVALID_ARGUMENT naming the field (or, for a quaternion component, the quaternion). Each enum
// field set to an unknown value is refused the same way. A field added to the contract is
// covered without touching this test; one the service may accept at any value is listed.
namespace pb = google::protobuf;

struct FieldPath {
  std::vector<const pb::FieldDescriptor*> path;  ///< from the request down to the scalar
  std::string name() const {
    std::string n;
    for (const auto* f : path) n += (n.empty() ? "" : ".") + f->name();
    return n;
  }
};

void collectScalars(const pb::Descriptor* d, std::vector<const pb::FieldDescriptor*> prefix,
                    std::vector<FieldPath>& out) {
  for (int i = 0; i < d->field_count(); ++i) {
    const pb::FieldDescriptor* f = d->field(i);
    auto path = prefix;
    path.push_back(f);
    if (f->type() == pb::FieldDescriptor::TYPE_MESSAGE)
      collectScalars(f->message_type(), path, out);
    else
      out.push_back({path});
  }
}

// The message holding the last field of `p`, created on the way down (repeated: the element
// index 0 must exist; the base request has every repeated field non-empty or scalar).
pb::Message* holderOf(pb::Message& root, const FieldPath& p) {
  pb::Message* m = &root;
  for (std::size_t i = 0; i + 1 < p.path.size(); ++i)
    m = m->GetReflection()->MutableMessage(m, p.path[i]);
  return m;
}

void setNumber(pb::Message& m, const pb::FieldDescriptor* f, double v) {
  const pb::Reflection* r = m.GetReflection();
  if (f->is_repeated()) {
    ASSERT_EQ(f->cpp_type(), pb::FieldDescriptor::CPPTYPE_DOUBLE) << f->full_name();
    ASSERT_GT(r->FieldSize(m, f), 0) << f->full_name();
    r->SetRepeatedDouble(&m, f, 0, v);
    return;
  }
  ASSERT_EQ(f->cpp_type(), pb::FieldDescriptor::CPPTYPE_DOUBLE) << f->full_name();
  r->SetDouble(&m, f, v);
}

// Fields any value of which is meaningful: the seed, a switch.
bool acceptsAnyValue(const std::string& name) {
  return name == "budget.seed" || name == "budget.skip_verification";
}

// Checks every scalar of `base` (accepted as is) through `refusal` ("" = accepted).
void expectEveryFieldGuarded(const pb::Message& base,
                             const std::function<std::string(const pb::Message&)>& refusal,
                             int expected_doubles) {
  ASSERT_EQ(refusal(base), "") << "the base request must be accepted";
  std::vector<FieldPath> fields;
  collectScalars(base.GetDescriptor(), {}, fields);
  int doubles = 0;
  for (const FieldPath& p : fields) {
    const std::string name = p.name();
    const pb::FieldDescriptor* f = p.path.back();
    const bool in_quaternion = f->containing_type()->name() == "Quaternion";
    const std::string parent = name.substr(0, name.rfind('.'));
    const auto expectRefused = [&](const std::unique_ptr<pb::Message>& m, const std::string& what) {
      const std::string message = refusal(*m);
      EXPECT_FALSE(message.empty()) << name << " = " << what << " accepted";
      const bool named = message.find(name) != std::string::npos ||
                         (in_quaternion && message.find(parent) != std::string::npos);
      EXPECT_TRUE(named) << name << " = " << what
                         << ": the message names another field: " << message;
    };
    switch (f->cpp_type()) {
      case pb::FieldDescriptor::CPPTYPE_DOUBLE: {
        ++doubles;
        for (const double v : {kNaN, kInf, -kInf, 1e308, -1e308}) {
          std::unique_ptr<pb::Message> m(base.New());
          m->CopyFrom(base);
          setNumber(*holderOf(*m, p), f, v);
          expectRefused(m, std::to_string(v));
        }
        break;
      }
      case pb::FieldDescriptor::CPPTYPE_ENUM: {
        std::unique_ptr<pb::Message> m(base.New());
        m->CopyFrom(base);
        pb::Message* h = holderOf(*m, p);
        h->GetReflection()->SetEnumValue(h, f, 99);
        expectRefused(m, "99 (unknown enum value)");
        break;
      }
      case pb::FieldDescriptor::CPPTYPE_UINT32: {
        if (acceptsAnyValue(name)) break;
        std::unique_ptr<pb::Message> m(base.New());
        m->CopyFrom(base);
        pb::Message* h = holderOf(*m, p);
        h->GetReflection()->SetUInt32(h, f, std::numeric_limits<std::uint32_t>::max());
        expectRefused(m, "UINT32_MAX");
        break;
      }
      case pb::FieldDescriptor::CPPTYPE_STRING: {
        std::unique_ptr<pb::Message> m(base.New());
        m->CopyFrom(base);
        pb::Message* h = holderOf(*m, p);
        h->GetReflection()->SetString(h, f, std::string(1000, 'x'));
        expectRefused(m, "a 1000-byte string");
        break;
      }
      default:
        EXPECT_TRUE(acceptsAnyValue(name)) << name << ": no absurd value tried for this type";
    }
  }
  EXPECT_EQ(doubles, expected_doubles) << "the contract's double fields changed";
}

TEST(RequestValidation, EveryFieldOfPlanJumpRefusesAbsurdValues) {
  v1::PlanJumpRequest base = test::standingRequest(1.0);
  auto* o = base.mutable_task()->mutable_obstacle();
  o->set_x_min_m(1.0);
  o->set_x_max_m(1.2);
  o->set_height_m(0.2);
  base.mutable_state()->set_stamp_s(12.5);
  base.mutable_budget()->set_seed(7);
  // position 3 + quaternion 4 + velocities 6 + joints 2 (repeated) + stamp 1 + task 3 + box 3
  expectEveryFieldGuarded(
      base,
      [](const pb::Message& m) { return rejection(static_cast<const v1::PlanJumpRequest&>(m)); },
      22);
}

TEST(RequestValidation, EveryFieldOfWarmCacheRefusesAbsurdValues) {
  const planner::InitialState nominal = toPlanRequest(test::standingRequest(0.0), robot()).initial;
  v1::WarmCacheRequest base;
  *base.mutable_task() = test::standingRequest(0.0).task();
  base.set_v0_min_m_s(0.0);
  base.set_v0_max_m_s(0.2);
  base.set_v0_step_m_s(0.05);
  auto* o = base.mutable_task()->mutable_obstacle();
  o->set_x_min_m(1.0);
  o->set_x_max_m(1.2);
  o->set_height_m(0.2);
  expectEveryFieldGuarded(
      base,
      [&nominal](const pb::Message& m) -> std::string {
        try {
          toWarmRequest(static_cast<const v1::WarmCacheRequest&>(m), robot(), nominal);
        } catch (const ServiceError& e) {
          EXPECT_EQ(e.code(), ErrorCode::InvalidArgument) << e.what();
          return e.what();
        }
        return "";
      },
      9);  // task 3 + box 3 + grid 3
}

TEST(RequestValidation, ConvertsToTheJumpFrame) {
  v1::PlanJumpRequest r = test::standingRequest(0.0);
  // Heading 90 degrees left (yaw about z), pitched 0.2 rad nose-up, rolling at 2 m/s along the
  // heading with a lateral drift that v0 must ignore.
  const double yaw = M_PI / 2, pitch = 0.2;
  const Eigen::Quaterniond q = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) *
                               Eigen::AngleAxisd(-pitch, Eigen::Vector3d::UnitY());
  auto* o = r.mutable_state()->mutable_base_orientation_w();
  o->set_w(q.w());
  o->set_x(q.x());
  o->set_y(q.y());
  o->set_z(q.z());
  auto* v = r.mutable_state()->mutable_base_linear_velocity_w_m_s();
  v->set_x(0.3);
  v->set_y(2.0);
  r.mutable_state()->mutable_base_angular_velocity_b_rad_s()->set_y(-0.5);
  const PlanRequest p = toPlanRequest(r, robot());
  EXPECT_NEAR(p.initial.v0, 2.0, 1e-12);
  EXPECT_NEAR(p.initial.pitch, pitch, 1e-12);
  EXPECT_NEAR(p.initial.pitch_rate, 0.5, 1e-12);
  EXPECT_DOUBLE_EQ(p.initial.q[1], 1.0);
  EXPECT_DOUBLE_EQ(p.initial.q[2], -2.0);
  EXPECT_FALSE(p.max_evaluations.has_value());
  EXPECT_EQ(p.seed, 0u);
}

TEST(RequestValidation, WarmCacheGrid) {
  planner::InitialState nominal = toPlanRequest(test::standingRequest(0.0), robot()).initial;
  v1::WarmCacheRequest w;
  *w.mutable_task() = test::standingRequest(0.0).task();
  w.set_v0_min_m_s(0.0);
  w.set_v0_max_m_s(0.2);
  w.set_v0_step_m_s(0.05);
  const WarmRequest ok = toWarmRequest(w, robot(), nominal);
  ASSERT_EQ(ok.v0_grid.size(), 5u);
  EXPECT_DOUBLE_EQ(ok.v0_grid.back(), 0.2);
  const auto rejected = [&](const v1::WarmCacheRequest& bad) -> std::string {
    try {
      toWarmRequest(bad, robot(), nominal);
    } catch (const ServiceError& e) {
      return e.what();
    }
    return "";
  };
  v1::WarmCacheRequest bad = w;
  bad.set_v0_step_m_s(0.0);
  EXPECT_NE(rejected(bad).find("v0_step_m_s must be finite and in (0, 5]"), std::string::npos);
  bad.set_v0_step_m_s(6.0);
  EXPECT_NE(rejected(bad).find("v0_step_m_s must be finite and in (0, 5]"), std::string::npos);
  bad = w;
  bad.set_v0_max_m_s(3.4);
  bad.set_v0_min_m_s(-1.0);
  bad.set_v0_step_m_s(0.001);
  EXPECT_NE(rejected(bad).find("at most 1000 points"), std::string::npos);
  bad = w;
  bad.set_v0_max_m_s(-0.5);
  EXPECT_NE(rejected(bad).find("v0_max_m_s must be >= v0_min_m_s"), std::string::npos);
  bad = w;
  bad.set_v0_min_m_s(kNaN);
  EXPECT_NE(rejected(bad).find("v0_min_m_s must be finite and in [-1, 3.4]"), std::string::npos);
  bad = w;
  bad.clear_task();
  EXPECT_NE(rejected(bad).find("task is required"), std::string::npos);
}

}  // namespace
}  // namespace wj::server
