# Runs a caller of libmdr_c (COMMAND, a ;-list) and compares its standard output byte for byte
# with the service's reference (REFERENCE): the test of tests/capi's C, Fortran and Python callers.
separate_arguments(command UNIX_COMMAND "${COMMAND}")
execute_process(COMMAND ${command} OUTPUT_FILE ${OUTPUT} RESULT_VARIABLE result)
if(NOT result EQUAL 0)
  message(FATAL_ERROR "${COMMAND} failed: ${result}")
endif()
execute_process(COMMAND ${CMAKE_COMMAND} -E compare_files ${OUTPUT} ${REFERENCE}
  RESULT_VARIABLE different)
if(different)
  execute_process(COMMAND diff ${OUTPUT} ${REFERENCE} OUTPUT_VARIABLE diff_text)
  string(SUBSTRING "${diff_text}" 0 4000 diff_text)
  message(FATAL_ERROR "${OUTPUT} differs from the service's ${REFERENCE}:\n${diff_text}")
endif()
message(STATUS "${OUTPUT}: identical to the service's reference")
