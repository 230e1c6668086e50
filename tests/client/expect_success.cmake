# Runs COMMAND (a ;-list) and passes only if it exits with 0 AND its stdout matches every regex in
# REGEXES, which the file EXPECT sets (golden/*.cmake: one file per case, with the closed forms
# the numbers come from). PASS_REGULAR_EXPRESSION alone would ignore the exit code.
include(${EXPECT})
execute_process(COMMAND ${COMMAND} RESULT_VARIABLE exit_code OUTPUT_VARIABLE out
                ERROR_VARIABLE err)
if(NOT exit_code EQUAL 0)
  message(FATAL_ERROR "exit code ${exit_code}; stdout:\n${out}\nstderr:\n${err}")
endif()
foreach(regex IN LISTS REGEXES)
  if(NOT out MATCHES "${regex}")
    message(FATAL_ERROR "stdout does not match '${regex}':\n${out}")
  endif()
endforeach()
list(LENGTH REGEXES checks)
message(STATUS "${checks} checks passed")
