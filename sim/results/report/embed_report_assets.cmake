# Writes OUT: a C++ file defining autonomsim::sim::report_assets::<name>[] as raw string literals
# of the report page's files. Called at build time with -DOUT=... -DDIR=... (sim/results/report)
# -DKINDS=... (the generated kinds.js, an absolute path).
set(assets
  "kHtml|report.html"
  "kCss|report.css"
  "kJs|report.js"
  "kKindsJs|${KINDS}"
  "kUplotJs|vendor/uplot/uPlot.iife.min.js"
  "kUplotCss|vendor/uplot/uPlot.min.css"
  "kIndexHtml|sweep_index.html")
set(delimiter "autonomsim_asset")
set(text "// Generated from sim/results/report/ by embed_report_assets.cmake; do not edit.\n")
string(APPEND text "#include \"sim/results/report/report_assets.h\"\n\n")
string(APPEND text "namespace autonomsim::sim::report_assets {\n\n")
foreach(asset IN LISTS assets)
  string(REPLACE "|" ";" parts "${asset}")
  list(GET parts 0 name)
  list(GET parts 1 file)
  if(IS_ABSOLUTE "${file}")
    file(READ "${file}" content)
  else()
    file(READ "${DIR}/${file}" content)
  endif()
  string(FIND "${content}" ")${delimiter}\"" clash)
  if(NOT clash EQUAL -1)
    message(FATAL_ERROR "${file} contains the raw string delimiter )${delimiter}\"")
  endif()
  string(APPEND text "extern const char ${name}[] = R\"${delimiter}(${content})${delimiter}\";\n\n")
endforeach()
string(APPEND text "}  // namespace autonomsim::sim::report_assets\n")
file(WRITE "${OUT}.tmp" "${text}")
file(RENAME "${OUT}.tmp" "${OUT}")
