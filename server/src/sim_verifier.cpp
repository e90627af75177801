// The Simbody verifier of the sim component behind the PlanVerifier interface.
#include <bit>
#include <fstream>
#include <sstream>

#include "server/cache_key.h"
#include "server/plan_verifier.h"
#include "sim/executor_settings_file.h"
#include "sim/verifier.h"

namespace wj::server {

namespace {

class SimPlanVerifier final : public PlanVerifier {
 public:
  SimPlanVerifier(const model::RobotModel& robot, sim::VerifierSettings settings,
                  std::uint64_t settings_hash)
      : verifier_(robot, std::move(settings)), settings_hash_(settings_hash) {}

  std::string name() const override { return "simbody (wj::sim::Verifier)"; }

  VerifierVerdict verify(const planner::JumpPlan& plan,
                         const planner::JumpTask& task) const override {
    return toVerdict(verifier_.verify(plan, sim::scenarioForTask(task)));
  }

  std::optional<VerifierVerdict> verifyUnless(const planner::JumpPlan& plan,
                                              const planner::JumpTask& task,
                                              const std::atomic<bool>& stop) const override {
    const auto r = verifier_.verifyUnless(plan, sim::scenarioForTask(task), stop);
    if (!r) return std::nullopt;
    return toVerdict(*r);
  }

  static VerifierVerdict toVerdict(const sim::VerificationReport& r) {
    VerifierVerdict v;
    v.passed = r.passed;
    for (const sim::FailureReason f : r.failures.toVector())
      v.failure_bits |= 1u << static_cast<unsigned>(f);
    v.reasons = r.reasons;
    v.simulated = r.measured;
    v.max_envelope_ratio = r.max_envelope_ratio;
    v.landed_upright = r.landed_upright;
    return v;
  }

  std::vector<std::string> failureNames(std::uint32_t bits) const override {
    std::vector<std::string> out;
    for (int i = 0; i < sim::kNumFailureReasons; ++i)
      if (bits & (1u << static_cast<unsigned>(i)))
        out.emplace_back(sim::toString(static_cast<sim::FailureReason>(i)));
    return out;
  }

  std::uint64_t settingsHash() const override { return settings_hash_; }

 private:
  sim::Verifier verifier_;
  std::uint64_t settings_hash_;
};

std::string readFile(const std::string& path, const std::string& key) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("verification." + key + ": cannot open " + path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

}  // namespace

bool simVerifierAvailable() {
  return true;
}

std::unique_ptr<PlanVerifier> makeSimVerifier(const model::RobotModel& robot,
                                              const VerificationConfig& config) {
  sim::VerifierSettings settings;
  std::string sim_text;
  if (!config.sim_settings_file.empty()) {
    sim_text = readFile(config.sim_settings_file, "sim_settings_file");
    settings.sim = sim::parseSimSettings(sim_text, config.sim_settings_file);
  }
  // The robot client's executor (its gains decide how a plan flies, and so the verdict).
  std::string executor_text;
  if (!config.jump_executor_file.empty()) {
    executor_text = readFile(config.jump_executor_file, "jump_executor_file");
    settings.executor = sim::parseExecutorSettings(executor_text, config.jump_executor_file);
  }
  settings.model = config.sagittal_model ? sim::VerificationModel::SagittalWhenSymmetric
                                         : sim::VerificationModel::Full;
  settings.acceptance.max_apex_height_error_m = config.max_apex_height_error_m;
  settings.acceptance.max_touchdown_dx_error_m = config.max_touchdown_dx_error_m;
  settings.acceptance.max_touchdown_pitch_error_rad = config.max_touchdown_pitch_error_rad;
  // The sim's built-in defaults are covered by the version tag: bump it when they change.
  // v2: the executor lands with landing_kp 120 (was 60), which changes verdicts.
  // v3: the run ends once the robot has been at rest for settle_window_s (0.2 s).
  // v4: verification.sagittal_model (the sagittal model's figures differ from the full one's
  // by round-off).
  // v5: the executor's take-off wheel law (the tyre-corrected speed reference with a slip band,
  // session 17), which changes the simulated jumps and so the stored verdicts.
  // v6: the executor's take-off momentum feedback and flight gains 300 / 6 (session 20).
  // v7: the drives brake at their peak torque (the actuator file's `braking`; session 22).
  // v8: a hop at the start (a measured start state a few mm off the ground) is not the take-off
  // (session 24: such plans were refused with their apex 0.29 m "off").
  std::uint64_t h = fnv1a64("wj::sim::Verifier v8");
  h = fnv1a64(config.sagittal_model ? "sagittal" : "full", h);
  h = fnv1a64(sim_text, h);
  if (!executor_text.empty()) h = fnv1a64(executor_text, fnv1a64("jump_executor_file", h));
  for (const double x : {config.max_apex_height_error_m, config.max_touchdown_dx_error_m,
                         config.max_touchdown_pitch_error_rad}) {
    const auto bits = std::bit_cast<std::uint64_t>(x);
    h = fnv1a64(std::string_view(reinterpret_cast<const char*>(&bits), sizeof bits), h);
  }
  // The lift-off correction decides which plan a miss stores (hashed only when on, so that the
  // caches written without it stay valid).
  if (config.liftoff_correction_rounds > 0)
    h = fnv1a64("liftoff_correction_rounds " + std::to_string(config.liftoff_correction_rounds), h);
  return std::make_unique<SimPlanVerifier>(robot, std::move(settings), h);
}

}  // namespace wj::server
