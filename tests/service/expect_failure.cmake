# Runs COMMAND (a ;-list) and passes only if it exits non-zero AND its stderr matches REGEX.
# (PASS_REGULAR_EXPRESSION alone would ignore the exit code.)
execute_process(COMMAND ${COMMAND} RESULT_VARIABLE exit_code OUTPUT_VARIABLE out
                ERROR_VARIABLE err)
if(exit_code EQUAL 0)
  message(FATAL_ERROR "expected a non-zero exit code; stdout:\n${out}\nstderr:\n${err}")
endif()
if(NOT err MATCHES "${REGEX}")
  message(FATAL_ERROR "stderr does not match '${REGEX}':\n${err}")
endif()
message(STATUS "exit code ${exit_code}, stderr: ${err}")
