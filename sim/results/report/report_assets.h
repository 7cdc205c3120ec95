// The report page's files (sim/results/report/), embedded in the program at build time by
// embed_report_assets.cmake, so that `autonomsim report` needs nothing beside the binary.
#pragma once

namespace autonomsim::sim::report_assets {

extern const char kHtml[];       // report.html: the template (placeholders /*@...@*/ and @...@)
extern const char kCss[];        // report.css
extern const char kJs[];         // report.js
extern const char kKindsJs[];    // kinds.js: EVENT and FAULT, generated from sim/core/vocabulary.h
extern const char kUplotJs[];    // vendor/uplot/uPlot.iife.min.js
extern const char kUplotCss[];   // vendor/uplot/uPlot.min.css
extern const char kIndexHtml[];  // sweep_index.html: a sweep's index.html template

}  // namespace autonomsim::sim::report_assets
