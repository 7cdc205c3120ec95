#include "sim/study/sweep_index.h"

#include <nlohmann/json.hpp>

#include "sim/results/report.h"
#include "sim/results/report/report_assets.h"

namespace autonomsim::sim {
namespace {

std::string HtmlText(std::string text) {
  std::string out;
  for (char c : text) {
    if (c == '<') out += "&lt;";
    else if (c == '>') out += "&gt;";
    else if (c == '&') out += "&amp;";
    else out += c;
  }
  return out;
}

}  // namespace

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
  ReplacePlaceholder(page, "@TITLE@", HtmlText(input.title));
  ReplacePlaceholder(page, "/*@REPORT_CSS@*/", report_assets::kCss);
  ReplacePlaceholder(page, "@DATA@", JsonForScript(data));
  return page;
}

}  // namespace autonomsim::sim
