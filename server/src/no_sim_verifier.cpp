// Built when the sim component is absent: there is no verifier, and the service says so.
#include "server/plan_verifier.h"

namespace wj::server {

bool simVerifierAvailable() {
  return false;
}

std::unique_ptr<PlanVerifier> makeSimVerifier(const model::RobotModel& /*robot*/,
                                              const VerificationConfig& /*config*/) {
  return nullptr;
}

}  // namespace wj::server
