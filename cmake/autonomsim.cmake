# autonomsim_test(NAME SOURCES src... LIBS lib... [PROPERTIES prop value...])
# One GoogleTest executable; its tests are registered with ctest one by one, with PROPERTIES if
# given. Tests run with the repository root as working directory so that they can name scenario
# files as users do.
function(autonomsim_test name)
  cmake_parse_arguments(ARG "" "" "SOURCES;LIBS;PROPERTIES" ${ARGN})
  add_executable(${name} ${ARG_SOURCES})
  target_link_libraries(${name} PRIVATE ${ARG_LIBS} autonomsim_flags GTest::gtest_main GTest::gmock)
  if(AUTONOMSIM_SANITIZE)
    # The tests' own code unoptimised under the sanitizers (still instrumented): it is half that
    # build's compile time (a unity batch of stack_tests: 58 s at -O1, 32 s at -O0), and the work
    # a test drives runs in the libraries, which keep -O1 (CI: build 576 -> 487 s, tests 184 ->
    # 188 s). Not in the release build: there it saved 25 s of building and cost 24 s of tests.
    target_compile_options(${name} PRIVATE -O0)
  endif()
  gtest_discover_tests(${name} WORKING_DIRECTORY ${PROJECT_SOURCE_DIR}
                       PROPERTIES ENVIRONMENT "AUTONOMSIM_BIN_DIR=${CMAKE_BINARY_DIR}/bin"
                       ${ARG_PROPERTIES} DISCOVERY_TIMEOUT 60)
endfunction()

# autonomsim_fuzzer(NAME SOURCES src... LIBS lib... SEEDS seeds [DICT dict] [TIMEOUT s])
# A libFuzzer target (<module>/fuzz/). SEEDS: a glob of shipped files, one input each, or a *.seeds
# file, one input per line; DICT: a libFuzzer dictionary, or CONFIG_KEYS for the config keys
# tools/fuzz.sh gathers; both relative to the source tree. TIMEOUT: the seconds one input may take
# in the fuzz build before it counts as a hang (default 10).
# - AUTONOMSIM_FUZZ (preset fuzz, clang): the libFuzzer executable, a member of fuzz_targets;
#   its line "NAME|SEEDS|DICT|TIMEOUT" goes to fuzz_targets.txt in the build folder, which
#   tools/fuzz.sh reads to seed and run it.
# - AUTONOMSIM_SANITIZE (preset asan, CI): the same code with tools/fuzz/replay_main.cc as its main
#   instead of libFuzzer, and the ctest test FuzzReplay.NAME feeding it every seed once under the
#   sanitizers.
# - Otherwise nothing.
# The target knows the source tree, for the shipped files it reads.
function(autonomsim_fuzzer name)
  cmake_parse_arguments(ARG "" "SEEDS;DICT;TIMEOUT" "SOURCES;LIBS" ${ARGN})
  if(NOT ARG_SEEDS)
    message(FATAL_ERROR "autonomsim_fuzzer(${name}): SEEDS is required")
  endif()
  if(NOT ARG_TIMEOUT)
    set(ARG_TIMEOUT 10)
  endif()
  if(AUTONOMSIM_FUZZ)
    add_executable(${name} ${ARG_SOURCES})
    target_link_options(${name} PRIVATE -fsanitize=fuzzer)
    add_dependencies(fuzz_targets ${name})
    set_property(GLOBAL APPEND PROPERTY AUTONOMSIM_FUZZ_TARGETS
                 "${name}|${ARG_SEEDS}|${ARG_DICT}|${ARG_TIMEOUT}")
  elseif(AUTONOMSIM_SANITIZE)
    add_executable(${name} ${ARG_SOURCES} ${PROJECT_SOURCE_DIR}/tools/fuzz/replay_main.cc)
    set(scratch ${CMAKE_BINARY_DIR}/fuzz-tmp)  # the file-reading targets' scratch folders
    file(MAKE_DIRECTORY ${scratch})
    add_test(NAME FuzzReplay.${name} COMMAND ${name} ${PROJECT_SOURCE_DIR}/${ARG_SEEDS}
             WORKING_DIRECTORY ${PROJECT_SOURCE_DIR})
    set_tests_properties(FuzzReplay.${name} PROPERTIES ENVIRONMENT "TMPDIR=${scratch}")
  else()
    return()
  endif()
  target_link_libraries(${name} PRIVATE ${ARG_LIBS} autonomsim_flags)
  target_compile_definitions(${name} PRIVATE AUTONOMSIM_SOURCE_DIR="${PROJECT_SOURCE_DIR}")
endfunction()

# fuzz_targets.txt in the build folder: the fuzz build's targets, one "NAME|SEEDS|DICT|TIMEOUT" a line
# (autonomsim_fuzzer), for tools/fuzz.sh. Called once, after every module.
function(autonomsim_write_fuzz_targets)
  if(NOT AUTONOMSIM_FUZZ)
    return()
  endif()
  get_property(lines GLOBAL PROPERTY AUTONOMSIM_FUZZ_TARGETS)
  list(JOIN lines "\n" text)
  file(WRITE ${CMAKE_BINARY_DIR}/fuzz_targets.txt "${text}\n")
endfunction()
