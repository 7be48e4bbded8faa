// A small job as the queue tests submit it: the spec the RPCs would have
// checked and a few bytes standing for the upload (queues never decode it).
#pragma once

#include <string>

#include "server/job.h"

namespace vpr::service {

inline JobSubmission test_submission(int priority = 0, const std::string& peer = "client-a",
                                     const std::string& label = "") {
  JobSubmission s;
  s.spec.set_target_vertices(1000);
  s.spec.set_priority(priority);
  s.spec.set_label(label);
  s.mesh = {'D', 'R', 'A', 'C', 'O', 1, 2, 3};
  s.client = peer;
  return s;
}

}  // namespace vpr::service
