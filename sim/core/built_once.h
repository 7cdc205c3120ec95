// What a run builds once per distinct key and shares, read-only, among its cars: a camera's ray
// table, a lane detector's tables. Keys are compared with ==; a run has a handful of distinct
// ones, so a list searched from the front is all it takes.
#pragma once

#include <memory>
#include <utility>
#include <vector>

namespace autonomsim::sim {

template <class Key, class Value>
class BuiltOnce {
 public:
  // The value built for `key`, or build() (a std::shared_ptr<const Value>) kept for it.
  template <class Build>
  std::shared_ptr<const Value> Get(const Key& key, Build build) {
    for (const auto& [built_key, value] : built_) {
      if (built_key == key) return value;
    }
    built_.emplace_back(key, build());
    return built_.back().second;
  }

 private:
  std::vector<std::pair<Key, std::shared_ptr<const Value>>> built_;
};

}  // namespace autonomsim::sim
