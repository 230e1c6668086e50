# Installs BUILD_DIR into WORK_DIR/prefix, then configures, builds and runs SOURCE_DIR against
# that prefix only.
function(run step)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE code OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT code EQUAL 0)
    message(FATAL_ERROR "${step} failed (${code}):\n${out}\n${err}")
  endif()
  message(STATUS "${step}: ok\n${out}")
endfunction()

file(REMOVE_RECURSE ${WORK_DIR})
set(prefix ${WORK_DIR}/prefix)
run("install" ${CMAKE_COMMAND} --install ${BUILD_DIR} --prefix ${prefix})
foreach(installed include/mdr/client/contact_client.h include/mdr/v1/contact_service.grpc.pb.h
                  lib/cmake/mdr/mdrConfig.cmake)
  if(NOT EXISTS ${prefix}/${installed})
    message(FATAL_ERROR "not installed: ${installed}")
  endif()
endforeach()
# The Python package: installed where Debian's python3 looks for a package under this prefix
# (for the default prefix /usr/local that is on sys.path), and importable from there.
if(PYTHON_DIR)
  run("python package" /usr/bin/python3 -c
      "import site, sys; d = sys.argv[1]; assert d in site.getsitepackages([sys.argv[2]]), d; sys.path.insert(0, d); import mdr, mdr.v1.contact_service_pb2_grpc; assert mdr.__file__.startswith(d), mdr.__file__; print(mdr.__file__)"
      ${prefix}/${PYTHON_DIR} ${prefix})
endif()
run("configure" ${CMAKE_COMMAND} -S ${SOURCE_DIR} -B ${WORK_DIR}/build -G ${GENERATOR}
    -DCMAKE_BUILD_TYPE=Release -DCMAKE_PREFIX_PATH=${prefix})
run("build" ${CMAKE_COMMAND} --build ${WORK_DIR}/build)
run("run" ${WORK_DIR}/build/outside)
