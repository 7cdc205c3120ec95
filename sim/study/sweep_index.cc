#include "sim/study/sweep_index.h"

#include <nlohmann/json.hpp>

#include "sim/results/report.h"
#include "sim/results/report/report_assets.h"

namespace autonomsim::sim {

std::string SweepIndexHtml(const SweepIndexInput& input) {
  // the per-node columns, hidden until asked for: the metrics follow the fixed columns (index,
  // run_id, the varied keys, repeat, seed)
  std::vector<std::size_t> node_columns;
  const std::vector<std::string>& columns = input.table->columns;
  for (std::size_t c = input.axis_keys.size() + 4; c < columns.size(); ++c) {
    if (IsNodeColumn(columns[c])) node_columns.push_back(c);
  }
  const nlohmann::json data = {{"title", input.title},         {"node_columns", node_columns},
                               {"axis_keys", input.axis_keys}, {"columns", input.table->columns},
                               {"rows", input.table->rows},    {"links", input.links},
                               {"plots", input.plots},         {"failed", input.failed},
                               {"missing", input.missing}};
  std::string page = report_assets::kIndexHtml;
  ReplacePlaceholder(page, "@TITLE@", XmlEscape(input.title));
  ReplacePlaceholder(page, "/*@REPORT_CSS@*/", report_assets::kCss);
  ReplacePlaceholder(page, "@DATA@", JsonForScript(data));
  return page;
}

}  // namespace autonomsim::sim
