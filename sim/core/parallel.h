// Parallelism across independent runs (ARCHITECTURE: one run is single-threaded; parallelism
// lives across runs). Used by `check --jobs` and sweeps.
#pragma once

#include <cstddef>
#include <functional>

namespace autonomsim::sim {

// Runs `body(i)` for every i in [0, n) on min(jobs, n) threads (the calling thread is one of
// them), each i exactly once, in no particular order. `body` must not throw (catch inside it).
void ParallelFor(std::size_t n, int jobs, const std::function<void(std::size_t)>& body);

}  // namespace autonomsim::sim
