#include "sim/core/parallel.h"

#include <algorithm>
#include <atomic>
#include <thread>
#include <vector>

namespace autonomsim::sim {

void ParallelFor(std::size_t n, int jobs, const std::function<void(std::size_t)>& body) {
  std::atomic<std::size_t> next{0};
  auto worker = [&] {
    for (std::size_t i = next++; i < n; i = next++) body(i);
  };
  const std::size_t threads_wanted =
      std::min<std::size_t>(static_cast<std::size_t>(std::max(1, jobs)), n);
  std::vector<std::thread> threads;
  for (std::size_t t = 1; t < threads_wanted; ++t) threads.emplace_back(worker);
  worker();
  for (std::thread& t : threads) t.join();
}

}  // namespace autonomsim::sim
