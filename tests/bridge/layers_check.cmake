# The layers base <- core <- analysis <- bridge <- service, capi <- clients, checked on the
# sources and on the binaries: a source includes no header of a layer above its own (nor of a
# sibling: the service and the C library never include each other), the physics and the bridge
# include no gRPC, and the binaries in BINARIES need no gRPC library.
# cmake -DSOURCE_DIR=<repository> -DBINARIES=<a;b> -P layers_check.cmake
set(forbidden_base "mdr/(core|analysis|bridge|service|client)/|mdr/v1/|mdr/mdr\\.h|grpc")
set(forbidden_core "mdr/(analysis|bridge|service|client)/|mdr/v1/|mdr/mdr\\.h|grpc")
set(forbidden_analysis "mdr/(bridge|service|client)/|mdr/v1/|mdr/mdr\\.h|grpc")
set(forbidden_bridge "mdr/(service|client)/|mdr/mdr\\.h|grpc")
set(forbidden_capi "mdr/(service|client)/|grpc")
set(forbidden_service "mdr/client/|mdr/mdr\\.h")
set(layer_dirs
  base server/base core server/core analysis server/analysis bridge server/bridge
  capi capi service server/service)

set(violations "")
list(LENGTH layer_dirs count)
math(EXPR last "${count} - 1")
foreach(i RANGE 0 ${last} 2)
  math(EXPR j "${i} + 1")
  list(GET layer_dirs ${i} layer)
  list(GET layer_dirs ${j} dir)
  file(GLOB_RECURSE sources "${SOURCE_DIR}/${dir}/*.h" "${SOURCE_DIR}/${dir}/*.cc")
  if(NOT sources)
    message(FATAL_ERROR "no sources found under ${SOURCE_DIR}/${dir}")
  endif()
  foreach(source IN LISTS sources)
    file(STRINGS "${source}" includes REGEX "^[ \t]*#[ \t]*include")
    foreach(line IN LISTS includes)
      if(line MATCHES "${forbidden_${layer}}")
        file(RELATIVE_PATH shown "${SOURCE_DIR}" "${source}")
        string(APPEND violations "\n  ${shown} (layer ${layer}): ${line}")
      endif()
    endforeach()
  endforeach()
endforeach()

foreach(binary IN LISTS BINARIES)
  execute_process(COMMAND readelf -d "${binary}" OUTPUT_VARIABLE dynamic RESULT_VARIABLE rc)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "readelf -d ${binary} failed (${rc})")
  endif()
  if(NOT dynamic MATCHES "NEEDED")
    message(FATAL_ERROR "readelf -d ${binary} lists no needed library: not a dynamic binary?")
  endif()
  if(dynamic MATCHES "\\[(libgrpc[^]]*|libgpr[^]]*)\\]")
    string(APPEND violations "\n  ${binary} needs ${CMAKE_MATCH_1}")
  endif()
endforeach()

if(violations)
  message(FATAL_ERROR "layering violated:${violations}")
endif()
message(STATUS "layers hold")
