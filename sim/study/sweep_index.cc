#include "sim/study/sweep_index.h"

#include <nlohmann/json.hpp>

#include "sim/results/report.h"
#include "sim/results/report/report_assets.h"

namespace autonomsim::sim {
namespace {}  // namespace

std::string SweepIndexHtml(const SweepIndexInput& input) {
  const nlohmann::json data = {{"title", input.title},
                               {"axis_keys", input.axis_keys},
                               {"columns", input.table->columns},
                               {"rows", input.table->rows},
                               {"links", input.links},
                               {"plots", input.plots},
                               {"failed", input.failed},
                               {"missing", input.missing}};
  std::string page = report_assets::kIndexHtml;
  ReplacePlaceholder(page, "@TITLE@", XmlEscape(input.title));
  ReplacePlaceholder(page, "/*@REPORT_CSS@*/", report_assets::kCss);
  ReplacePlaceholder(page, "@DATA@", JsonForScript(data));
  return page;
}

}  // namespace autonomsim::sim
