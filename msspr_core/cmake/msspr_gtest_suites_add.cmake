# Run by ctest (included from the script msspr_gtest_suites() generates): lists the tests of
# ${_msspr_exe} and adds one ctest test per suite, or per case for ${_msspr_per_case}. A test
# all of whose cases were skipped (GTEST_SKIP: 0 passed) is reported as skipped.
cmake_policy(PUSH)
cmake_policy(SET CMP0057 NEW)  # if(... IN_LIST ...)
if(NOT EXISTS "${_msspr_exe}")
  add_test("${_msspr_prefix}NOT_BUILT" /bin/sh -c
           "echo '${_msspr_exe} is not built: make build builds it (the tests target)' >&2; exit 1")
  cmake_policy(POP)
  return()
endif()
execute_process(COMMAND "${_msspr_exe}" --gtest_list_tests
                WORKING_DIRECTORY "${_msspr_workdir}"
                OUTPUT_VARIABLE _msspr_out ERROR_VARIABLE _msspr_err RESULT_VARIABLE _msspr_rc
                TIMEOUT 120)
if(NOT _msspr_rc EQUAL 0)
  string(REPLACE "'" "" _msspr_err "${_msspr_err}")
  add_test("${_msspr_prefix}LIST_FAILED" /bin/sh -c
           "echo '${_msspr_exe} --gtest_list_tests exited ${_msspr_rc}: ${_msspr_err}' >&2; exit 1")
  cmake_policy(POP)
  return()
endif()

string(REPLACE ";" "," _msspr_out "${_msspr_out}")
string(REPLACE "\n" ";" _msspr_lines "${_msspr_out}")
set(_msspr_suite "")
set(_msspr_added "")  # the suite last added (gtest lists each suite once, its cases together)
foreach(_msspr_line IN LISTS _msspr_lines)
  string(REGEX REPLACE " +#.*$" "" _msspr_line "${_msspr_line}")  # "  # GetParam() = ..."
  if(_msspr_line MATCHES "^([A-Za-z_][A-Za-z0-9_/]*)\\.$")
    set(_msspr_suite "${CMAKE_MATCH_1}")
  elseif(_msspr_suite AND _msspr_line MATCHES "^  ([A-Za-z_][A-Za-z0-9_/]*)$")
    set(_msspr_case "${CMAKE_MATCH_1}")
    if(_msspr_suite MATCHES "(^|/)DISABLED_" OR _msspr_case MATCHES "^DISABLED_")
      continue()
    endif()
    if(_msspr_suite IN_LIST _msspr_per_case)
      set(_msspr_name "${_msspr_prefix}${_msspr_suite}.${_msspr_case}")
      add_test("${_msspr_name}" "${_msspr_exe}" "--gtest_filter=${_msspr_suite}.${_msspr_case}")
      set_tests_properties("${_msspr_name}" PROPERTIES COST 1000)
    elseif(NOT _msspr_suite STREQUAL _msspr_added)
      set(_msspr_added "${_msspr_suite}")
      set(_msspr_name "${_msspr_prefix}${_msspr_suite}")
      add_test("${_msspr_name}" "${_msspr_exe}" "--gtest_filter=${_msspr_suite}.*")
    else()
      continue()
    endif()
    set_tests_properties("${_msspr_name}" PROPERTIES WORKING_DIRECTORY "${_msspr_workdir}"
                         SKIP_REGULAR_EXPRESSION "\\[  PASSED  \\] 0 tests\\."
                         ${_msspr_props})
  endif()
endforeach()
cmake_policy(POP)
