// A sweep's index.html: its results table in the browser, sortable by any column, each run linking
// its replay report (sim/results/report.h), the plots below. Beside results.csv and plots/.
#pragma once

#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "sim/study/results_table.h"

namespace autonomsim::sim {

struct SweepIndexInput {
  std::string title;                   // the sweep's name
  std::vector<std::string> axis_keys;  // the varied keys
  const ResultsTable* table{nullptr};  // results.csv's rows
  // run id -> its report (or folder when it has none), relative to the index's folder
  std::map<std::string, std::string> links;
  std::vector<std::string> plots;  // plot files, relative to the index's folder
  std::size_t failed{0};           // runs with a failed expectation
  std::size_t missing{0};          // grid points without a complete run
};

// The page, self-contained but for the links and the plot images beside it.
std::string SweepIndexHtml(const SweepIndexInput& input);

}  // namespace autonomsim::sim
